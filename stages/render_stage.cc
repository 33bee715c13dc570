#include "stages/render_stage.h"

#include "calib/error.h"
#include "solver/plane_pixels.h"
#include "stages/io/image_io.h"
#include "stages/io/lighting_io.h"
#include "stages/io/scene_io.h"
#include "stages/stage_util.h"

namespace shadowsg {

std::optional<ImageMetrics> CompareWithPhotograph(const Scene& scene, const Image& render, RenderObjects objects) {
  const Image* gt = nullptr;
  std::vector<const SceneObject*> blockers;
  switch (objects) {
    case RenderObjects::kNone:
    case RenderObjects::kCasters:
      gt = scene.image.empty() ? nullptr : &scene.image;
      blockers = scene.Casters();
      break;
    case RenderObjects::kAll:
      gt = scene.image_virtual_objs ? &*scene.image_virtual_objs : nullptr;
      for (const auto& o : scene.objects) blockers.push_back(&o);
      break;
  }
  if (!gt) return std::nullopt;
  const PlanePixels pixels = FindPlanePixels(scene, BuildRayCaster(blockers));
  if (pixels.size() == 0) return std::nullopt;
  return CompareImages(render, *gt, PlanePixelMask(pixels));
}

RenderStageResult RunRenderStage(const std::filesystem::path& scene_dir, const RenderStageOptions& options,
                                 const StageContext& ctx) {
  std::string error;
  if (!options.trace.IsValid(&error)) throw InputError("render options", error);
  if (options.out.extension() != ".exr") throw InputError(options.out.string(), "output must be an .exr file");
  SceneLoadOptions load;
  load.require_image = options.compare;
  load.load_extras = options.compare;
  const Scene scene = LoadScene(scene_dir, load);
  const LightSet lights = ReadLighting(options.lighting);
  if (options.out.has_parent_path()) EnsureOutputDir(options.out.parent_path());

  RenderStageResult result;
  const Stopwatch clock;
  result.image = RenderPathTraced(scene, lights, options.trace, ctx.Progress("render"));
  result.seconds = clock.Seconds();
  WriteExrWithPreview(options.out, result.image);
  if (options.compare) result.metrics = CompareWithPhotograph(scene, result.image, options.trace.objects);
  return result;
}

}  // namespace shadowsg
