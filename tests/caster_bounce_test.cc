// The light the casters reflect onto the plane (solver/caster_bounce.h):
// against a brute-force integral over a sphere, against the path tracer's
// bounces, and in the `sg` solver's choice between the models with and
// without it.
#include "solver/caster_bounce.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "solver/plane_pixels.h"
#include "solver/primitives.h"
#include "solver/sg_solver.h"
#include "solver/shadow_plane.h"
#include "stages/evaluation.h"
#include "stages/io/json_util.h"
#include "stages/io/scene_io.h"
#include "stages/solve_stage.h"
#include "stages/synth_stage.h"
#include "quiet_context.h"
#include "test_util.h"

namespace shadowsg {
namespace {

namespace fs = std::filesystem;

using shadowsg::testing::QuietContext;

// A sphere of radius 0.5 resting on the plane z = 0 at the origin, albedo 0.6.
struct SphereOnPlane {
  static constexpr double kRadius = 0.5, kAlbedo = 0.6;
  const Eigen::Vector3d centre{0, 0, kRadius + 1e-3};
  TriangleMesh mesh;
  RayCaster casters;
  SphereOnPlane() {
    mesh = MakeIcosphere(kRadius, 5);
    for (auto& v : mesh.vertices) v += centre;
    casters.AddMesh(mesh);
    casters.Commit();
  }
};

// The first bounce of a sharp lobe off a sphere, by brute force: a convex
// caster hides none of its own sky and none of its surface that faces x, so
// B(x) = sum over surface samples facing x of rho/pi E(y) cos_x cos_y / d^2 dA,
// E(y) = sum over sky directions above the plane of G(w) max(n_y.w, 0) dw.
double BruteForceBounce(const SphereOnPlane& s, const Eigen::Vector3d& x, const Eigen::Vector3d& mu, double lambda) {
  constexpr int kSky = 400000, kSurface = 20000;
  const double golden = M_PI * (3 - std::sqrt(5.0));
  std::vector<Eigen::Vector3d> sky;  // directions where the lobe is not negligible
  std::vector<double> weight;
  for (int i = 0; i < kSky; ++i) {
    const double z = 1 - (2.0 * i + 1) / kSky, r = std::sqrt(1 - z * z);
    const Eigen::Vector3d w(r * std::cos(golden * i), r * std::sin(golden * i), z);
    const double g = std::exp(lambda * (w.dot(mu) - 1));
    if (g > 1e-9 && z > 0) sky.push_back(w), weight.push_back(g * 4 * M_PI / kSky);
  }
  double b = 0;
  for (int i = 0; i < kSurface; ++i) {
    const double z = 1 - (2.0 * i + 1) / kSurface, r = std::sqrt(1 - z * z);
    const Eigen::Vector3d n(r * std::cos(golden * i), r * std::sin(golden * i), z);
    const Eigen::Vector3d y = s.centre + SphereOnPlane::kRadius * n;
    const Eigen::Vector3d v = x - y;
    const double d2 = v.squaredNorm(), cos_y = n.dot(v) / std::sqrt(d2), cos_x = -v.z() / std::sqrt(d2);
    if (cos_y <= 0 || cos_x <= 0) continue;
    double e = 0;
    for (size_t k = 0; k < sky.size(); ++k) e += weight[k] * std::max(0.0, n.dot(sky[k]));
    const double area = 4 * M_PI * SphereOnPlane::kRadius * SphereOnPlane::kRadius / kSurface;
    b += SphereOnPlane::kAlbedo / M_PI * e * cos_x * cos_y / d2 * area;
  }
  return b;
}

void ExpectFirstBounceMatchesBruteForce(const CasterBounceOptions& options) {
  const SphereOnPlane s;
  const CasterBounce bounce({s.mesh}, {Eigen::Vector3d::Constant(SphereOnPlane::kAlbedo)}, s.casters,
                            Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ(), options);
  const std::vector<Eigen::Vector3d> points = {{0.75, 0, 0}, {0, -1.0, 0}, {-1.5, 0.4, 0}, {1.2, 1.2, 0}, {0, 3, 0}};
  // A high sun and one 6 degrees above the horizon (the widened lobe of v_ij
  // would put half of that below the plane without the upper share).
  for (const Eigen::Vector3d& mu : {Eigen::Vector3d(0.3, -0.2, 0.93).normalized(),
                                    Eigen::Vector3d(-0.99, 0.1, 0.105).normalized()}) {
    const double lambda = 400;
    const std::array<Eigen::MatrixXf, 3> e = bounce.Irradiance({mu}, {lambda}, nullptr);
    Eigen::MatrixXf radiance(e[0].rows(), 1);
    for (long j = 0; j < radiance.rows(); ++j) radiance(j, 0) = bounce.patches()[j].albedo_over_pi[0] * e[0](j, 0);
    const Eigen::MatrixXf b = bounce.FormFactors(points) * radiance;
    for (size_t i = 0; i < points.size(); ++i) {
      const double ref = BruteForceBounce(s, points[i], mu, lambda);
      std::printf("sun z %.2f, point (%.2f, %.2f): model %.4g, brute force %.4g (%+.1f %%)\n", mu.z(), points[i].x(),
                  points[i].y(), b(static_cast<long>(i), 0), ref, 100 * (b(static_cast<long>(i), 0) / ref - 1));
      EXPECT_NEAR(b(static_cast<long>(i), 0), ref, 0.03 * ref + 1e-8)
          << "sun " << mu.transpose() << ", point " << points[i].transpose();
    }
  }
}

TEST(CasterBounce, FirstBounceOffASphereMatchesBruteForce) { ExpectFirstBounceMatchesBruteForce({}); }

// A mesh finer than the patches' grid (a scan): the sphere's 20480 faces
// against a grid of 2048 points. The patches are clustered from every fifth
// face, and every face still gives its area to one of them.
TEST(CasterBounce, FirstBounceOffAFineMeshMatchesBruteForce) {
  CasterBounceOptions options;
  options.surface_points = 2000;
  ExpectFirstBounceMatchesBruteForce(options);
}

// The plane points a solver gathers the bounce at: a grid around the sphere's
// foot, some of them right beside it, where the form factors peak.
std::vector<Eigen::Vector3d> GroundGrid(int n, double half) {
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const Eigen::Vector3d x(-half + 2 * half * (i + 0.5) / n, -half + 2 * half * (j + 0.5) / n, 0);
      if (x.norm() > 0.1) points.push_back(x);
    }
  return points;
}

// K(x, j) = cos_x cos_j / d^2 with the disk's area term, zero where the
// patch faces away from x or x sees it from below; finite (zero) at a patch's
// own centre.
TEST(CasterBounce, FormFactorsFollowTheDiskFormula) {
  const SphereOnPlane s;
  const CasterBounce bounce({s.mesh}, {Eigen::Vector3d::Constant(SphereOnPlane::kAlbedo)}, s.casters,
                            Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ());
  std::vector<Eigen::Vector3d> points = GroundGrid(12, 3.0);
  points.push_back(bounce.patches()[0].centre);
  const Eigen::MatrixXf k = bounce.FormFactors(points);
  ASSERT_EQ(k.rows(), static_cast<long>(points.size()));
  ASSERT_EQ(k.cols(), static_cast<long>(bounce.size()));
  long zeros = 0, lit = 0;
  for (long r = 0; r < k.rows(); ++r)
    for (long j = 0; j < k.cols(); ++j) {
      const CasterBounce::Patch& p = bounce.patches()[static_cast<size_t>(j)];
      const Eigen::Vector3d v = p.centre - points[static_cast<size_t>(r)];
      const double d2 = v.squaredNorm(), up = v.z(), facing = -p.normal.dot(v);
      const double expected = up > 0 && facing > 0 ? up * facing / d2 * p.area / (d2 + p.area / M_PI) : 0.0;
      ASSERT_TRUE(std::isfinite(k(r, j))) << r << " " << j;
      EXPECT_NEAR(k(r, j), expected, 1e-6 * expected + 1e-12) << r << " " << j;
      (expected > 0 ? lit : zeros) += 1;
    }
  EXPECT_EQ(k(k.rows() - 1, 0), 0.0f);
  // Both cases occur: the plane sees the sphere's lower half, not its upper.
  EXPECT_GT(lit, k.size() / 10);
  EXPECT_GT(zeros, k.size() / 10);
}

TEST(CasterBounce, FactoredFormFactorsStayWithinTheirTolerance) {
  const SphereOnPlane s;
  const CasterBounce bounce({s.mesh}, {Eigen::Vector3d::Constant(SphereOnPlane::kAlbedo)}, s.casters,
                            Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ());
  const Eigen::MatrixXf k = bounce.FormFactors(GroundGrid(60, 3.0));
  const long m = k.cols();
  ASSERT_GT(k.rows(), 3 * m);
  // No tolerance: K itself.
  const FactoredFormFactors exact = FactorFormFactors(k, 0);
  EXPECT_EQ(exact.basis.size(), 0);
  EXPECT_EQ(exact.rank(), m);
  EXPECT_TRUE(exact.left.isApprox(k));
  // Fewer points than patches, or a tolerance that needs more than half the
  // patches (here 0.003): nothing to gain.
  EXPECT_EQ(FactorFormFactors(k.topRows(m / 2), 0.01).basis.size(), 0);
  EXPECT_EQ(FactorFormFactors(k, 0.003).basis.size(), 0);

  // What the solver gathers: a sun's and a sky's bounce, per unit amplitude.
  const std::array<Eigen::MatrixXf, 3> e =
      bounce.Irradiance({Eigen::Vector3d(0.6, -0.3, 0.74).normalized(), Eigen::Vector3d::UnitZ()}, {500, 1}, nullptr);
  const Eigen::MatrixXf radiance = SphereOnPlane::kAlbedo / M_PI * e[0];
  const Eigen::MatrixXf gathered = k * radiance;
  long last_rank = m;
  for (double tolerance : {0.01, 0.03, 0.1}) {
    const FactoredFormFactors f = FactorFormFactors(k, tolerance);
    ASSERT_GT(f.basis.size(), 0) << "tolerance " << tolerance;
    const long r = f.rank();
    EXPECT_LE(r, m / 2);
    EXPECT_LE(r, last_rank);  // a looser tolerance never needs more
    last_rank = r;
    // The basis is orthonormal, and the residual of K is within the tolerance.
    EXPECT_TRUE((f.basis * f.basis.transpose()).isApprox(Eigen::MatrixXf::Identity(r, r), 1e-4));
    const double residual = (k - f.left * f.basis).norm() / k.norm();
    EXPECT_LE(residual, tolerance * 1.01 + 1e-5) << "tolerance " << tolerance;
    // The gathered bounce's error is of the same order (measured: 0.7-1.0x K's).
    const double gather_error = (f.Times(radiance) - gathered).norm() / gathered.norm();
    std::printf("tolerance %.3f: rank %ld of %ld, K residual %.2e, gathered bounce error %.2e\n", tolerance, r, m,
                residual, gather_error);
    EXPECT_LE(gather_error, 1.5 * tolerance);
  }
}

// A box and a sphere under a sun and a sky, path traced at 64 x 48 by the
// project's renderer with `bounces` diffuse bounces.
std::string TwoCasterSpec(int bounces) {
  return R"({
  "format": "synth/1",
  "camera": {"width": 64, "height": 48, "fov_deg": 55, "look_from": [0.4, -2.4, 1.6], "look_at": [0, 0, 0.15]},
  "plane": {"xyz": [0, 0, 0], "normal": [0, 0, 1], "scale": [6, 6, 1], "diffuse": [0.8, 0.7, 0.6]},
  "objects": [
    {"mesh": {"primitive": "box", "half_extents": [0.3, 0.12, 0.28]},
     "position": [-0.3, 0.1, 0], "rest_on_plane": true, "rotate_deg": [0, 0, 25], "diffuse": [0.8, 0.8, 0.8]},
    {"mesh": {"primitive": "icosphere", "radius": 0.22, "subdivisions": 3},
     "position": [0.45, -0.2, 0], "rest_on_plane": true, "diffuse": [0.9, 0.5, 0.3]}
  ],
  "lights": {"lobes": [{"axis": [0.7, -0.3, 0.45], "sharpness": 2000, "amplitude": [3000, 2900, 2700]},
                       {"axis": [0, 0, 1], "sharpness": 1.5, "amplitude": [0.3, 0.35, 0.45]}]},
  "render": {"spp": 256, "bounces": )" +
         std::to_string(bounces) + R"(, "seed": 7}
})";
}

