// `shadowsg eval`: score a given lighting (lighting.json or an env-map EXR) on
// a scene, with the same metrics and outputs as solve (metrics.md).
#pragma once

#include <filesystem>
#include <string>

#include "stages/stage_context.h"

namespace shadowsg {

struct EvalOptions {
  // How SG lighting is rendered: "sg" (exact cosine, capped occlusion: the
  // model `--method sg` fits) or "paper" (the paper's cosine SG and sigmoid).
  std::string sg_model = "sg";
  std::string visibility = "spheres";  // SG: spheres (the model's sigmoid) | exact (ray-cast mesh)
  bool bounce = false;                 // SG, sg model: add the light the casters reflect onto the plane
  // Env maps are rendered through the baselines' light transport (ray-cast
  // mesh visibility) at this many rows over the hemisphere.
  int map_height = 16;
  std::string Validate() const;
};

void RunEval(const std::filesystem::path& scene_dir, const std::filesystem::path& lighting_file,
             const std::filesystem::path& out_dir, const EvalOptions& options, const StageContext& ctx);

}  // namespace shadowsg
