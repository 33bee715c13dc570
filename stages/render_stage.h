// `shadowsg render`: the scene's view rendered by the path tracer under a
// given lighting file (lighting.json, a lights/1 JSON or an env-map .exr).
#pragma once

#include <filesystem>
#include <optional>

#include "calib/image.h"
#include "solver/lights.h"
#include "solver/metrics.h"
#include "solver/path_tracer.h"
#include "solver/scene.h"
#include "stages/stage_context.h"

namespace shadowsg {

struct RenderStageOptions {
  std::filesystem::path lighting;  // required
  std::filesystem::path out;       // OUT.exr; a tone-mapped OUT.png is written beside it
  PathTraceOptions trace;
  // Score the render against the scene's photograph on the shadow-plane
  // pixels (metrics.md): image.exr for casters, image_virtual_objs.exr
  // (plane pixels free of every object) when rendering all objects.
  bool compare = false;
};

struct RenderStageResult {
  Image image;
  std::optional<ImageMetrics> metrics;  // when compare was asked and possible
  double seconds = 0;                   // wall time of the render alone
};

RenderStageResult RunRenderStage(const std::filesystem::path& scene_dir, const RenderStageOptions& options,
                                 const StageContext& ctx);

// Scores `render` against the scene's photograph as RenderStageOptions::compare
// describes; nullopt when the scene holds no such photograph.
std::optional<ImageMetrics> CompareWithPhotograph(const Scene& scene, const Image& render, RenderObjects objects);

}  // namespace shadowsg