fs::path SynthScene(const shadowsg::testing::TempDir& tmp, const std::string& name, const std::string& spec) {
  std::ofstream(tmp / (name + ".json")) << spec;
  RunSynthStage(ReadSynthSpec(tmp / (name + ".json")), tmp / name, QuietContext(2));
  return tmp / name;
}

TEST(CasterBounce, MatchesThePathTracersBounces) {
  shadowsg::testing::TempDir tmp;
  const fs::path direct = SynthScene(tmp, "direct", TwoCasterSpec(0));
  const fs::path bounced = SynthScene(tmp, "bounced", TwoCasterSpec(2));
  Scene scene = LoadScene(direct);
  const Scene with = LoadScene(bounced);
  const RayCaster casters = BuildRayCaster(scene.Casters());
  const PlanePixels pixels = FindPlanePixels(scene, casters);
  ASSERT_GT(pixels.size(), 1000u);
  ShadowPlaneModel model = PrepareShadowPlane(scene, direct, pixels, ShadingModel::kSg, QuietContext(2));
  const SgLighting lighting = *ReadSynthSpec(tmp / "direct.json").lights.sg;
  const std::vector<Eigen::Vector3f> plain = RenderShadowPlane(model, lighting);
  AddCasterBounce(scene, casters, &model);
  const std::vector<Eigen::Vector3f> lit = RenderShadowPlane(model, lighting);
  // The plane's share of light that came off the casters: path tracer (two
  // bounces minus none, same samples) against the model, per pixel.
  double sm = 0, sp = 0, smm = 0, spp = 0, smp = 0;
  const double n = static_cast<double>(pixels.size());
  for (size_t k = 0; k < pixels.size(); ++k) {
    const double m = (lit[k] - plain[k]).sum(), p = (with.image.rgb(pixels.pixel[k]) - scene.image.rgb(pixels.pixel[k])).sum();
    sm += m, sp += p, smm += m * m, spp += p * p, smp += m * p;
  }
  const double correlation = (smp / n - sm / n * sp / n) /
                             std::sqrt((smm / n - sm * sm / n / n) * (spp / n - sp * sp / n / n));
  std::printf("bounce on the plane: model %.5f, path tracer %.5f (ratio %.3f), correlation %.3f\n", sm / n, sp / n,
              sm / sp, correlation);
  EXPECT_GT(sp / n, 0.005);  // the scene does bounce a visible amount
  EXPECT_NEAR(sm / sp, 1.0, 0.15);
  EXPECT_GT(correlation, 0.8);
}

