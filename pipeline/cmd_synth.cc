// `shadowsg synth SPEC.json --out SCENE_DIR`: a synthetic registered scene
// with ground truth (stages/synth_stage.h; spec format in README.md).
#include <cstdio>

#include "pipeline/cli_common.h"
#include "pipeline/commands.h"
#include "stages/synth_stage.h"

namespace shadowsg {

void RegisterSynthCommand(CLI::App& app) {
  struct Options {
    CommonOptions common;
    std::string spec, out_dir;
    int spp = 0, bounces = -1;
    double scale = 1.0;
  };
  auto opt = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand("synth", "Render a synthetic scene folder with ground truth from a spec");
  cmd->add_option("SPEC", opt->spec, "Synth spec (JSON, README.md \"Synthetic scenes\")")->required();
  cmd->add_option("--out", opt->out_dir, "Scene folder to write")->required();
  cmd->add_option("--spp", opt->spp, "Samples per pixel (default: the spec's)")->check(CLI::PositiveNumber);
  cmd->add_option("--bounces", opt->bounces, "Diffuse bounces (default: the spec's)")->check(CLI::NonNegativeNumber);
  cmd->add_option("--scale", opt->scale, "Scale the spec's resolution (intrinsics follow)")
      ->check(CLI::Range(0.01, 16.0));
  AddCommonOptions(cmd, &opt->common);
  cmd->callback([opt, cmd] {
    const StageContext ctx = MakeContext(opt->common);
    SynthSpec spec = ReadSynthSpec(opt->spec);
    SynthOverrides over;
    if (opt->spp > 0) over.samples_per_pixel = opt->spp;
    if (opt->bounces >= 0) over.max_bounces = opt->bounces;
    if (cmd->count("--seed") > 0) over.seed = opt->common.seed;  // else the spec's seed
    over.resolution_scale = opt->scale;
    ApplyOverrides(over, &spec);
    const SynthResult r = RunSynthStage(spec, opt->out_dir, ctx);
    std::printf("wrote scene %s: %dx%d, %d spp, rendered in %.1f s on %d threads%s\n", opt->out_dir.c_str(),
                spec.camera.width, spec.camera.height, spec.trace.samples_per_pixel, r.render_seconds, ctx.threads,
                r.has_virtual_objects ? " (with image_virtual_objs.exr)" : "");
  });
}

}  // namespace shadowsg
