// What every stage receives from the command line: threads, seed, verbosity,
// and where to send progress and log lines.
#pragma once

#include <cstdint>
#include <functional>
#include <string>

#include "solver/progress.h"

namespace shadowsg {

struct StageContext {
  int threads = 1;
  uint64_t seed = 0;
  bool quiet = false;
  // Makes a progress callback for one task (label shown before the bar).
  std::function<ProgressFn(const std::string& label)> progress;
  std::function<void(const std::string& line)> log;

  ProgressFn Progress(const std::string& label) const { return progress ? progress(label) : ProgressFn(); }
  void Log(const std::string& line) const {
    if (log && !quiet) log(line);
  }
  // Warnings are shown even with --quiet.
  void Warn(const std::string& line) const {
    if (log) log("warning: " + line);
  }
};

}  // namespace shadowsg
