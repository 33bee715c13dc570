#include "stages/solve_stage.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "calib/error.h"
#include "solver/baselines.h"
#include "solver/exact_visibility.h"
#include "solver/observability.h"
#include "solver/metrics.h"
#include "solver/plane_pixels.h"
#include "solver/sg_paper_solver.h"
#include "solver/sg_solver.h"
#include "solver/shadow_plane.h"
#include "stages/composite_stage.h"
#include "stages/evaluation.h"
#include "stages/io/scene_io.h"
#include "stages/stage_util.h"

namespace shadowsg {
namespace fs = std::filesystem;

std::string SolveOptions::Validate() const {
  static const char* kMethods[] = {"sg", "sg-paper", "ss03", "ss03+", "sh21"};
  if (std::find(std::begin(kMethods), std::end(kMethods), method) == std::end(kMethods))
    return "--method: unknown method '" + method + "' (expected sg, sg-paper, ss03, ss03+ or sh21)";
  if (lobes < 0) return "--lobes: must be >= 0";
  if (budget != "fast" && budget != "balanced" && budget != "best" && budget != "paper")
    return "--budget: expected fast, balanced, best or paper";
  if (map_height < 2 || map_height > 256) return "--map-height: expected 2 to 256 rows";
  if (ssdf != "exact" && ssdf != "c2f") return "--ssdf: expected exact or c2f";
  if (visibility != "spheres" && visibility != "exact") return "--visibility: expected spheres or exact";
  if (visibility == "exact" && method != "sg") return "--visibility exact: only with --method sg";
  if (bounce != "auto" && bounce != "on" && bounce != "off") return "--bounce: expected auto, on or off";
  if (bounce == "on" && method != "sg") return "--bounce on: only with --method sg";
  return "";
}

namespace {

// The lit plane's irradiance trend across the view (solver/observability.h).
LitPlaneTrend LitTrend(const Scene& scene, const PlanePixels& pixels) {
  std::vector<double> irradiance(pixels.size());
  for (size_t i = 0; i < pixels.size(); ++i)
    irradiance[i] = scene.image.rgb(pixels.pixel[i]).cast<double>().sum() /
                    std::max(1e-12, PlaneAlbedo(scene.plane, pixels.point[i]).sum());
  return MeasureLitPlaneTrend(pixels.point, scene.plane.normal, irradiance);
}

std::vector<Eigen::Vector3f> Targets(const Scene& scene, const PlanePixels& pixels) {
  std::vector<Eigen::Vector3f> t;
  t.reserve(pixels.size());
  for (int p : pixels.pixel) t.push_back(scene.image.rgb(p));
  return t;
}

LightingEstimate SolveWithSgPaper(Scene& scene, const fs::path& scene_dir, const PlanePixels& pixels,
                                  const SolveOptions& o, const StageContext& ctx) {
  ShadowPlaneModel model = PrepareShadowPlane(scene, scene_dir, pixels, ShadingModel::kPaper, ctx);
  model.search = o.ssdf == "c2f" ? SsdfSearch::kCoarseToFine : SsdfSearch::kExact;
  SgPaperOptions po;
  if (o.lobes > 0) po.lobes = o.lobes;
  if (o.steps >= 0) po.steps = o.steps;
  po.seed = ctx.seed;
  std::string error;
  if (!po.IsValid(&error)) throw InputError("", error);
  SgSolveSummary summary;
  Stopwatch solve_clock;
  LightingEstimate est;
  est.method = o.method;
  est.sg = SolveSgPaper(model, Targets(scene, pixels), po, &summary, ctx.Progress("sg-paper"));
  est.solve_seconds = solve_clock.Seconds();
  CompleteSgEstimate(model, &est);
  est.extra = Json{{"steps", summary.iterations},
                   {"final_batch_loss", summary.final_loss},
                   {"lobes_initial", summary.lobes_initial},
                   {"invalid_lobes_removed", summary.invalid_lobes_removed},
                   {"ssdf", o.ssdf}};
  return est;
}

LightingEstimate SolveWithSg(Scene& scene, const fs::path& scene_dir, const PlanePixels& pixels,
                             const RayCaster& casters, const SolveOptions& o, const StageContext& ctx) {
  ShadowPlaneModel model = PrepareShadowPlane(scene, scene_dir, pixels, ShadingModel::kSg, ctx);
  model.search = o.ssdf == "c2f" ? SsdfSearch::kCoarseToFine : SsdfSearch::kExact;
  // --visibility exact: fit and re-render with the meshes' ray-cast visibility.
  if (o.visibility == "exact") model.exact = MakeExactVisibility(scene);
  if (o.bounce != "off") AddCasterBounce(scene, casters, &model);
  SgSolverOptions so = SgSolverOptions::Budget(o.budget);
  // auto: the fits with and without the bounce race on held-out pixels
  // (the model's other errors can favour either; README).
  so.choose_bounce = o.bounce == "auto";
  so.lobes = o.lobes;
  if (o.restarts > 0) so.restarts = o.restarts;
  so.seed = ctx.seed;
  std::string error;
  if (!so.IsValid(&error)) throw InputError("", error);
  SgSolverSummary summary;
  Stopwatch solve_clock;
  LightingEstimate est;
  est.method = o.method;
  est.sg = SolveSg(model, Targets(scene, pixels), so, &summary, ctx.Progress("sg"));
  est.solve_seconds = solve_clock.Seconds();
  if (!summary.bounce) {  // the direct-only fit won: render what was fitted
    model.bounce.reset();
    model.bounce_ground.reset();
  }
  Stopwatch render_clock;
  CompleteSgEstimate(model, &est);
  est.extra = Json{{"budget", o.budget},
                   {"restarts", so.restarts},
                   {"visibility", o.visibility},
                   {"bounce", summary.bounce},
                   {"bounce_heldout_mse", summary.bounce_heldout_mse},
                   {"bounce_race_entries", summary.bounce_race_entries},
                   {"bounce_carried", summary.bounce_carried},
                   {"pooled_direct_fits", summary.pooled_direct_fits},
                   {"render_seconds", render_clock.Seconds()},
                   {"size_tolerance", so.size_tolerance},
                   {"heldout_mse_path", summary.heldout_mse},
                   {"heldout_mse_path_judged", summary.path_judged},
                   {"fit_mse_selected", summary.fit_mse_selected},
                   {"fit_mse_refined", summary.fit_mse_refined},
                   {"refine_iterations", summary.refine_iterations},
                   {"path_lm_steps", summary.path_lm_steps},
                   {"path_lm_refused", summary.path_lm_refused},
                   {"invalid_lobes_removed", summary.invalid_lobes_removed},
                   {"scan_moves", summary.scan_moves},
                   {"restart_heldout_mse", summary.restart_heldout_mse},
                   {"restart_judged_mse", summary.restart_judged_mse},
                   {"judge_pixels", summary.judge_pixels},
                   {"restart_chosen", summary.restart_chosen},
                   {"pooled", summary.pooled},
                   {"pool_refined", summary.pool_refined},
                   {"theta_seconds", summary.theta_seconds},
                   {"select_seconds", summary.select_seconds},
                   {"refine_seconds", summary.refine_seconds},
                   {"ssdf", o.ssdf}};
  return est;
}

LightingEstimate SolveWithBaseline(const Scene& scene, const PlanePixels& pixels, const RayCaster& casters,
                                   const SolveOptions& o, const StageContext& ctx) {
  BaselineOptions bo;
  bo.method = o.method == "ss03" ? BaselineMethod::kSS03
              : o.method == "ss03+" ? BaselineMethod::kSS03Plus
                                    : BaselineMethod::kSH21;
  bo.map_rows = o.map_height;
  bo.estimate_albedo = o.estimate_albedo;
  bo.seed = ctx.seed;
  std::string error;
  if (!bo.IsValid(&error)) throw InputError("", error);
  const BaselineResult r = SolveBaseline(scene, pixels, casters, bo, ctx.Progress(o.method));
  LightingEstimate est;
  est.method = o.method;
  est.envmap = r.envmap;
  est.plane_render = r.render;
  est.n_params = r.n_params;
  est.solve_seconds = r.solve_seconds;
  est.extra = Json{{"map_rows", o.map_height}, {"albedo_scale", r.albedo_scale}, {"invalid_texels", r.invalid_texels}};
  return est;
}

}  // namespace

void RunSolve(const fs::path& scene_dir, const fs::path& out_dir, const SolveOptions& o, const StageContext& ctx) {
  Stopwatch clock;
  if (const std::string e = o.Validate(); !e.empty()) throw InputError("", e);
  SceneLoadOptions load;
  load.require_observation = true;  // a black or saturated photo holds no shadow to solve from
  Scene scene = LoadScene(scene_dir, load);
  const RayCaster casters = BuildRayCaster(scene.Casters());
  const PlanePixels pixels = FindPlanePixels(scene, casters);
  if (pixels.size() == 0)
    throw InputError((scene_dir / "scene.json").string(),
                     "no shadow-plane pixels: the camera does not see the plane rectangle (or the mask excludes it)");
  ctx.Log("solve: " + scene.name + ", " + std::to_string(pixels.size()) + " plane pixels, method " + o.method +
          ", " + std::to_string(ctx.threads) + " threads");
  const double informative = InformativeSkyShare(scene.plane.normal, pixels.point, casters);
  if (informative == 0)
    ctx.Warn("no visible plane pixel is in the object's shadow from any direction: the image fixes the total light, "
             "not where it comes from (the estimate is one of many that render the same)");
  else if (informative < 0.25)
    ctx.Warn("the visible shadow constrains only " + std::to_string(static_cast<int>(std::lround(100 * informative))) +
             " % of the sky (cosine-weighted): light from the rest is known in total only");
  const LitPlaneTrend trend = LitTrend(scene, pixels);
  if (trend.ratio > kNearLightTrend) {
    char msg[256];
    std::snprintf(msg, sizeof(msg),
                  "the lit plane's brightness changes %.1fx across the view: a light close to the scene? Distant "
                  "lighting (every method here) cannot reproduce that falloff; expect a poor fit",
                  trend.ratio);
    ctx.Warn(msg);
  }
  LightingEstimate est;
  if (o.method == "sg-paper") est = SolveWithSgPaper(scene, scene_dir, pixels, o, ctx);
  else if (o.method == "sg") est = SolveWithSg(scene, scene_dir, pixels, casters, o, ctx);
  else est = SolveWithBaseline(scene, pixels, casters, o, ctx);
  // The solvers' last guard dropped what was not lighting; say so.
  if (const int bad = est.extra.value("invalid_lobes_removed", 0); bad > 0)
    ctx.Warn(o.method + ": " + std::to_string(bad) + " lobes with non-finite values were dropped from the estimate");
  if (const int bad = est.extra.value("invalid_texels", 0); bad > 0)
    ctx.Warn(o.method + ": " + std::to_string(bad) + " non-finite env-map values were set to 0");
  est.extra["informative_sky_share"] = informative;
  est.extra["lit_plane_trend"] = trend.ratio;
  if (o.score_exact && est.sg) {
    // The same lighting rendered with the meshes' exact visibility: compares
    // --visibility modes (and methods) under one renderer.
    Stopwatch exact_clock;
    std::vector<Eigen::Vector3f> albedo;
    for (const Eigen::Vector3d& p : pixels.point) albedo.push_back(PlaneAlbedo(scene.plane, p).cast<float>());
    std::vector<Eigen::Vector3f> r = MakeExactVisibility(scene)->Render(pixels.point, albedo, *est.sg, false);
    // The bounce as fitted (its second bounce shaded by the model's own visibility).
    for (size_t k = 0; k < est.plane_bounce.size(); ++k) r[k] += est.plane_bounce[k];
    const ImageMetrics im = CompareImages(PlaneRenderImage(pixels, r), scene.image, PlanePixelMask(pixels));
    est.extra["psnr_exact_visibility"] = im.psnr;
    est.extra["ssim_exact_visibility"] = im.ssim;
    est.extra["exact_render_seconds"] = exact_clock.Seconds();
  }
  if (scene.image_virtual_objs) EnsureCompositeTrees(scene, scene_dir, ctx);  // for the insertion scores
  const Json m = ScoreAndWrite(scene, pixels, est, out_dir, clock, ctx);
  char line[256];
  std::snprintf(line, sizeof(line), "solve: %s psnr %.2f dB, ssim %.4f, %d lobes, %d params, solve %.2f s, total %.2f s",
                o.method.c_str(), m["psnr"].get<double>(), m["ssim"].get<double>(), est.n_lobes, est.n_params,
                est.solve_seconds, m["total_seconds"].get<double>());
  ctx.Log(line);
  ctx.Log("outputs in " + out_dir.string());
}

}  // namespace shadowsg
