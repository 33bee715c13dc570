// A one-line progress bar on stderr, redrawn at most 10 times a second; plain
// lines (no carriage returns) when stderr is not a terminal.
#pragma once

#include <chrono>
#include <mutex>
#include <string>

#include "solver/progress.h"

namespace shadowsg {

class ProgressBar {
 public:
  ProgressBar(std::string label, bool quiet);
  ~ProgressBar();
  void Update(double fraction, const std::string& status);
  void Finish();

 private:
  std::string label_;
  bool quiet_;
  bool tty_;
  bool finished_ = false;
  int last_percent_ = -1;
  std::chrono::steady_clock::time_point start_, last_draw_;
  std::mutex mutex_;
};

}  // namespace shadowsg
