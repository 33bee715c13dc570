// `shadowsg intrinsics --images DIR --board COLSxROWS --square SIZE --out camera.json`.
#include <cstdio>

#include "calib/error.h"
#include "pipeline/cli_common.h"
#include "pipeline/commands.h"
#include "stages/intrinsics_stage.h"

namespace shadowsg {

namespace {

// "9x6" -> 9, 6.
void ParseBoard(const std::string& text, int* cols, int* rows) {
  int c = 0, r = 0;
  char x = 0, extra = 0;
  if (std::sscanf(text.c_str(), "%d%c%d%c", &c, &x, &r, &extra) != 3 || (x != 'x' && x != 'X') || c < 2 || r < 2)
    throw InputError("--board", "expected COLSxROWS inner corners, e.g. 9x6, got \"" + text + "\"");
  *cols = c;
  *rows = r;
}

}  // namespace

void RegisterIntrinsicsCommand(CLI::App& app) {
  struct Options {
    CommonOptions common;
    IntrinsicsStageOptions stage;
    std::string board, detector = "sb";
  };
  auto opt = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand("intrinsics", "Calibrate the camera (K, k1 k2 p1 p2 k3) from checkerboard photos");
  cmd->add_option("--images", opt->stage.images, "Folder of checkerboard photos (.jpg .png .exr)")->required();
  cmd->add_option("--board", opt->board, "Inner corners COLSxROWS, e.g. 9x6 for a board of 10x7 squares")->required();
  cmd->add_option("--square", opt->stage.calibration.square, "Square side (any unit; only extrinsics use it)")
      ->capture_default_str();
  cmd->add_option("--out", opt->stage.out, "camera.json to write")->capture_default_str();
  cmd->add_option("--coverage", opt->stage.coverage, "Coverage picture (default: <out>_coverage.png)");
  cmd->add_option("--detector", opt->detector, "sb (findChessboardCornersSB) or classic (+cornerSubPix)")
      ->capture_default_str();
  cmd->add_flag("--fix-aspect", opt->stage.calibration.fix_aspect, "Force fx = fy");
  cmd->add_flag("--fix-principal-point", opt->stage.calibration.fix_principal_point, "Keep cx, cy at the image centre");
  cmd->add_flag("--zero-tangential", opt->stage.calibration.zero_tangential, "Force p1 = p2 = 0");
  cmd->add_flag("--fix-k3", opt->stage.calibration.fix_k3, "Force k3 = 0 (few or central views)");
  cmd->add_option("--max-view-rms", opt->stage.calibration.max_view_rms_px,
                  "Reject views above this RMS in px (0: automatic, 3x median and at least 0.5 px)")
      ->capture_default_str();
  cmd->add_option("--min-views", opt->stage.calibration.min_views, "Fewest views to calibrate from")
      ->capture_default_str();
  AddCommonOptions(cmd, &opt->common);
  cmd->callback([opt] {
    IntrinsicsStageOptions& s = opt->stage;
    ParseBoard(opt->board, &s.calibration.cols, &s.calibration.rows);
    if (opt->detector == "sb")
      s.detector = CornerDetector::kSectorBased;
    else if (opt->detector == "classic")
      s.detector = CornerDetector::kClassic;
    else
      throw InputError("--detector", "expected sb or classic, got \"" + opt->detector + "\"");
    const StageContext ctx = MakeContext(opt->common);
    const IntrinsicsStageResult r = RunIntrinsicsStage(s, ctx);
    const Camera& c = r.calibration.camera;
    std::printf("views        %d used, %zu rejected\n", r.calibration.UsedViews(),
                r.calibration.views.size() - r.calibration.UsedViews());
    std::printf("rms          %.4f px\n", r.calibration.rms_px);
    std::printf("K            fx %.3f  fy %.3f  cx %.3f  cy %.3f  (%dx%d)\n", c.fx, c.fy, c.cx, c.cy, c.width,
                c.height);
    std::printf("distortion   k1 %.5f  k2 %.5f  p1 %.5f  p2 %.5f  k3 %.5f\n", c.k1, c.k2, c.p1, c.p2, c.k3);
    std::printf("wrote        %s, %s\n", r.camera_json.string().c_str(), r.coverage_png.string().c_str());
  });
}

}  // namespace shadowsg
