#include "stages/composite_stage.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "calib/error.h"
#include "stages/io/image_io.h"
#include "stages/io/lighting_io.h"
#include "stages/io/scene_io.h"
#include "stages/render_stage.h"
#include "stages/sphere_tree_stage.h"
#include "stages/stage_util.h"

namespace shadowsg {
namespace fs = std::filesystem;

namespace {

// The photo's 99th percentile (of each pixel's largest channel): the white
// point of every PNG the stage writes, so that they compare by eye.
float PhotoWhite(const Image& photo) {
  std::vector<float> v;
  v.reserve(photo.pixels());
  for (size_t p = 0; p < photo.pixels(); ++p) v.push_back(photo.rgb(p).maxCoeff());
  if (v.empty()) return 1.0f;
  auto k = v.begin() + static_cast<long>(0.99 * (v.size() - 1));
  std::nth_element(v.begin(), k, v.end());
  return *k > 0 && std::isfinite(*k) ? *k : 1.0f;
}

Image SideBySide(const Image& left, const Image& right, float white) {
  const Image a = ToneMap(left, white), b = ToneMap(right, white);
  Image out(a.width + b.width, std::max(a.height, b.height), 3);
  for (int y = 0; y < a.height; ++y)
    for (int x = 0; x < a.width; ++x) out.set_rgb(out.index(x, y), a.rgb(a.index(x, y)));
  for (int y = 0; y < b.height; ++y)
    for (int x = 0; x < b.width; ++x) out.set_rgb(out.index(a.width + x, y), b.rgb(b.index(x, y)));
  return out;
}

const char* QualityName(CompositeQuality q) { return q == CompositeQuality::kPreview ? "preview" : "final"; }

}  // namespace

void EnsureCompositeTrees(Scene& scene, const fs::path& scene_dir, const StageContext& ctx) {
  if (scene.VirtualObjects().empty()) return;
  for (auto& o : scene.objects) EnsureSphereTree(o, scene_dir, ctx);
}

std::optional<ImageMetrics> PreviewInsertionScores(const Scene& scene, const LightSet& lights,
                                                   const StageContext& ctx) {
  if (!scene.image_virtual_objs || scene.VirtualObjects().empty()) return std::nullopt;
  for (const auto& o : scene.objects)
    if (!o.sphere_tree) {
      ctx.Warn("insertion scores: " + o.mesh_path + " has no sphere tree; insert_psnr / insert_ssim left null");
      return std::nullopt;
    }
  CompositeOptions options;
  options.quality = CompositeQuality::kPreview;
  options.seed = ctx.seed;
  const CompositeResult r = CompositeVirtualObjects(scene, lights, options, ctx.Progress("insertion preview"));
  return CompareWithPhotograph(scene, r.composite, RenderObjects::kAll);
}

Json RunComposite(const fs::path& scene_dir, const fs::path& out_dir, const CompositeStageOptions& options,
                  const StageContext& ctx) {
  Stopwatch clock;
  CompositeOptions co = options.composite;
  co.seed = ctx.seed;
  std::string error;
  if (!co.IsValid(&error)) throw InputError("composite options", error);
  const LightSet lights = ReadLighting(options.lighting);
  if (lights.empty()) throw InputError(options.lighting.string(), "no lights in the lighting file");
  if (co.quality == CompositeQuality::kPreview && !lights.areas.empty())
    throw InputError(options.lighting.string(),
                     "the preview composites distant lighting only (SG, env maps, suns); use --quality final for "
                     "area lights");
  Scene scene = LoadScene(scene_dir);

  // The objects to insert.
  const bool own_objects = options.objects.empty();
  fs::path objects_dir = scene_dir;
  if (!own_objects) {
    std::vector<SceneObject> inserted = ReadObjectsFile(options.objects);
    std::erase_if(scene.objects, [](const SceneObject& o) { return !o.is_train; });
    for (auto& o : inserted) scene.objects.push_back(std::move(o));
    objects_dir = options.objects.parent_path();
  }
  const size_t n_virtual = scene.VirtualObjects().size();
  if (n_virtual == 0) ctx.Warn("composite: no virtual objects to insert; the composite is the photograph");
  if (co.quality == CompositeQuality::kPreview)
    for (auto& o : scene.objects) EnsureSphereTree(o, o.is_train ? scene_dir : objects_dir, ctx);
  ctx.Log("composite: " + scene.name + ", " + std::to_string(n_virtual) + " virtual objects, " +
          QualityName(co.quality) + " quality, " + std::to_string(ctx.threads) + " threads");

  EnsureOutputDir(out_dir);
  Stopwatch composite_clock;
  const CompositeResult r = CompositeVirtualObjects(scene, lights, co, ctx.Progress("composite"));
  const double composite_seconds = composite_clock.Seconds();

  Json m;
  m["method"] = "composite";
  m["quality"] = QualityName(co.quality);
  m["lighting"] = options.lighting.string();
  m["objects_file"] = own_objects ? Json(nullptr) : Json(options.objects.string());
  m["virtual_objects"] = n_virtual;
  m["insert_psnr"] = nullptr;
  m["insert_ssim"] = nullptr;
  m["insert_pixels"] = nullptr;
  if (own_objects && n_virtual > 0 && scene.image_virtual_objs) {
    if (const auto s = CompareWithPhotograph(scene, r.composite, RenderObjects::kAll)) {
      m["insert_psnr"] = s->psnr;
      m["insert_ssim"] = s->ssim;
      m["insert_pixels"] = s->pixels;
    }
  } else if (!own_objects && scene.image_virtual_objs) {
    ctx.Log("composite: --objects given; image_virtual_objs.exr shows the scene's own objects, so nothing is scored");
  }
  if (co.quality == CompositeQuality::kFinal) {
    m["spp"] = co.samples_per_pixel;
    m["bounces"] = co.max_bounces;
  } else {
    m["supersampling"] = co.supersampling;
    m["env_lobe_height"] = co.env_lobe_height;
    m["lobes"] = PreviewSgLighting(lights, co.env_lobe_height).lobes.size();
  }
  m["additive_channels"] = r.additive_channels;
  m["composite_seconds"] = composite_seconds;
  m["threads"] = ctx.threads;
  m["seed"] = ctx.seed;
  m["scene"] = scene.name;

  const float white = PhotoWhite(scene.image);
  WriteExrWithPreview(out_dir / "composite.exr", r.composite, white);
  WriteExr(out_dir / "shadow.exr", r.shadow);
  WriteExr(out_dir / "objects.exr", r.objects);
  WriteLdr(out_dir / "side_by_side.png", SideBySide(scene.image, r.composite, white));
  m["total_seconds"] = clock.Seconds();
  WriteJsonFile(out_dir / "metrics.json", m);

  char line[256];
  if (m["insert_psnr"].is_number())
    std::snprintf(line, sizeof line, "composite: insert psnr %.2f dB, ssim %.4f over %zu plane pixels, %.1f s",
                  m["insert_psnr"].get<double>(), m["insert_ssim"].get<double>(), m["insert_pixels"].get<size_t>(),
                  composite_seconds);
  else
    std::snprintf(line, sizeof line, "composite: %.1f s (nothing to score against)", composite_seconds);
  ctx.Log(line);
  ctx.Log("outputs in " + out_dir.string());
  return m;
}

}  // namespace shadowsg
