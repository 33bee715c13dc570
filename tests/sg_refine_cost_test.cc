// The refinement's cost (solver/sg_refine_cost.h): its Jacobian against
// central differences of its residuals, with the casters' bounce in the
// model, and its per-lobe cache against fresh evaluations.
#include "solver/sg_refine_cost.h"

#include <gtest/gtest.h>

#include "sg_test_scene.h"

namespace shadowsg {
namespace {

// The test caster's sphere tree for the direct light and, with the bounce,
// testing::AddTestCasterBounce's sphere mesh.
ShadowPlaneModel ModelWithBounce(bool bounce) {
  ShadowPlaneModel model = testing::TestPlaneModel(20, CosineModel::kExact);
  model.normal = Eigen::Vector3d::UnitZ();
  if (bounce) testing::AddTestCasterBounce(&model);
  return model;
}

// What a two-lobe RefineCost reads (it keeps references, so they live
// here): the model, uniform targets of 0.5 and a uniform weight. With
// form_tolerance >= 0 the bounce's form factors are prepared (factored at
// that tolerance), as the solver's fit pixels have them.
struct CostInputs {
  ShadowPlaneModel model;
  std::vector<Eigen::Vector3f> targets;
  std::vector<double> weight;
  CostInputs(bool bounce, double w, double form_tolerance = -1)
      : model(ModelWithBounce(bounce)),
        targets(model.points.size(), Eigen::Vector3f::Constant(0.5f)),
        weight(model.points.size(), w) {
    if (form_tolerance >= 0) model.PrepareBounceForm(form_tolerance);
  }
  RefineCost Cost(bool bounce_sharpness) const { return RefineCost(model, weight, targets, 2, bounce_sharpness); }
};

// A sun and a sky lobe.
std::vector<SgLobe> Lobes() {
  return {{Eigen::Vector3d(0.55, -0.3, 0.78).normalized(), 300.0, Eigen::Vector3d(40, 38, 35)},
          {Eigen::Vector3d(0.1, 0.2, 0.97).normalized(), 2.0, Eigen::Vector3d(0.4, 0.5, 0.7)}};
}

// Residuals at `lobes`, r(k, c) at 3k + c (the Jacobian too when jac is not null).
std::vector<double> Residuals(const RefineCost& cost, const std::vector<SgLobe>& lobes,
                              RefineJacobian* jac = nullptr) {
  Eigen::MatrixX3d r;
  cost.Evaluate(lobes, &r, jac);
  EXPECT_EQ(r.rows(), cost.points());
  std::vector<double> out(3 * static_cast<size_t>(r.rows()));
  for (long k = 0; k < r.rows(); ++k)
    for (int c = 0; c < 3; ++c) out[3 * k + c] = r(k, c);
  return out;
}

// Column `col` of the Jacobian over every residual (3k + c): geometry
// columns move every channel, an amplitude column (col >= 3L) channel
// `channel` only.
std::vector<double> Column(const RefineJacobian& jac, int lobes, int col, int channel = -1) {
  const long np = jac.channel[0].rows();
  std::vector<double> out(3 * static_cast<size_t>(np), 0.0);
  for (long k = 0; k < np; ++k)
    for (int c = 0; c < 3; ++c)
      if (col < 3 * lobes || c == channel) out[3 * k + c] = jac.channel[c](k, col);
  return out;
}

// d r / d(log sharpness of lobe `lobe`) by central differences.
std::vector<double> NumericSharpnessColumn(const RefineCost& cost, std::vector<SgLobe> lobes, int lobe) {
  constexpr double kH = 1e-3;
  const double lambda = lobes[lobe].sharpness;
  lobes[lobe].sharpness = lambda * std::exp(kH);
  const std::vector<double> up = Residuals(cost, lobes);
  lobes[lobe].sharpness = lambda * std::exp(-kH);
  const std::vector<double> down = Residuals(cost, lobes);
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
  const CostInputs direct(false, 1.0), bounced(true, 1.0);
  const RefineCost direct_cost = direct.Cost(true), bounced_cost = bounced.Cost(true);
  const RefineCost amplitude_only = bounced.Cost(/*bounce_sharpness=*/false);
  const auto lobes = Lobes();
  RefineJacobian jac, jac_plain;
  Residuals(bounced_cost, lobes, &jac);
  Residuals(amplitude_only, lobes, &jac_plain);
  for (int lobe = 0; lobe < 2; ++lobe) {
    const std::vector<double> numeric = NumericSharpnessColumn(bounced_cost, lobes, lobe);
    const std::vector<double> without = NumericSharpnessColumn(direct_cost, lobes, lobe);
    const std::vector<double> analytic = Column(jac, 2, 3 * lobe + 2);
    const double error = Distance(analytic, numeric) / Norm(numeric);
    const double bounce_share = Distance(numeric, without) / Norm(numeric);
    std::printf("lobe %d: relative error %.4f, the bounce's share of the column %.3f\n", lobe, error, bounce_share);
    // The bounce is a visible part of the column (a Jacobian without it is
    // off by that much), and the forward difference inside gets it.
    EXPECT_GT(bounce_share, 0.005) << "lobe " << lobe;
    EXPECT_LT(error, 0.2 * bounce_share) << "lobe " << lobe;
    // Without the column the Jacobian misses the bounce's share.
    EXPECT_GT(Distance(Column(jac_plain, 2, 3 * lobe + 2), numeric) / Norm(numeric), 0.8 * bounce_share)
        << "lobe " << lobe;
  }
}

// The axis columns against central differences of the direct shading (the
// bounce has no axis column: sg_refine_cost.h), steps made by TurnAxis.
TEST(RefineCost, AxisColumnsMatchDifferences) {
  const CostInputs direct(false, 1.0);
  const RefineCost cost = direct.Cost(false);
  const auto lobes = Lobes();
  RefineJacobian jac;
  Residuals(cost, lobes, &jac);
  constexpr double kH = 1e-4;
  for (int lobe = 0; lobe < 2; ++lobe) {
    const auto t = TangentBasis(lobes[lobe].axis);
    EXPECT_NEAR(t[0].dot(lobes[lobe].axis), 0, 1e-12);
    EXPECT_NEAR(t[1].dot(lobes[lobe].axis), 0, 1e-12);
    EXPECT_NEAR(t[0].dot(t[1]), 0, 1e-12);
    EXPECT_NEAR(std::abs(t[0].cross(t[1]).dot(lobes[lobe].axis)), 1, 1e-12);
    for (int i = 0; i < 2; ++i) {
      auto up = lobes, down = lobes;
      up[lobe].axis = TurnAxis(lobes[lobe].axis, i == 0 ? kH : 0, i == 1 ? kH : 0);
      down[lobe].axis = TurnAxis(lobes[lobe].axis, i == 0 ? -kH : 0, i == 1 ? -kH : 0);
      const std::vector<double> ru = Residuals(cost, up), rd = Residuals(cost, down);
      std::vector<double> numeric(ru.size());
      for (size_t k = 0; k < ru.size(); ++k) numeric[k] = (ru[k] - rd[k]) / (2 * kH);
      const double error = Distance(Column(jac, 2, 3 * lobe + i), numeric) / Norm(numeric);
      std::printf("lobe %d tangent %d: relative error %.2e (column norm %.3g)\n", lobe, i, error, Norm(numeric));
      EXPECT_GT(Norm(numeric), 0) << "lobe " << lobe;
      EXPECT_LT(error, 0.02) << "lobe " << lobe << " tangent " << i;
    }
  }
}

// The amplitude columns are exact: the residuals are linear in them.
TEST(RefineCost, AmplitudeColumnsMatchDifferences) {
  const CostInputs bounced(true, 2.0);
  const RefineCost cost = bounced.Cost(true);
  const auto lobes = Lobes();
  RefineJacobian jac;
  const std::vector<double> r0 = Residuals(cost, lobes, &jac);
  for (int lobe = 0; lobe < 2; ++lobe)
    for (int c = 0; c < 3; ++c) {
      auto moved = lobes;
      moved[lobe].amplitude[c] += 1.0;
      const std::vector<double> r1 = Residuals(cost, moved);
      const std::vector<double> column = Column(jac, 2, 3 * 2 + lobe, c);
      double worst = 0, scale = 0;
      for (size_t k = 0; k < r0.size(); ++k) {
        worst = std::max(worst, std::abs((r1[k] - r0[k]) - column[k]));
        scale = std::max(scale, std::abs(r1[k] - r0[k]));
      }
      EXPECT_GT(scale, 0) << "lobe " << lobe << " channel " << c;
      EXPECT_LT(worst, 1e-9 + 1e-5 * scale) << "lobe " << lobe << " channel " << c;
    }
}

// One cost evaluated along a path of parameters (one lobe moved, both,
// back, the sharpness derivative asked for after a residual-only call)
// gives what a fresh cost gives at each point: nothing stale is reused.
// With the form factors prepared, residual-only calls sum the lobes' bounce
// before carrying it to the points, and Jacobian calls carry each lobe's:
// the two agree (and factored form factors too).
TEST(RefineCost, CachedShadingMatchesAFreshCost) {
  for (const auto& [exact_sharpness, form_tolerance] :
       std::vector<std::pair<bool, double>>{{false, -1}, {true, -1}, {false, 0}, {true, 0.1}, {false, 0.1}}) {
    SCOPED_TRACE(std::to_string(exact_sharpness) + " form tolerance " + std::to_string(form_tolerance));
    const CostInputs bounced(true, 1.0, form_tolerance);
    if (form_tolerance >= 0) {
      ASSERT_TRUE(bounced.model.HasBounceForm());
    }
    if (form_tolerance > 0) {
      ASSERT_LT(bounced.model.bounce_form.rank(), 64);
    }
    const RefineCost reused = bounced.Cost(exact_sharpness);
    const auto start = Lobes();
    auto sun_moved = start;
    sun_moved[0].axis = Eigen::Vector3d(0.5, -0.35, 0.79).normalized();
    auto both_moved = sun_moved;
    both_moved[1].sharpness *= std::exp(0.3);
    // One lobe's shading alone may sum in another order than beside another
    // lobe's (float products): equal to rounding, not bitwise.
    auto expect_near = [](const std::vector<double>& a, const std::vector<double>& b, const char* what) {
      EXPECT_LT(Distance(a, b), 1e-5 * Norm(b)) << what;
    };
    for (const auto& lobes : {start, sun_moved, both_moved, start, sun_moved}) {
      const RefineCost fresh = bounced.Cost(exact_sharpness);
      const std::vector<double> r_fresh = Residuals(fresh, lobes);
      expect_near(Residuals(reused, lobes), r_fresh, "residuals");
      RefineJacobian j_reused, j_fresh;
      expect_near(Residuals(reused, lobes, &j_reused), r_fresh, "residuals with Jacobians");
      Residuals(fresh, lobes, &j_fresh);
      for (int col = 0; col < 4 * 2; ++col)
        for (int c = 0; c < 3; ++c)
          expect_near(Column(j_reused, 2, col, c), Column(j_fresh, 2, col, c), "Jacobian column");
    }
  }
}

// Each lobe takes the hints of the lobe nearest its axis, and a cost started
// from them evaluates as a fresh one does, whichever lobe's hints it got:
// the sun turned 2 degrees and the lobes listed the other way round.
TEST(RefineCost, NearestAxisHintsAreSoundForMovedLobes) {
  CostInputs in(false, 1.0);
  in.model.PrepareCones();
  const auto start = Lobes();
  const RefineCost learnt = in.Cost(false);
  Residuals(learnt, start);
  const std::vector<OccluderCones::AngleHints> from = {learnt.Hints(0), learnt.Hints(1)};
  ASSERT_EQ(from[0].axes.size(), 1u);
  std::vector<SgLobe> moved = {start[1], start[0]};
  moved[1].axis = (moved[1].axis + 0.035 * Eigen::Vector3d(1, 1, 0)).normalized();
  const std::vector<OccluderCones::AngleHints> hints = NearestAxisHints(moved, start, from);
  ASSERT_EQ(hints.size(), 2u);
  EXPECT_EQ(hints[0].axes, from[1].axes);
  EXPECT_EQ(hints[1].axes, from[0].axes);
  EXPECT_EQ(hints[1].leaf, from[0].leaf);
  EXPECT_TRUE(NearestAxisHints(moved, start, {}).at(0).axes.empty());
  const std::vector<double> fresh = Residuals(in.Cost(false), moved);
  for (bool swapped : {false, true}) {
    SCOPED_TRACE(swapped ? "each lobe the other's hints" : "nearest hints");
    RefineCost hinted = in.Cost(false);
    hinted.SetHints(0, hints[swapped ? 1 : 0]);
    hinted.SetHints(1, hints[swapped ? 0 : 1]);
    EXPECT_LT(Distance(Residuals(hinted, moved), fresh), 1e-6 * Norm(fresh));
  }
}

// CostExceeds says yes only where the full cost is above the limit: a step
// far off (the sun turned 25 degrees, the sky 20x brighter) is shown more
// costly than the start on a sample of the points, no limit at or above a
// cost is shown exceeded, and the sample adds the bounce as the residuals
// do (unfactored and factored form factors).
TEST(RefineCost, CostExceedsOnlyAboveTheFullCost) {
  for (double form_tolerance : {-1.0, 0.1}) {
    SCOPED_TRACE("form tolerance " + std::to_string(form_tolerance));
    CostInputs in(true, 1.0, form_tolerance);
    in.model.PrepareCones();
    const RefineCost cost = in.Cost(false);
    auto half_cost = [&](const std::vector<SgLobe>& lobes) {
      double s = 0;
      for (double r : Residuals(cost, lobes)) s += r * r;
      return 0.5 * s;
    };
    const auto start = Lobes();
    auto far = start;
    far[0].axis = Eigen::Vector3d(0.2, 0.35, 0.92).normalized();
    far[1].amplitude *= 20;
    const double f_start = half_cost(start), f_far = half_cost(far);
    ASSERT_GT(f_far, 20 * f_start);
    EXPECT_TRUE(cost.CostExceeds(far, f_start));
    EXPECT_FALSE(cost.CostExceeds(far, f_far));
    EXPECT_FALSE(cost.CostExceeds(start, f_start));
    // The bounce counts: the same far step without it costs less on the sample.
    CostInputs direct(false, 1.0);
    direct.model.PrepareCones();
    const RefineCost no_bounce = direct.Cost(false);
    double lo = 0, hi = f_far;  // the smallest limit each is shown above, by bisection
    auto threshold = [&](const RefineCost& c) {
      lo = 0, hi = f_far;
      for (int i = 0; i < 40; ++i) {
        const double mid = 0.5 * (lo + hi);
        (c.CostExceeds(far, mid) ? lo : hi) = mid;
      }
      return lo;
    };
    EXPECT_GT(threshold(cost), threshold(no_bounce));
  }
}

}  // namespace
}  // namespace shadowsg
