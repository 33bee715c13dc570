// shadowsg: lighting from shadows. One binary, one subcommand per stage.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <exception>
#if defined(__GLIBC__)
#include <malloc.h>
#endif

#include "calib/error.h"
#include "pipeline/commands.h"
#include "stages/io/atomic_file.h"

namespace {

// The solver allocates and frees matrices of 1-30 MB many times a second
// (dictionary columns, Jacobians, cone tables). glibc serves those by mmap
// and returns them on free, so each one faults its pages in again (12-35 %
// of the fit's set-up time in perf). Served from the heap and kept, they are
// reused: fast sunsky solve 1.99-2.33 s -> 1.85-1.96 s (2 threads, 3 runs
// each), peak memory 267 -> 290 MB.
void KeepFreedMemory() {
#if defined(__GLIBC__)
  mallopt(M_MMAP_THRESHOLD, 32 << 20);  // glibc's upper limit for this setting
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
#endif
}

}  // namespace

int main(int argc, char** argv) {
  using namespace shadowsg;
  KeepFreedMemory();
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
