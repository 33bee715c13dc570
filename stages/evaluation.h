// Scoring and writing a lighting estimate (cli.md "solve"/"eval" outputs,
// metrics.md): the re-rendered view, error map, env map, lighting file and
// metrics.json. Shared by every method so that all are scored the same way.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "solver/plane_pixels.h"
#include "solver/scene.h"
#include "solver/sg.h"
#include "solver/shadow_plane.h"
#include "stages/io/json_util.h"
#include "stages/stage_context.h"
#include "stages/stage_util.h"

namespace shadowsg {

struct LightingEstimate {
  std::string method;
  std::optional<SgLighting> sg;             // SG methods
  Image envmap;                             // every method: H x 2H radiance map
  std::vector<Eigen::Vector3f> plane_render;  // re-render at every plane pixel
  std::vector<Eigen::Vector3f> plane_bounce;  // SG with the casters' bounce: its share of plane_render
  int n_lobes = 0;                          // SG: lobes kept; maps: 0
  int n_params = 0;
  double solve_seconds = 0;
  Json extra = Json::object();              // method-specific report (summary, options)
};

// Height of the env maps written for SG estimates.
inline constexpr int kEnvMapOutputHeight = 256;

// Builds (or loads from the cache) the casters' sphere trees and the SG model
// of the plane pixels.
ShadowPlaneModel PrepareShadowPlane(Scene& scene, const std::filesystem::path& scene_dir, const PlanePixels& pixels,
                                    ShadingModel shading, const StageContext& ctx);

// Fills an SG estimate's render (every plane pixel), env map and sizes.
void CompleteSgEstimate(const ShadowPlaneModel& model, LightingEstimate* estimate);

// Full-size image with the plane render at plane pixels and 0 elsewhere.
Image PlaneRenderImage(const PlanePixels& pixels, const std::vector<Eigen::Vector3f>& values);

// Scores the estimate and writes lighting.json (SG), envmap.exr/.png,
// render.exr/.png, error.png and metrics.json (last, with total_seconds
// measured from `command_clock`). Returns metrics.json's content.
// insert_psnr / insert_ssim come from the preview composite
// (PreviewInsertionScores) when the scene has virtual objects and
// image_virtual_objs.exr and every object has a sphere tree
// (EnsureCompositeTrees).
Json ScoreAndWrite(const Scene& scene, const PlanePixels& pixels, const LightingEstimate& estimate,
                   const std::filesystem::path& out_dir, const Stopwatch& command_clock, const StageContext& ctx);

// Heat-map picture of |render - gt| (mean over channels) on plane pixels,
// scaled so that 10 % of the ground truth's range is full scale.
Image ErrorMap(const Image& render, const Image& gt, const Image& mask);

}  // namespace shadowsg
