// Options every subcommand has (cli.md): --threads, --seed, --quiet; and the
// StageContext built from them.
#pragma once

#include <CLI/CLI.hpp>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "stages/stage_context.h"

namespace shadowsg {

struct CommonOptions {
  int threads = 0;  // 0: all cores
  uint64_t seed = 0;
  bool quiet = false;
};

void AddCommonOptions(CLI::App* cmd, CommonOptions* options);
// Applies the thread count (OpenMP) and returns the context for stages.
StageContext MakeContext(const CommonOptions& options);

// Every subcommand registers itself with one of these (see main.cc).
using CommandRegistrar = std::function<void(CLI::App& app)>;

}  // namespace shadowsg
