// `shadowsg render SCENE_DIR --lighting FILE --out OUT.exr`: the scene's view
// rendered by the path tracer (solver/path_tracer.h).
#include <cstdio>

#include "calib/error.h"
#include "pipeline/cli_common.h"
#include "pipeline/commands.h"
#include "stages/render_stage.h"

namespace shadowsg {

void RegisterRenderCommand(CLI::App& app) {
  struct Options {
    CommonOptions common;
    std::string scene_dir, objects = "casters";
    RenderStageOptions render;
  };
  auto opt = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand("render", "Path-trace a scene's view under a lighting file");
  cmd->add_option("SCENE_DIR", opt->scene_dir, "Scene folder (scene.json and meshes; image.exr only for --compare)")
      ->required();
  cmd->add_option("--lighting", opt->render.lighting, "lighting.json, a lights/1 JSON or an env-map .exr")
      ->required();
  cmd->add_option("--out", opt->render.out, "Output .exr (a tone-mapped .png is written beside it)")->required();
  cmd->add_option("--spp", opt->render.trace.samples_per_pixel, "Samples per pixel")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--bounces", opt->render.trace.max_bounces, "Diffuse bounces after the first hit (0: direct only)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--objects", opt->objects, "casters (as image.exr), all (with virtual objects) or none (plane only)")
      ->check(CLI::IsMember({"casters", "all", "none"}))
      ->capture_default_str();
  cmd->add_flag("--compare", opt->render.compare,
                "Print PSNR/SSIM against the scene's image on the shadow-plane pixels (metrics.md)");
  AddCommonOptions(cmd, &opt->common);
  cmd->callback([opt] {
    const StageContext ctx = MakeContext(opt->common);
    opt->render.trace.seed = opt->common.seed;
    opt->render.trace.objects = opt->objects == "all"    ? RenderObjects::kAll
                                : opt->objects == "none" ? RenderObjects::kNone
                                                         : RenderObjects::kCasters;
    const RenderStageResult r = RunRenderStage(opt->scene_dir, opt->render, ctx);
    std::printf("wrote %s: %dx%d, %d spp, %d bounces, %.1f s on %d threads\n", opt->render.out.c_str(), r.image.width,
                r.image.height, opt->render.trace.samples_per_pixel, opt->render.trace.max_bounces, r.seconds,
                ctx.threads);
    if (opt->render.compare) {
      if (r.metrics)
        std::printf("vs photograph: psnr %.2f dB, ssim %.4f, rel_rmse %.4f over %zu plane pixels\n", r.metrics->psnr,
                    r.metrics->ssim, r.metrics->rel_rmse, r.metrics->pixels);
      else
        ctx.Warn("--compare: the scene has no photograph for these objects (or no plane pixels); nothing scored");
    }
  });
}

}  // namespace shadowsg
