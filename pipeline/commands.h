// The subcommands of `shadowsg`. Each cmd_*.cc adds one subcommand (its
// options and the callback that runs the stage) to the app.
#pragma once

#include <CLI/CLI.hpp>

namespace shadowsg {

void RegisterInfoCommand(CLI::App& app);
void RegisterSolveCommand(CLI::App& app);
void RegisterEvalCommand(CLI::App& app);
void RegisterCompositeCommand(CLI::App& app);
void RegisterExportCommand(CLI::App& app);
void RegisterRenderCommand(CLI::App& app);
void RegisterSynthCommand(CLI::App& app);
void RegisterDemoCommand(CLI::App& app);
void RegisterSphereTreeCommand(CLI::App& app);
void RegisterIntrinsicsCommand(CLI::App& app);
void RegisterLinearizeCommand(CLI::App& app);
void RegisterPoseCommand(CLI::App& app);
void RegisterPlaneCommand(CLI::App& app);
void RegisterRegisterCommand(CLI::App& app);
void RegisterRunCommand(CLI::App& app);
void RegisterBenchCommand(CLI::App& app);

}  // namespace shadowsg