// Solves a scene fast with --bounce mode; returns metrics.json.
Json Solve(const fs::path& scene, const fs::path& out, const std::string& bounce) {
  SolveOptions o;
  o.budget = "fast";
  o.bounce = bounce;
  RunSolve(scene, out, o, QuietContext(2));
  return ReadJsonFile(out / "metrics.json");
}

TEST(CasterBounce, SolverKeepsTheBounceWhereTheImageHasIt) {
  shadowsg::testing::TempDir tmp;
  const fs::path bounced = SynthScene(tmp, "bounced", TwoCasterSpec(2));
  const Json off = Solve(bounced, tmp / "off", "off");
  const Json on = Solve(bounced, tmp / "auto", "auto");
  std::printf("bounced scene: off %.2f dB, auto %.2f dB (bounce %d), held-out %s\n", off["psnr"].get<double>(),
              on["psnr"].get<double>(), on["report"]["bounce"].get<bool>(),
              on["report"]["bounce_heldout_mse"].dump().c_str());
  EXPECT_FALSE(off["report"]["bounce"].get<bool>());
  EXPECT_TRUE(on["report"]["bounce"].get<bool>());
  EXPECT_GT(on["psnr"].get<double>(), off["psnr"].get<double>() + 1.0);
  // The report states the rule the size was chosen by.
  EXPECT_DOUBLE_EQ(on["report"]["size_tolerance"].get<double>(), SgSolverOptions{}.size_tolerance);

  // Where the image holds no bounce (direct light only), the held-out error
  // keeps the model without it.
  const fs::path direct = SynthScene(tmp, "direct", TwoCasterSpec(0));
  const Json plain = Solve(direct, tmp / "plain", "auto");
  std::printf("direct-only scene: auto %.2f dB (bounce %d), held-out %s\n", plain["psnr"].get<double>(),
              plain["report"]["bounce"].get<bool>(), plain["report"]["bounce_heldout_mse"].dump().c_str());
  EXPECT_FALSE(plain["report"]["bounce"].get<bool>());
}

