// The subcommands of `shadowsg`. Each cmd_*.cc adds one subcommand (its
// options and the callback that runs the stage) to the app.
#pragma once

#include <CLI/CLI.hpp>

namespace shadowsg {

void RegisterInfoCommand(CLI::App& app);

}  // namespace shadowsg
