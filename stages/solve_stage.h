// `shadowsg solve`: estimate a scene's lighting with one method and write the
// outputs of cli.md (lighting.json, envmap.exr, render.exr, metrics.json, PNGs).
#pragma once

#include <filesystem>
#include <string>

#include "stages/stage_context.h"

namespace shadowsg {

struct SolveOptions {
  std::string method = "sg";         // sg | sg-paper | ss03 | ss03+ | sh21
  int lobes = 0;                     // sg: 0 = chosen by the solver; sg-paper: initial lobes (256)
  std::string budget = "balanced";   // sg: fast | balanced | best
  int restarts = 0;                  // sg: fits from fresh pixels (0: the budget's)
  int steps = -1;                    // sg-paper: Adam steps (-1: the published 20000)
  int map_height = 16;               // baselines: map rows over the hemisphere
  bool estimate_albedo = false;      // sh21: estimate the plane albedo scale jointly
  std::string ssdf = "exact";        // exact | c2f (the reference's coarse-to-fine search)
  std::string visibility = "spheres";  // sg: spheres (sphere-tree sigmoid) | exact (ray-cast mesh, slower)
  bool score_exact = false;          // sg, sg-paper: also score the estimate rendered with exact visibility
  // sg: light the casters reflect onto the plane (solver/caster_bounce.h):
  // on | off | auto (fitted with and without, the lower held-out error kept).
  std::string bounce = "auto";

  // Message naming the bad option, or empty.
  std::string Validate() const;
};

void RunSolve(const std::filesystem::path& scene_dir, const std::filesystem::path& out_dir,
              const SolveOptions& options, const StageContext& ctx);

}  // namespace shadowsg
