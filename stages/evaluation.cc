#include "stages/evaluation.h"

#include <algorithm>
#include <cmath>

#include "solver/metrics.h"
#include "stages/composite_stage.h"
#include "stages/io/image_io.h"
#include "stages/io/lighting_io.h"
#include "stages/sphere_tree_stage.h"

namespace shadowsg {
namespace fs = std::filesystem;

ShadowPlaneModel PrepareShadowPlane(Scene& scene, const fs::path& scene_dir, const PlanePixels& pixels,
                                    ShadingModel shading, const StageContext& ctx) {
  for (auto& obj : scene.objects)
    if (obj.is_train) EnsureSphereTree(obj, scene_dir, ctx);
  return MakeShadowPlaneModel(scene, pixels, shading);
}

void CompleteSgEstimate(const ShadowPlaneModel& model, LightingEstimate* est) {
  est->plane_render = RenderShadowPlane(model, *est->sg, &est->plane_bounce);
  est->envmap = SgToEnvMap(*est->sg, kEnvMapOutputHeight);
  est->n_lobes = static_cast<int>(est->sg->lobes.size());
  est->n_params = 6 * est->n_lobes;
}

Image PlaneRenderImage(const PlanePixels& pixels, const std::vector<Eigen::Vector3f>& values) {
  Image img(pixels.width, pixels.height, 3);
  for (size_t k = 0; k < pixels.size(); ++k) img.set_rgb(pixels.pixel[k], values[k].cwiseMax(0.0f));
  return img;
}

Image ErrorMap(const Image& render, const Image& gt, const Image& mask) {
  float range = 0;
  for (size_t p = 0; p < gt.pixels(); ++p)
    if (mask.data[p]) range = std::max(range, gt.rgb(p).maxCoeff());
  const float full = 0.1f * (range > 0 ? range : 1.0f);
  Image out(gt.width, gt.height, 3);
  for (size_t p = 0; p < gt.pixels(); ++p) {
    if (!mask.data[p]) {
      out.set_rgb(p, Eigen::Vector3f::Constant(0.15f));  // grey: not scored
      continue;
    }
    const float e = std::clamp((render.rgb(p).cwiseMax(0.0f) - gt.rgb(p)).cwiseAbs().mean() / full, 0.0f, 1.0f);
    // Black -> red -> yellow -> white.
    out.set_rgb(p, Eigen::Vector3f(std::min(1.0f, 3 * e), std::clamp(3 * e - 1, 0.0f, 1.0f),
                                   std::clamp(3 * e - 2, 0.0f, 1.0f)));
  }
  return out;
}

Json ScoreAndWrite(const Scene& scene, const PlanePixels& pixels, const LightingEstimate& est, const fs::path& out,
                   const Stopwatch& clock, const StageContext& ctx) {
  EnsureOutputDir(out);
  const Image mask = PlanePixelMask(pixels);
  const Image render = PlaneRenderImage(pixels, est.plane_render);
  const ImageMetrics im = CompareImages(render, scene.image, mask);

  Json m;
  m["method"] = est.method;
  m["psnr"] = im.psnr;
  m["ssim"] = im.ssim;
  m["rel_rmse"] = im.rel_rmse;
  m["env_angular_error_deg"] = nullptr;
  m["irradiance_rel_rmse"] = nullptr;
  if (scene.env_gt && !est.envmap.empty()) {
    const EnvMetrics em = CompareEnvMaps(est.envmap, *scene.env_gt);
    m["env_angular_error_deg"] = em.angular_error_deg;
    m["irradiance_rel_rmse"] = em.irradiance_rel_rmse;
  }
  m["insert_psnr"] = nullptr;
  m["insert_ssim"] = nullptr;
  {
    // Insertion scores: the preview composite of the scene's virtual objects
    // (stages/composite_stage.h), when the scene has their ground truth.
    LightSet lights;
    if (est.sg) lights.sg = est.sg;
    else if (!est.envmap.empty()) lights.env = est.envmap;
    if (!lights.empty())
      if (const auto insert = PreviewInsertionScores(scene, lights, ctx)) {
        m["insert_psnr"] = insert->psnr;
        m["insert_ssim"] = insert->ssim;
      }
  }
  m["n_lobes"] = est.n_lobes;
  m["n_params"] = est.n_params;
  m["solve_seconds"] = est.solve_seconds;
  m["threads"] = ctx.threads;
  m["plane_pixels"] = pixels.size();
  m["scene"] = scene.name;
  if (!est.extra.empty()) m["report"] = est.extra;

  if (est.sg) {
    WriteSgLighting(out / "lighting.json", *est.sg);
  } else if (fs::exists(out / "lighting.json")) {
    // Left as it was (nothing written is removed), but a script reading the
    // folder would take it for this method's lighting.
    ctx.Warn((out / "lighting.json").string() + " is from an earlier solve: " + est.method +
             " writes envmap.exr, not an SG lighting file");
  }
  if (!est.envmap.empty()) WriteExrWithPreview(out / "envmap.exr", est.envmap);
  // One exposure for render and photo so the previews compare by eye.
  float white = 0;
  for (int p : pixels.pixel) white = std::max(white, scene.image.rgb(p).maxCoeff());
  WriteExrWithPreview(out / "render.exr", render, white);
  WriteLdr(out / "error.png", ErrorMap(render, scene.image, mask));
  m["total_seconds"] = clock.Seconds();
  WriteJsonFile(out / "metrics.json", m);
  return m;
}

}  // namespace shadowsg
