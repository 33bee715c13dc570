// `shadowsg eval SCENE_DIR --lighting FILE --out DIR`.
#include "pipeline/cli_common.h"
#include "pipeline/commands.h"
#include "stages/eval_stage.h"

namespace shadowsg {

void RegisterEvalCommand(CLI::App& app) {
  struct Options {
    CommonOptions common;
    std::string scene_dir, lighting, out_dir;
    EvalOptions eval;
  };
  auto opt = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand("eval", "Score a lighting file (lighting.json or env-map EXR) on a scene");
  cmd->add_option("SCENE_DIR", opt->scene_dir, "Registered scene folder")->required();
  cmd->add_option("--lighting", opt->lighting, "lighting.json (SG) or an equirectangular .exr")->required();
  cmd->add_option("--out", opt->out_dir, "Output folder")->required();
  cmd->add_option("--sg-model", opt->eval.sg_model, "SG rendering: sg (exact cosine, capped occlusion) or paper")
      ->capture_default_str();
  cmd->add_option("--map-height", opt->eval.map_height, "Env maps: rows over the hemisphere for the transport")
      ->capture_default_str();
  cmd->add_option("--visibility", opt->eval.visibility,
                  "SG rendering: spheres (sphere-tree sigmoid) or exact (ray-cast mesh visibility)")
      ->capture_default_str();
  cmd->add_flag("--bounce", opt->eval.bounce,
                "SG, --sg-model sg: add the light the object reflects onto the plane (as solve's report.bounce)");
  AddCommonOptions(cmd, &opt->common);
  cmd->callback([opt] { RunEval(opt->scene_dir, opt->lighting, opt->out_dir, opt->eval, MakeContext(opt->common)); });
}

}  // namespace shadowsg
