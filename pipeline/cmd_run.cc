// `shadowsg run CAPTURE_DIR [--out DIR] [--force STAGE]...`: every capture
// stage, solve and composite on a capture folder described by capture.json
// (stages/run_stage.h), resuming where outputs are up to date.
#include <cstdio>

#include "pipeline/cli_common.h"
#include "pipeline/commands.h"
#include "stages/run_stage.h"

namespace shadowsg {

void RegisterRunCommand(CLI::App& app) {
  struct Options {
    CommonOptions common;
    RunCaptureOptions run;
    std::string capture;
  };
  auto opt = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand(
      "run", "A capture folder end to end (capture.json): intrinsics, linearize, plane, pose, register, solve, "
             "composite; stages whose outputs are up to date are skipped");
  cmd->add_option("CAPTURE_DIR", opt->capture, "Capture folder holding capture.json (or the capture.json itself)")
      ->required();
  cmd->add_option("--out", opt->run.out, "Output folder (default: CAPTURE_DIR/shadowsg)");
  cmd->add_option("--force", opt->run.force,
                  "Redo this stage even if up to date (repeatable; intrinsics, linearize, plane, pose, register, "
                  "solve, composite, or all); the stages after it follow");
  AddCommonOptions(cmd, &opt->common);
  cmd->callback([opt] {
    opt->run.capture = opt->capture;
    const RunCaptureResult r = RunCapture(opt->run, MakeContext(opt->common));
    std::fputs(FormatRunSummary(r).c_str(), stdout);
  });
}

}  // namespace shadowsg