// A scene's plane model with the casters' bounce, and its image at the
// plane pixels: what SolveSg takes.
std::pair<ShadowPlaneModel, std::vector<Eigen::Vector3f>> ModelWithBounce(const fs::path& dir) {
  Scene scene = LoadScene(dir);
  const RayCaster casters = BuildRayCaster(scene.Casters());
  const PlanePixels pixels = FindPlanePixels(scene, casters);
  ShadowPlaneModel model = PrepareShadowPlane(scene, dir, pixels, ShadingModel::kSg, QuietContext(2));
  AddCasterBounce(scene, casters, &model);
  std::vector<Eigen::Vector3f> targets;
  for (size_t k = 0; k < pixels.size(); ++k) targets.push_back(scene.image.rgb(pixels.pixel[k]).cast<float>());
  return {std::move(model), std::move(targets)};
}

// `balanced` on few pixels, seed 2: the restarts' tests below.
SgSolverOptions SmallBalanced() {
  SgSolverOptions o = SgSolverOptions::Budget("balanced");
  o.fit_pixels = 600;
  o.holdout_pixels = 300;
  o.seed = 2;
  return o;
}

// Restarts on a scene whose image has the bounce: the model without it
// loses the first restart's race clearly and is not fitted again; the
// winner's fits are those of racing every restart.
TEST(CasterBounce, AClearLoserOfTheFirstRaceIsNotFittedAgain) {
  shadowsg::testing::TempDir tmp;
  const fs::path bounced = SynthScene(tmp, "bounced", TwoCasterSpec(2));
  const auto [model, targets] = ModelWithBounce(bounced);
  SgSolverOptions o = SmallBalanced();
  ASSERT_EQ(o.restarts, 3);
  ASSERT_TRUE(o.bounce_race_once);
  SgSolverSummary once;
  SolveSg(model, targets, o, &once);
  ASSERT_EQ(once.bounce_race_entries.size(), 2u);
  std::printf("held-out without / with the bounce %s; restarts entered %d / %d\n",
              Json(once.bounce_heldout_mse).dump().c_str(), once.bounce_race_entries[0], once.bounce_race_entries[1]);
  EXPECT_TRUE(once.bounce);
  EXPECT_EQ(once.bounce_race_entries[0], 1);
  EXPECT_EQ(once.bounce_race_entries[1], 3);

  o.bounce_race_once = false;
  SgSolverSummary every;
  SolveSg(model, targets, o, &every);
  ASSERT_EQ(every.bounce_race_entries.size(), 2u);
  EXPECT_EQ(every.bounce_race_entries[0], 3);
  EXPECT_EQ(every.bounce_race_entries[1], 3);
  EXPECT_TRUE(every.bounce);
  ASSERT_EQ(every.restart_heldout_mse.size(), once.restart_heldout_mse.size());
  for (size_t r = 0; r < once.restart_heldout_mse.size(); ++r)
    EXPECT_DOUBLE_EQ(every.restart_heldout_mse[r], once.restart_heldout_mse[r]);
}

