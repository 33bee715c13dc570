#include "stages/eval_stage.h"

#include <cstdio>

#include "calib/error.h"
#include "solver/envmap.h"
#include "solver/exact_visibility.h"
#include "solver/light_transport.h"
#include "solver/plane_pixels.h"
#include "solver/shadow_plane.h"
#include "stages/composite_stage.h"
#include "stages/evaluation.h"
#include "stages/io/lighting_io.h"
#include "stages/io/scene_io.h"
#include "stages/stage_util.h"

namespace shadowsg {
namespace fs = std::filesystem;

std::string EvalOptions::Validate() const {
  if (sg_model != "sg" && sg_model != "paper") return "--sg-model: expected sg or paper";
  if (map_height < 1 || map_height > 32) return "--map-height: expected 1 to 32 rows";
  if (visibility != "spheres" && visibility != "exact") return "--visibility: expected spheres or exact";
  if (bounce && sg_model != "sg") return "--bounce: only with --sg-model sg (the paper's model is direct light only)";
  return "";
}

void RunEval(const fs::path& scene_dir, const fs::path& lighting_file, const fs::path& out_dir,
             const EvalOptions& o, const StageContext& ctx) {
  Stopwatch clock;
  if (const std::string e = o.Validate(); !e.empty()) throw InputError("", e);
  const LightSet lights = ReadLighting(lighting_file);
  if (!lights.suns.empty() || !lights.areas.empty())
    throw InputError(lighting_file.string(), "eval scores distant lighting (SG or env map), not analytic lights");
  Scene scene = LoadScene(scene_dir);
  const RayCaster casters = BuildRayCaster(scene.Casters());
  const PlanePixels pixels = FindPlanePixels(scene, casters);
  if (pixels.size() == 0)
    throw InputError((scene_dir / "scene.json").string(), "no shadow-plane pixels: the camera does not see the plane");

  LightingEstimate est;
  est.method = "eval";
  est.plane_render.assign(pixels.size(), Eigen::Vector3f::Zero());
  Stopwatch render_clock;
  if (lights.sg) {
    ShadowPlaneModel model = PrepareShadowPlane(
        scene, scene_dir, pixels, o.sg_model == "sg" ? ShadingModel::kSg : ShadingModel::kPaper, ctx);
    if (o.visibility == "exact") model.exact = MakeExactVisibility(scene);  // cosine exact, mesh visibility
    if (o.bounce) AddCasterBounce(scene, casters, &model);
    est.sg = lights.sg;
    CompleteSgEstimate(model, &est);
  }
  if (lights.env) {
    const int rows = o.map_height;
    const Image env = ResampleEnvMap(*lights.env, 2 * rows);
    const LightTransport transport(scene, pixels.point, casters, rows, ctx.Progress("transport"));
    const std::vector<Eigen::Vector3f> r = transport.RenderAll(transport.map().FromEnvMap(env));
    for (size_t k = 0; k < r.size(); ++k) est.plane_render[k] += r[k];
    est.envmap = *lights.env;
    est.n_params = 3 * lights.env->width * lights.env->height / 2;
  }
  est.solve_seconds = 0;
  est.extra = Json{{"lighting", lighting_file.string()}, {"render_seconds", render_clock.Seconds()},
                   {"sg_model", o.sg_model}, {"visibility", o.visibility}, {"bounce", o.bounce},
                   {"map_rows", o.map_height}};
  if (scene.image_virtual_objs) EnsureCompositeTrees(scene, scene_dir, ctx);  // for the insertion scores
  const Json m = ScoreAndWrite(scene, pixels, est, out_dir, clock, ctx);
  char line[200];
  std::snprintf(line, sizeof(line), "eval: psnr %.2f dB, ssim %.4f (%s)", m["psnr"].get<double>(),
                m["ssim"].get<double>(), lighting_file.filename().string().c_str());
  ctx.Log(line);
}

}  // namespace shadowsg
