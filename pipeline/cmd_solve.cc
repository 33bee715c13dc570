// `shadowsg solve SCENE_DIR --out DIR [--method M] [--lobes N] [--budget B]`.
#include "pipeline/cli_common.h"
#include "pipeline/commands.h"
#include "stages/solve_stage.h"

namespace shadowsg {

void RegisterSolveCommand(CLI::App& app) {
  struct Options {
    CommonOptions common;
    std::string scene_dir, out_dir;
    SolveOptions solve;
  };
  auto opt = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand("solve", "Estimate the lighting of a registered scene from its shadows");
  cmd->add_option("SCENE_DIR", opt->scene_dir, "Registered scene folder")->required();
  cmd->add_option("--out", opt->out_dir, "Output folder")->required();
  cmd->add_option("--method", opt->solve.method, "sg (default), sg-paper, ss03, ss03+ or sh21")->capture_default_str();
  cmd->add_option("--lobes", opt->solve.lobes, "sg: force N lobes (0: chosen by the solver); sg-paper: initial lobes");
  cmd->add_option("--budget", opt->solve.budget, "sg: fast, balanced or best")->capture_default_str();
  cmd->add_option("--restarts", opt->solve.restarts,
                  "sg: fits from fresh pixels, pooled into one more fit; the best judged one kept "
                  "(default: fast 1, balanced 3, best 6)")
      ->check(CLI::Range(0, 100));
  cmd->add_option("--steps", opt->solve.steps, "sg-paper: Adam steps (default 20000, as published)");
  cmd->add_option("--map-height", opt->solve.map_height, "ss03/ss03+/sh21: map rows over the hemisphere")
      ->capture_default_str();
  cmd->add_flag("--estimate-albedo", opt->solve.estimate_albedo, "sh21: estimate the plane albedo jointly");
  cmd->add_option("--ssdf", opt->solve.ssdf, "Occluder search: exact (branch and bound) or c2f (reference's top-3)")
      ->capture_default_str();
  cmd->add_option("--visibility", opt->solve.visibility,
                  "sg: spheres (sphere-tree sigmoid, fast) or exact (ray-cast mesh visibility, slower)")
      ->capture_default_str();
  cmd->add_option("--bounce", opt->solve.bounce,
                  "sg: light the object reflects onto the plane: auto (fitted with and without, the better held-out "
                  "kept), on or off")
      ->capture_default_str();
  cmd->add_flag("--score-exact", opt->solve.score_exact,
                "sg, sg-paper: also score the estimate rendered with exact (ray-cast) visibility");
  AddCommonOptions(cmd, &opt->common);
  cmd->callback([opt] { RunSolve(opt->scene_dir, opt->out_dir, opt->solve, MakeContext(opt->common)); });
}

}  // namespace shadowsg
