// `shadowsg demo [--out demo-out] [--quick]`: synthesises the bundled sample
// scene (data/sample: Spot the cow, CC0), estimates its lighting with `sg`,
// and says where to look.
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <vector>

#include "calib/error.h"
#include "pipeline/cli_common.h"
#include "pipeline/commands.h"
#include "pipeline/sample_data.h"
#include "stages/solve_stage.h"
#include "stages/stage_util.h"
#include "stages/synth_stage.h"

namespace shadowsg {
namespace fs = std::filesystem;

namespace {

// --quick: half the resolution and a quarter of the samples (~8x faster).
constexpr double kQuickScale = 0.5;
constexpr int kQuickSppDivisor = 4;

}  // namespace

void RegisterDemoCommand(CLI::App& app) {
  struct Options {
    CommonOptions common;
    std::string out_dir = "demo-out";
    bool quick = false;
  };
  auto opt = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand("demo", "Synthesise the bundled sample scene and show where to look");
  cmd->add_option("--out", opt->out_dir, "Output folder")->capture_default_str();
  cmd->add_flag("--quick", opt->quick, "Half resolution, a quarter of the samples");
  AddCommonOptions(cmd, &opt->common);
  cmd->callback([opt, cmd] {
    const StageContext ctx = MakeContext(opt->common);
    const Stopwatch clock;
    const fs::path spec_path = FindSampleSpec();
    SynthSpec spec = ReadSynthSpec(spec_path);
    SynthOverrides over;
    if (opt->quick) {
      over.resolution_scale = kQuickScale;
      over.samples_per_pixel = std::max(1, spec.trace.samples_per_pixel / kQuickSppDivisor);
    }
    if (cmd->count("--seed") > 0) over.seed = opt->common.seed;
    ApplyOverrides(over, &spec);
    const fs::path out = opt->out_dir;
    EnsureOutputDir(out);
    const fs::path scene_dir = out / "scene";
    ctx.Log("demo: synthesising " + spec_path.string() + " into " + scene_dir.string());
    const SynthResult r = RunSynthStage(spec, scene_dir, ctx);
    const fs::path solve_dir = out / "solve";
    SolveOptions solve;
    solve.budget = opt->quick ? "fast" : "balanced";
    ctx.Log("demo: estimating the lighting (sg, " + solve.budget + ") into " + solve_dir.string());
    RunSolve(scene_dir, solve_dir, solve, ctx);
    const std::string s = scene_dir.string();
    const std::string so = solve_dir.string();
    std::printf("shadowsg demo: Spot the cow on a ground plane under a sun and a sky, %dx%d, %d spp,\n"
                "done in %.1f s on %d threads. Look at:\n",
                spec.camera.width, spec.camera.height, spec.trace.samples_per_pixel, clock.Seconds(), ctx.threads);
    std::printf("  %s/image.png                the synthetic photograph (tone-mapped image.exr)\n", s.c_str());
    if (r.has_virtual_objects)
      std::printf("  %s/image_virtual_objs.png   the same view with the virtual object (insertion ground truth)\n",
                  s.c_str());
    std::printf("  %s/env_gt.png               the true lighting as an environment map (env_gt.exr)\n", s.c_str());
    std::printf("  %s/scene.json               camera, plane and objects (scene-format.md); lights.json: the lights\n",
                s.c_str());
    std::printf("  %s/render.png               the shadow plane re-rendered from the estimated lighting\n", so.c_str());
    std::printf("  %s/error.png                where it differs from the photograph (10 %% of the range = white)\n",
                so.c_str());
    std::printf("  %s/envmap.png               the estimated lighting (lighting.json: its lobes)\n", so.c_str());
    std::printf("  %s/metrics.json             PSNR, SSIM, env-map errors, lobes, seconds\n", so.c_str());
  });
}

}  // namespace shadowsg