// Restarts on a scene whose image has no bounce: the direct model wins the
// first restart's race, and a fit carried into the bounce model (where one
// enters) leaves that race as it was: where the race decides the later
// restarts (later_restarts_bounce off), they fit the direct model alone, as
// without carrying. By default they fit the model with the bounce.
TEST(CasterBounce, CarriedFitsLeaveTheFirstRaceToDecideTheLaterRestarts) {
  shadowsg::testing::TempDir tmp;
  const fs::path direct = SynthScene(tmp, "direct", TwoCasterSpec(0));
  const auto [model, targets] = ModelWithBounce(direct);
  SgSolverOptions o = SmallBalanced();
  ASSERT_TRUE(o.later_restarts_bounce);
  SgSolverSummary later;
  SolveSg(model, targets, o, &later);
  EXPECT_EQ(later.bounce_race_entries, (std::vector<int>{1, 3}));
  ASSERT_EQ(later.bounce_heldout_mse.size(), 2u);
  EXPECT_TRUE(std::isfinite(later.bounce_heldout_mse[0]));  // the direct model's first fit is judged
  o.later_restarts_bounce = false;
  SgSolverSummary carried, plain;
  const SgLighting with = SolveSg(model, targets, o, &carried);
  o.carry_direct_into_bounce = false;
  const SgLighting without = SolveSg(model, targets, o, &plain);
  std::printf("held-out without / with the bounce %s (carrying) %s (not); restarts carried %d\n",
              Json(carried.bounce_heldout_mse).dump().c_str(), Json(plain.bounce_heldout_mse).dump().c_str(),
              carried.bounce_carried);
  EXPECT_EQ(plain.bounce_carried, 0);
  ASSERT_EQ(plain.bounce_race_entries, (std::vector<int>{3, 1}));
  EXPECT_EQ(carried.bounce_race_entries, plain.bounce_race_entries);
  // The direct fits are the same; a carried fit can only lower the bounce
  // model's best.
  EXPECT_EQ(carried.bounce_heldout_mse[0], plain.bounce_heldout_mse[0]);
  EXPECT_LE(carried.bounce_heldout_mse[1], plain.bounce_heldout_mse[1]);
  if (carried.bounce_carried == 0) {
    EXPECT_EQ(carried.bounce_heldout_mse[1], plain.bounce_heldout_mse[1]);
    ASSERT_EQ(with.lobes.size(), without.lobes.size());
    for (size_t i = 0; i < with.lobes.size(); ++i) EXPECT_EQ(with.lobes[i].axis, without.lobes[i].axis);
  }
}

