// shadowsg: lighting from shadows. One binary, one subcommand per stage.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <exception>

#include "calib/error.h"
#include "pipeline/commands.h"
#include "pipeline/heap.h"
#include "stages/io/atomic_file.h"

int main(int argc, char** argv) {
  using namespace shadowsg;
  KeepFreedMemory();
  AskHugePagesForTheHeap();
  CLI::App app{"shadowsg: recover lighting from the shadows an object casts on a plane, and insert "
               "virtual objects with matching shadows."};
  app.require_subcommand(1);
  app.set_version_flag("--version", "shadowsg 0.1.0");
  RegisterInfoCommand(app);
  RegisterSolveCommand(app);
  RegisterEvalCommand(app);
  RegisterCompositeCommand(app);
  RegisterExportCommand(app);
  RegisterRenderCommand(app);
  RegisterSynthCommand(app);
  RegisterDemoCommand(app);
  RegisterSphereTreeCommand(app);
  RegisterIntrinsicsCommand(app);
  RegisterLinearizeCommand(app);
  RegisterPoseCommand(app);
  RegisterPlaneCommand(app);
  RegisterRegisterCommand(app);
  RegisterRunCommand(app);
  RegisterBenchCommand(app);

  InstallInterruptHandlers();
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const InputError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  } catch (const Interrupted&) {
    std::fprintf(stderr, "error: interrupted; finished outputs are intact, unfinished ones were not written\n");
    return 130;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}
