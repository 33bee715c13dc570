// `--visibility exact` (solver/exact_visibility.h): the transport's closed
// form, its gradients, and the solver on a path-traced box scene.
#include "solver/exact_visibility.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>

#include "solver/cosine_integral.h"
#include "solver/primitives.h"
#include "stages/io/json_util.h"
#include "stages/io/lighting_io.h"
#include "stages/solve_stage.h"
#include "stages/synth_stage.h"
#include "test_util.h"

namespace shadowsg {
namespace {

namespace fs = std::filesystem;

// A box caster (world space) standing on the plane z = 0.
struct BoxFixture {
  TriangleMesh box;
  std::shared_ptr<ExactVisibility> vis;
  BoxFixture() {
    box = MakeBox(Eigen::Vector3d(0.3, 0.15, 0.25));
    for (auto& v : box.vertices) v += Eigen::Vector3d(0, 0, 0.25);
    auto rc = std::make_shared<RayCaster>();
    rc->AddMesh(box);
    rc->Commit();
    vis = std::make_shared<ExactVisibility>(rc, std::vector<TriangleMesh>{box}, Eigen::Vector3d::UnitZ());
  }
};

TEST(ExactVisibility, UnoccludedIsTheClosedForm) {
  BoxFixture f;
  // A point beside the box: the box covers directions towards -x only.
  const OccludedTable t = f.vis->Tabulate({Eigen::Vector3d(0.8, 0, 0)});
  ASSERT_EQ(t.size(), 1u);
  EXPECT_GT(t.View(0).n_codes, 0u);
  for (double lambda : {20.0, 150.0, 3000.0}) {
    const Eigen::Vector3d mu = Eigen::Vector3d(0.6, 0.1, 0.79).normalized();  // away from the box
    const LobeShading s = f.vis->Shade(t.View(0), mu, lambda, true);
    const CosineIntegral ci = SgCosineIntegral(lambda, mu.z());
    EXPECT_NEAR(s.value, ci.value, 1e-12 * ci.value) << lambda;
    EXPECT_NEAR(s.dvalue_dlambda, ci.dlambda, 1e-12 * std::abs(ci.dlambda) + 1e-15) << lambda;
  }
  // A point with nothing occluded at all.
  const OccludedView empty;
  const LobeShading s = f.vis->Shade(empty, Eigen::Vector3d(0.3, 0.2, 0.93).normalized(), 2.0, false);
  EXPECT_DOUBLE_EQ(s.value, SgCosineIntegral(2.0, Eigen::Vector3d(0.3, 0.2, 0.93).normalized().z()).value);
}

TEST(ExactVisibility, OccludedValueAndGradients) {
  BoxFixture f;
  const Eigen::Vector3d x(0.6, 0.1, 0);
  const OccludedTable t = f.vis->Tabulate({x});
  // Axis straight at the box's centre: partly to fully blocked.
  const Eigen::Vector3d towards = (Eigen::Vector3d(0.05, 0.02, 0.3) - x).normalized();
  // One lambda per integration level: super-cells, cell centres, sub-cells.
  for (double lambda : {3.0, 30.0, 120.0, 500.0, 2500.0}) {
    for (const Eigen::Vector3d& mu : {towards, Eigen::Vector3d((towards + Eigen::Vector3d(0.12, 0.05, 0)).normalized())}) {
      const LobeShading s = f.vis->Shade(t.View(0), mu, lambda, true);
      const double closed = SgCosineIntegral(lambda, mu.z()).value;
      EXPECT_LT(s.value, closed) << lambda;          // something is blocked
      EXPECT_GT(s.value, -1e-3 * closed) << lambda;  // never much below 0
      auto value = [&](const Eigen::Vector3d& m, double l) { return f.vis->Shade(t.View(0), m, l, false).value; };
      const double scale = std::max(std::abs(s.value), 1e-3 * closed);
      const double hl = 1e-5 * lambda;
      const double dl = (value(mu, lambda + hl) - value(mu, lambda - hl)) / (2 * hl);
      EXPECT_LT(std::abs(dl - s.dvalue_dlambda), 1e-4 * std::max(std::abs(dl), scale / lambda)) << lambda;
      const double hm = 1e-6;
      for (int d = 0; d < 3; ++d) {
        Eigen::Vector3d e = Eigen::Vector3d::Zero();
        e[d] = hm;
        const double dm = (value(mu + e, lambda) - value(mu - e, lambda)) / (2 * hm);
        EXPECT_LT(std::abs(dm - s.dvalue_dmu[d]), 1e-4 * std::max(std::abs(dm), scale)) << lambda << " axis " << d;
      }
    }
  }
}

TEST(ExactVisibility, LevelsAgreeAtTheirSwitches) {
  // The integration level changes with lambda; the value must not jump.
  BoxFixture f;
  const Eigen::Vector3d x(0.5, -0.2, 0);
  const OccludedTable t = f.vis->Tabulate({x});
  const Eigen::Vector3d mu = (Eigen::Vector3d(0.1, 0.0, 0.35) - x).normalized();
  for (int i = 0; i < 4; ++i) {
    const double l = f.vis->LevelSwitch(i);
    const double below = f.vis->Shade(t.View(0), mu, l * (1 - 1e-9), false).value;
    const double above = f.vis->Shade(t.View(0), mu, l * (1 + 1e-9), false).value;
    const double closed = SgCosineIntegral(l, mu.z()).value;
    EXPECT_NEAR(below, above, 0.01 * closed) << l;
  }
}

TEST(ExactVisibility, StreamingRenderMatchesTable) {
  BoxFixture f;
  std::vector<Eigen::Vector3d> pts;
  std::vector<Eigen::Vector3f> albedo;
  for (int i = 0; i < 50; ++i) {
    pts.emplace_back(-1 + 0.04 * i, 0.3 - 0.01 * i, 0);
    albedo.emplace_back(0.8f, 0.7f, 0.6f);
  }
  SgLighting l;
  l.lobes.push_back({Eigen::Vector3d(-0.5, 0.2, 0.8).normalized(), 2000.0, Eigen::Vector3d(20, 18, 15)});
  l.lobes.push_back({Eigen::Vector3d(0, 0, 1), 1.0, Eigen::Vector3d(0.5, 0.6, 0.8)});
  const OccludedTable t = f.vis->Tabulate(pts);
  const auto a = f.vis->Render(pts, albedo, l, false, &t);
  const auto b = f.vis->Render(pts, albedo, l, false);
  for (size_t i = 0; i < pts.size(); ++i) EXPECT_EQ(a[i], b[i]);
}

// A path-traced box scene under a hard-edged sun lobe and a faint sky.
const char* kBoxSpec = R"({
  "format": "synth/1",
  "camera": {"width": 64, "height": 48, "fov_deg": 55,
             "look_from": [0.3, -2.6, 1.9], "look_at": [0, 0, 0.1]},
  "plane": {"xyz": [0, 0, 0], "normal": [0, 0, 1], "scale": [6, 6, 1], "diffuse": [0.8, 0.8, 0.8]},
  "objects": [
    {"mesh": {"primitive": "box", "half_extents": [0.35, 0.12, 0.3]},
     "position": [0, 0, 0], "rest_on_plane": true, "rotate_deg": [0, 0, 25], "diffuse": [0.5, 0.5, 0.5]}
  ],
  "lights": {"lobes": [{"axis": [0.55, 0.35, 0.76], "sharpness": 3000, "amplitude": [4000, 3800, 3400]},
                       {"axis": [0, 0, 1], "sharpness": 1.5, "amplitude": [0.25, 0.3, 0.4]}]},
  "render": {"spp": 64, "bounces": 4, "seed": 5},
  "env_gt_height": 32
})";

double AngleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) * 180 / M_PI;
}

TEST(ExactVisibility, SolveBeatsSpheresOnAPathTracedBox) {
  shadowsg::testing::TempDir tmp;
  std::ofstream(tmp / "spec.json") << kBoxSpec;
  StageContext ctx;
  ctx.quiet = true;
  ctx.threads = 2;
  const fs::path scene = tmp / "scene";
  RunSynthStage(ReadSynthSpec(tmp / "spec.json"), scene, ctx);
  const Eigen::Vector3d sun = Eigen::Vector3d(0.55, 0.35, 0.76).normalized();
  double psnr[2], psnr_exact[2];
  const char* modes[2] = {"spheres", "exact"};
  for (int m = 0; m < 2; ++m) {
    SolveOptions o;
    o.budget = "fast";
    o.visibility = modes[m];
    o.score_exact = true;
    const fs::path out = tmp / modes[m];
    RunSolve(scene, out, o, ctx);
    const Json metrics = ReadJsonFile(out / "metrics.json");
    psnr[m] = metrics["psnr"].get<double>();
    psnr_exact[m] = metrics["report"]["psnr_exact_visibility"].get<double>();
    const LightSet est = ReadLighting(out / "lighting.json");
    ASSERT_TRUE(est.sg);
    // The brightest lobe is the sun.
    const SgLobe* best = nullptr;
    for (const SgLobe& l : est.sg->lobes)
      if (!best || SgIntegral(l).sum() > SgIntegral(*best).sum()) best = &l;
    ASSERT_NE(best, nullptr);
    const double err = AngleDeg(best->axis, sun);
    std::printf("%s: psnr %.2f dB (exact-visibility render %.2f dB), %zu lobes, sun axis error %.2f deg\n", modes[m],
                psnr[m], metrics["report"]["psnr_exact_visibility"].get<double>(), est.sg->lobes.size(), err);
    if (m == 1) {
      EXPECT_LT(err, 2.0);
      // Scored under its own (exact) renderer, so the two PSNRs coincide.
      EXPECT_NEAR(metrics["report"]["psnr_exact_visibility"].get<double>(), psnr[m], 1e-6);
    }
  }
  // Under one renderer (exact visibility) the exact fit is far ahead; by
  // their own renderers the two are within noise on this 64 x 48 scene
  // (with the casters' bounce the sphere fit's own PSNR came level).
  EXPECT_GT(psnr_exact[1], psnr_exact[0] + 3.0);
  EXPECT_GT(psnr[1], psnr[0] - 1.0);
}

}  // namespace
}  // namespace shadowsg
