// `shadowsg composite SCENE_DIR --lighting FILE --out DIR [--objects FILE]`:
// inserts the scene's virtual objects ("is_train": false), or those of an
// objects file, into the photograph by differential rendering
// (solver/compositor.h) and writes
//   composite.exr / composite.png   the result (PNG at the photo's exposure)
//   shadow.exr                      L_with / L_without: the shadow layer
//   objects.exr                     premultiplied RGBA object layer
//   side_by_side.png                photo | composite, one exposure
//   metrics.json                    insert_psnr / insert_ssim (metrics.md) when
//                                   the scene has image_virtual_objs.exr and its
//                                   own virtual objects are inserted; null otherwise
#pragma once

#include <filesystem>
#include <optional>

#include "solver/compositor.h"
#include "solver/lights.h"
#include "solver/metrics.h"
#include "solver/scene.h"
#include "stages/io/json_util.h"
#include "stages/stage_context.h"

namespace shadowsg {

struct CompositeStageOptions {
  std::filesystem::path lighting;  // lighting.json, an env-map .exr or a lights/1 JSON
  std::filesystem::path objects;   // optional objects file (scene_io.h ReadObjectsFile)
  CompositeOptions composite;      // quality, samples, ... (seed: the context's)
};

// Runs the stage; returns metrics.json's content.
Json RunComposite(const std::filesystem::path& scene_dir, const std::filesystem::path& out_dir,
                  const CompositeStageOptions& options, const StageContext& ctx);

// Gives every object of a scene with virtual objects a sphere tree
// (EnsureSphereTree: loaded, cached or built), as the preview composite needs.
void EnsureCompositeTrees(Scene& scene, const std::filesystem::path& scene_dir, const StageContext& ctx);

// Insertion scores of solve and eval (metrics.md, "Virtual-object insertion"):
// the preview composite of the scene's virtual objects under `lights`, scored
// against image_virtual_objs.exr on the plane pixels no object covers.
// nullopt (and a warning when it is because of a missing tree) when the scene
// has no virtual objects, no image_virtual_objs.exr, or an object has no
// sphere tree (call EnsureCompositeTrees first).
std::optional<ImageMetrics> PreviewInsertionScores(const Scene& scene, const LightSet& lights,
                                                   const StageContext& ctx);

}  // namespace shadowsg
