// `shadowsg composite SCENE_DIR --lighting FILE --out DIR [--objects FILE]`:
// virtual objects inserted by differential rendering (stages/composite_stage.h).
#include "pipeline/cli_common.h"
#include "pipeline/commands.h"
#include "stages/composite_stage.h"

namespace shadowsg {

void RegisterCompositeCommand(CLI::App& app) {
  struct Options {
    CommonOptions common;
    std::string scene_dir, out_dir, quality = "final";
    CompositeStageOptions stage;
  };
  auto opt = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand(
      "composite", "Insert virtual objects into the photograph under a lighting estimate (differential rendering)");
  cmd->add_option("SCENE_DIR", opt->scene_dir, "Registered scene folder")->required();
  cmd->add_option("--lighting", opt->stage.lighting, "lighting.json (SG), an env-map .exr or a lights/1 JSON")
      ->required();
  cmd->add_option("--out", opt->out_dir, "Output folder")->required();
  cmd->add_option("--objects", opt->stage.objects,
                  "Objects file (\"objects/1\": entries as scene.json's) to insert instead of the scene's virtual "
                  "objects");
  cmd->add_option("--quality", opt->quality,
                  "final (path tracer, Embree visibility) or preview (closed-form SG, sphere-tree visibility)")
      ->check(CLI::IsMember({"final", "preview"}))
      ->capture_default_str();
  cmd->add_option("--spp", opt->stage.composite.samples_per_pixel, "final: samples per pixel of each render")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--bounces", opt->stage.composite.max_bounces, "final: diffuse bounces after the first hit")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--supersampling", opt->stage.composite.supersampling,
                  "preview: N x N rays per pixel for the object matte (1 to 16)")
      ->capture_default_str();
  cmd->add_option("--env-lobe-height", opt->stage.composite.env_lobe_height,
                  "preview: env maps become one SG lobe per texel of an H x 2H map (2 to 64)")
      ->capture_default_str();
  AddCommonOptions(cmd, &opt->common);
  cmd->callback([opt] {
    opt->stage.composite.quality = opt->quality == "preview" ? CompositeQuality::kPreview : CompositeQuality::kFinal;
    RunComposite(opt->scene_dir, opt->out_dir, opt->stage, MakeContext(opt->common));
  });
}

}  // namespace shadowsg
