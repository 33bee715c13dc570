// The refinement's cost (solver/sg_refine_cost.h): its Jacobian against
// central differences of its residuals, with the casters' bounce in the
// model, and its per-lobe cache against fresh evaluations.
#include "solver/sg_refine_cost.h"

#include <gtest/gtest.h>

#include <memory>

#include "solver/caster_bounce.h"
#include "solver/primitives.h"
#include "solver/ray_caster.h"
#include "sg_test_scene.h"

namespace shadowsg {
namespace {

// The test caster's sphere tree for the direct light, and a white sphere
// mesh of about its size for the bounce (the Jacobian check needs no
// agreement between the two).
ShadowPlaneModel ModelWithBounce(bool bounce) {
  ShadowPlaneModel model = testing::TestPlaneModel(20, CosineModel::kExact);
  model.normal = Eigen::Vector3d::UnitZ();
  if (!bounce) return model;
  TriangleMesh ball = MakeIcosphere(0.3, 3);
  for (Eigen::Vector3d& v : ball.vertices) v += Eigen::Vector3d(0, 0, 0.301);
  RayCaster casters;
  casters.AddMesh(ball);
  casters.Commit();
  CasterBounceOptions o;
  o.patches = 64;
  model.bounce = std::make_shared<const CasterBounce>(std::vector<TriangleMesh>{ball},
                                                      std::vector<Eigen::Vector3d>{Eigen::Vector3d::Constant(0.9)},
                                                      casters, Eigen::Vector3d::Zero(), model.normal, o);
  return model;
}

// Parameter blocks of a sun and a sky lobe: axis (3), log-sharpness, amplitude (3).
std::vector<std::vector<double>> Lobes() {
  const Eigen::Vector3d sun = Eigen::Vector3d(0.55, -0.3, 0.78).normalized();
  return {{sun.x(), sun.y(), sun.z()}, {std::log(300.0)}, {40, 38, 35},
          {0.1, 0.2, 0.97},            {std::log(2.0)},   {0.4, 0.5, 0.7}};
}

// Residuals at the given blocks (Jacobians when jac is not null).
std::vector<double> Residuals(const RefineCost& cost, const std::vector<std::vector<double>>& blocks,
                              std::vector<std::vector<double>>* jac = nullptr) {
  std::vector<const double*> p;
  for (const auto& b : blocks) p.push_back(b.data());
  std::vector<double> r(static_cast<size_t>(cost.num_residuals()));
  std::vector<double*> j;
  if (jac) {
    jac->assign(blocks.size(), {});
    for (size_t i = 0; i < blocks.size(); ++i) {
      (*jac)[i].assign(r.size() * blocks[i].size(), 0.0);
      j.push_back((*jac)[i].data());
    }
  }
  EXPECT_TRUE(cost.Evaluate(p.data(), r.data(), jac ? j.data() : nullptr));
  return r;
}

// d r / d(log sharpness of lobe `lobe`) by central differences.
std::vector<double> NumericSharpnessColumn(const RefineCost& cost, std::vector<std::vector<double>> blocks, int lobe) {
  constexpr double kH = 1e-3;
  const size_t b = 3 * static_cast<size_t>(lobe) + 1;
  const double x = blocks[b][0];
  blocks[b][0] = x + kH;
  const std::vector<double> up = Residuals(cost, blocks);
  blocks[b][0] = x - kH;
  const std::vector<double> down = Residuals(cost, blocks);
  std::vector<double> d(up.size());
  for (size_t k = 0; k < d.size(); ++k) d[k] = (up[k] - down[k]) / (2 * kH);
  return d;
}

double Norm(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x * x;
  return std::sqrt(s);
}

double Distance(const std::vector<double>& a, const std::vector<double>& b) {
  double s = 0;
  for (size_t k = 0; k < a.size(); ++k) s += (a[k] - b[k]) * (a[k] - b[k]);
  return std::sqrt(s);
}

TEST(RefineCost, SharpnessColumnCarriesTheBounce) {
  const ShadowPlaneModel direct = ModelWithBounce(false), bounced = ModelWithBounce(true);
  const std::vector<Eigen::Vector3f> targets(direct.points.size(), Eigen::Vector3f::Constant(0.5f));
  const std::vector<double> weight(direct.points.size(), 1.0);
  const RefineCost direct_cost(direct, weight, targets, 2, true), bounced_cost(bounced, weight, targets, 2, true);
  const RefineCost amplitude_only(bounced, weight, targets, 2, /*bounce_sharpness=*/false);
  const auto blocks = Lobes();
  std::vector<std::vector<double>> jac, jac_plain;
  Residuals(bounced_cost, blocks, &jac);
  Residuals(amplitude_only, blocks, &jac_plain);
  for (int lobe = 0; lobe < 2; ++lobe) {
    const std::vector<double> numeric = NumericSharpnessColumn(bounced_cost, blocks, lobe);
    const std::vector<double> without = NumericSharpnessColumn(direct_cost, blocks, lobe);
    const std::vector<double>& analytic = jac[3 * lobe + 1];
    const double error = Distance(analytic, numeric) / Norm(numeric);
    const double bounce_share = Distance(numeric, without) / Norm(numeric);
    std::printf("lobe %d: relative error %.4f, the bounce's share of the column %.3f\n", lobe, error, bounce_share);
    // The bounce is a visible part of the column (a Jacobian without it is
    // off by that much), and the forward difference inside gets it.
    EXPECT_GT(bounce_share, 0.005) << "lobe " << lobe;
    EXPECT_LT(error, 0.2 * bounce_share) << "lobe " << lobe;
    // Without the column the Jacobian misses the bounce's share.
    EXPECT_GT(Distance(jac_plain[3 * lobe + 1], numeric) / Norm(numeric), 0.8 * bounce_share) << "lobe " << lobe;
  }
}

// The amplitude columns are exact: the residuals are linear in them.
TEST(RefineCost, AmplitudeColumnsMatchDifferences) {
  const ShadowPlaneModel bounced = ModelWithBounce(true);
  const std::vector<Eigen::Vector3f> targets(bounced.points.size(), Eigen::Vector3f::Constant(0.5f));
  const std::vector<double> weight(bounced.points.size(), 2.0);
  const RefineCost cost(bounced, weight, targets, 2, true);
  auto blocks = Lobes();
  std::vector<std::vector<double>> jac;
  const std::vector<double> r0 = Residuals(cost, blocks, &jac);
  for (int lobe = 0; lobe < 2; ++lobe)
    for (int c = 0; c < 3; ++c) {
      auto moved = blocks;
      moved[3 * lobe + 2][c] += 1.0;
      const std::vector<double> r1 = Residuals(cost, moved);
      double worst = 0, scale = 0;
      for (size_t k = 0; k < r0.size(); ++k) {
        worst = std::max(worst, std::abs((r1[k] - r0[k]) - jac[3 * lobe + 2][k * 3 + c]));
        scale = std::max(scale, std::abs(r1[k] - r0[k]));
      }
      EXPECT_GT(scale, 0) << "lobe " << lobe << " channel " << c;
      EXPECT_LT(worst, 1e-9 + 1e-5 * scale) << "lobe " << lobe << " channel " << c;
    }
}

// One cost evaluated along a path of parameters (one lobe moved, both,
// back, the sharpness derivative asked for after a residual-only call)
// gives what a fresh cost gives at each point: nothing stale is reused.
TEST(RefineCost, CachedShadingMatchesAFreshCost) {
  for (bool exact_sharpness : {false, true}) {
    const ShadowPlaneModel bounced = ModelWithBounce(true);
    const std::vector<Eigen::Vector3f> targets(bounced.points.size(), Eigen::Vector3f::Constant(0.5f));
    const std::vector<double> weight(bounced.points.size(), 1.0);
    const RefineCost reused(bounced, weight, targets, 2, exact_sharpness);
    const auto start = Lobes();
    auto sun_moved = start;
    sun_moved[0] = {0.5, -0.35, 0.79};
    auto both_moved = sun_moved;
    both_moved[4][0] += 0.3;
    // One lobe's shading alone may sum in another order than beside another
    // lobe's (float products): equal to rounding, not bitwise.
    auto expect_near = [](const std::vector<double>& a, const std::vector<double>& b, const char* what) {
      EXPECT_LT(Distance(a, b), 1e-5 * Norm(b)) << what;
    };
    for (const auto& blocks : {start, sun_moved, both_moved, start, sun_moved}) {
      const RefineCost fresh(bounced, weight, targets, 2, exact_sharpness);
      const std::vector<double> r_fresh = Residuals(fresh, blocks);
      expect_near(Residuals(reused, blocks), r_fresh, "residuals");
      std::vector<std::vector<double>> j_reused, j_fresh;
      expect_near(Residuals(reused, blocks, &j_reused), r_fresh, "residuals with Jacobians");
      Residuals(fresh, blocks, &j_fresh);
      for (size_t b = 0; b < j_fresh.size(); ++b) expect_near(j_reused[b], j_fresh[b], "Jacobian block");
    }
  }
}

}  // namespace
}  // namespace shadowsg