// On a scene whose image has no bounce the direct model's first fit
// finishes; its lobes join the bounce model's pool of restarts
// (pool_across_models) and nowhere else: the fits themselves are those of
// solving without it.
TEST(CasterBounce, TheDirectFitsJoinTheBounceModelsPool) {
  shadowsg::testing::TempDir tmp;
  const fs::path direct = SynthScene(tmp, "direct", TwoCasterSpec(0));
  const auto [model, targets] = ModelWithBounce(direct);
  SgSolverOptions o = SmallBalanced();
  ASSERT_TRUE(o.pool_across_models);
  SgSolverSummary across, apart;
  SolveSg(model, targets, o, &across);
  o.pool_across_models = false;
  SolveSg(model, targets, o, &apart);
  std::printf("held-out without / with the bounce %s; direct fits pooled %d\n",
              Json(across.bounce_heldout_mse).dump().c_str(), across.pooled_direct_fits);
  ASSERT_EQ(across.bounce_race_entries, (std::vector<int>{1, 3}));
  EXPECT_EQ(across.pooled_direct_fits, 1);  // the first restart's direct fit
  EXPECT_EQ(apart.pooled_direct_fits, 0);
  // The race and every restart's fit are the same; only the pool differs.
  EXPECT_EQ(across.bounce_heldout_mse, apart.bounce_heldout_mse);
  EXPECT_EQ(across.bounce_race_entries, apart.bounce_race_entries);
}

// The amplitude systems' columns (LobeColumns, Weighted per channel) hold
// each lobe's render at unit amplitude, channel by channel: the bounce's
// channels sit side by side in one matrix, and a column taken from the
// wrong channel would miss the orange sphere's tint.
TEST(CasterBounce, LobeColumnsAreEachChannelsRender) {
  shadowsg::testing::TempDir tmp;
  const fs::path direct = SynthScene(tmp, "direct", TwoCasterSpec(0));
  const ShadowPlaneModel model = ModelWithBounce(direct).first;
  ASSERT_TRUE(model.bounce);
  const std::vector<SgLobe> lobes = {{Eigen::Vector3d(0.7, -0.3, 0.45).normalized(), 300, Eigen::Vector3d::Ones()},
                                     {Eigen::Vector3d(-0.2, 0.5, 0.8).normalized(), 4, Eigen::Vector3d::Ones()},
                                     {Eigen::Vector3d(0, 0, 1), 0.5, Eigen::Vector3d::Ones()}};
  std::vector<Eigen::Vector3d> axes;
  std::vector<double> sharpness;
  SplitLobes(lobes, &axes, &sharpness);
  const LobeShadingColumns columns = LobeColumns(model, axes, sharpness);
  const std::vector<double> unit(model.points.size(), 1.0);
  double largest_tint = 0;
  for (size_t j = 0; j < lobes.size(); ++j) {
    SgLighting one;
    one.lobes = {lobes[j]};
    const std::vector<Eigen::Vector3f> render = RenderShadowPlane(model, one);
    double scale = 0;
    for (const Eigen::Vector3f& r : render) scale = std::max(scale, static_cast<double>(r.maxCoeff()));
    for (int c = 0; c < 3; ++c) {
      const Eigen::MatrixXd w = columns.Weighted(model, unit, c);
      double worst = 0;
      for (size_t k = 0; k < render.size(); ++k)
        worst = std::max(worst, std::abs(w(static_cast<long>(k), static_cast<long>(j)) - render[k][c]));
      EXPECT_LT(worst, 1e-4 * scale) << "lobe " << j << ", channel " << c;
    }
    // The bounce's tint: its red and blue parts differ where the sphere lights the plane.
    for (size_t k = 0; k < render.size(); ++k) {
      const long row = static_cast<long>(k), col = static_cast<long>(j), nl = static_cast<long>(lobes.size());
      const float red = columns.bounce(row, col), blue = columns.bounce(row, 2 * nl + col);
      largest_tint = std::max(largest_tint, static_cast<double>(std::abs(red - blue)));
    }
  }
  EXPECT_GT(largest_tint, 0.0);
}

}  // namespace
}  // namespace shadowsg
