#include <gtest/gtest.h>

#include <cmath>

#include "solver/cosine_integral.h"
#include "solver/cosine_table.h"
#include "solver/sg_shading.h"
#include "solver/shadow_plane.h"
#include "solver/sphere_tree.h"
#include "solver/ssdf.h"
#include "sg_test_scene.h"

namespace shadowsg {
namespace {

using testing::TestCasterTree;
using testing::TestPlaneModel;

double RelErr(double a, double b) { return std::abs(a - b) / std::max({std::abs(a), std::abs(b), 1e-12}); }

TEST(CosineIntegral, MatchesBruteForceQuadrature) {
  for (double lambda : {0.5, 3.0, 40.0})
    for (double c : {1.0, 0.7, 0.0, -0.4}) {
      // Midpoint rule on a fine (theta, phi) grid about mu = +z, n in the xz-plane.
      const Eigen::Vector3d n(std::sqrt(1 - c * c), 0, c);
      const int nt = 2000, np = 400;
      double sum = 0;
      for (int i = 0; i < nt; ++i) {
        const double th = M_PI * (i + 0.5) / nt;
        for (int j = 0; j < np; ++j) {
          const double ph = 2 * M_PI * (j + 0.5) / np;
          const Eigen::Vector3d w(std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th));
          sum += std::exp(lambda * (w.z() - 1)) * std::max(0.0, n.dot(w)) * std::sin(th);
        }
      }
      sum *= (M_PI / nt) * (2 * M_PI / np);
      // The midpoint rule on the kinked integrand is itself good to ~1e-3.
      EXPECT_NEAR(SgCosineIntegral(lambda, c).value, sum, 1.5e-3 * std::max(sum, 1e-3)) << lambda << " " << c;
    }
  // n = mu in closed form: 2 pi (1/lambda - (1 - e^-lambda) / lambda^2).
  for (double lambda : {0.5, 3.0, 40.0, 700.0})
    EXPECT_NEAR(SgCosineIntegral(lambda, 1.0).value,
                2 * M_PI * (1 / lambda - (1 - std::exp(-lambda)) / (lambda * lambda)), 1e-9);
  // A sharp lobe is a directional light: C -> 2 pi / lambda * max(c, 0).
  EXPECT_NEAR(SgCosineIntegral(1e4, 0.6).value * 1e4 / (2 * M_PI), 0.6, 1e-3);
}

// Against a fine quadrature in x = cos(theta) (about mu), split where the
// plane's horizon starts and stops cutting the ring of directions at theta
// (x = +-sin(theta_n)), 3-point Gauss on 20000 cells a piece: good to about
// 1e-6 of the lobe's power. The integral once graded towards one end of its
// pieces only was off by up to 5.6e-6 (c near 0, and c < 0 where a kink fell
// inside a piece).
TEST(CosineIntegral, MatchesAFineQuadratureSplitAtTheKinks) {
  auto azimuth = [](double a, double b) {  // integral over phi of max(a + b cos(phi), 0)
    if (b <= std::abs(a)) return a > 0 ? 2 * M_PI * a : 0.0;
    return 2 * (a * std::acos(std::clamp(-a / b, -1.0, 1.0)) + std::sqrt(std::max(0.0, b * b - a * a)));
  };
  for (double lambda : {0.05, 0.5, 4.0, 60.0, 1000.0})
    for (double c : {-0.99, -0.3, -0.001, 0.0, 0.02, 0.7, 1.0}) {
      const double s = std::sqrt(std::max(0.0, 1 - c * c));
      const std::array<double, 4> cuts = {-1, -s, s, 1};
      double sum = 0;
      for (int g = 0; g < 3; ++g) {
        const int n = 20000;
        const double h = (cuts[g + 1] - cuts[g]) / n, o = std::sqrt(0.6) * h / 2;
        for (int i = 0; i < n && h > 0; ++i) {
          const double m = cuts[g] + (i + 0.5) * h;
          for (const auto& [x, w] : {std::pair{m - o, 5.0 / 18}, std::pair{m, 8.0 / 18}, std::pair{m + o, 5.0 / 18}})
            sum += w * h * std::exp(lambda * (x - 1)) * azimuth(c * x, s * std::sqrt(std::max(0.0, 1 - x * x)));
        }
      }
      const double power = 2 * M_PI * -std::expm1(-2 * lambda) / lambda;
      EXPECT_NEAR(SgCosineIntegral(lambda, c).value, sum, 2e-6 * power) << lambda << " " << c;
    }
}

TEST(CosineIntegral, TabulatedMatchesTheQuadrature) {
  // Within 2e-3 of the lobe's power (2 pi (1 - e^-2 lambda) / lambda), off
  // the table's nodes too, and beyond its sharpness range.
  for (double lambda : {0.05, 0.37, 2.9, 17.0, 133.0, 950.0, 4000.0, 3e4})
    for (double c = -1; c <= 1.0001; c += 0.0937) {
      const double power = 2 * M_PI * -std::expm1(-2 * lambda) / lambda;
      EXPECT_NEAR(SgCosineIntegralTabulated(lambda, c), SgCosineIntegral(lambda, c).value, 2e-3 * power)
          << lambda << " " << c;
    }
}

TEST(CosineIntegral, BuiltTableIsTheQuadratureRoundedToFloat) {
  // The build's generator and the solver share the quadrature's object
  // file, so every entry must come out bit for bit.
  for (int l = 0; l < kCosineTableLambdas; ++l)
    for (int k = 0; k < kCosineTableCosines; ++k)
      ASSERT_EQ(SgCosineTableRow(l)[k], static_cast<float>(SgCosineTableEntry(l, k))) << l << " " << k;
}

TEST(CosineIntegral, PaperFitIsOffAt45Degrees) {
  // method-notes.md: the one-SG cosine gives 0.626 instead of 0.707 at 45 deg
  // for a sharp light; the exact integral does not.
  const double lambda = 2000, c = std::cos(M_PI / 4);
  const Eigen::Vector3d n(0, 0, 1), mu(std::sin(M_PI / 4), 0, c);
  const double sg = EvalProductLobe(mu, lambda, n, CosineModel::kSgProduct).scale * lambda / (2 * M_PI);
  const double exact = EvalProductLobe(mu, lambda, n, CosineModel::kExact).scale * lambda / (2 * M_PI);
  EXPECT_NEAR(exact, c, 2e-3);
  EXPECT_NEAR(sg, 0.626, 0.01);
}

// Central differences of ProductLobe's scale and lambda' in double precision.
TEST(SgShading, ProductLobeDerivatives) {
  const Eigen::Vector3d n = Eigen::Vector3d(0.1, -0.2, 1).normalized();
  for (CosineModel cm : {CosineModel::kSgProduct, CosineModel::kExact})
    for (double lambda : {1.5, 12.0, 90.0}) {
      const Eigen::Vector3d mu = Eigen::Vector3d(0.4, 0.3, 0.8).normalized();
      const ProductLobe p = EvalProductLobe(mu, lambda, n, cm);
      const double h = 1e-4 * lambda;
      const double fd = (EvalProductLobe(mu, lambda + h, n, cm).scale - EvalProductLobe(mu, lambda - h, n, cm).scale) / (2 * h);
      EXPECT_LT(RelErr(p.dscale_dlambda, fd), 1e-4);
      for (int d = 0; d < 3; ++d) {
        Eigen::Vector3d e = Eigen::Vector3d::Zero();
        e[d] = 1e-5;
        const double fdm = (EvalProductLobe(mu + e, lambda, n, cm).scale - EvalProductLobe(mu - e, lambda, n, cm).scale) / 2e-5;
        EXPECT_LT(std::abs(p.dscale_dmu[d] - fdm), 1e-4 * std::max(1e-3, p.dscale_dmu.norm()));
        if (cm == CosineModel::kSgProduct) {
          const double fdl = (EvalProductLobe(mu + e, lambda, n).lambda_prime - EvalProductLobe(mu - e, lambda, n).lambda_prime) / 2e-5;
          EXPECT_LT(std::abs(p.dlambda_prime_dmu[d] - fdl), 1e-4 * p.dlambda_prime_dmu.norm());
        }
      }
    }
}

// Without derivatives the exact integral is the same value; its derivatives
// are NaN so that a caller who needed them cannot miss it.
TEST(SgShading, ProductLobeWithoutDerivatives) {
  const Eigen::Vector3d n = Eigen::Vector3d(0.1, -0.2, 1).normalized();
  const Eigen::Vector3d mu = Eigen::Vector3d(0.4, 0.3, 0.8).normalized();
  for (double lambda : {0.5, 12.0, 900.0}) {
    const ProductLobe full = EvalProductLobe(mu, lambda, n, CosineModel::kExact);
    const ProductLobe bare = EvalProductLobe(mu, lambda, n, CosineModel::kExact, /*derivatives=*/false);
    EXPECT_EQ(bare.scale, full.scale);
    EXPECT_EQ(bare.lambda_prime, full.lambda_prime);
    EXPECT_TRUE(std::isnan(bare.dscale_dlambda));
    EXPECT_TRUE(bare.dscale_dmu.array().isNaN().all());
    const ProductLobe product = EvalProductLobe(mu, lambda, n, CosineModel::kSgProduct, false);
    EXPECT_EQ(product.dscale_dlambda, EvalProductLobe(mu, lambda, n).dscale_dlambda);
  }
}

// Witness direction of the minimum, by brute force in double precision.
Eigen::Vector3d BruteWitness(const std::vector<SphereTree>& trees, const Eigen::Vector3d& x, const Eigen::Vector3d& mu) {
  const double theta = SignedAngleBruteForce(trees, x, mu);
  for (const auto& t : trees)
    for (size_t i = t.LevelBegin(t.levels - 1); i < t.nodes.size(); ++i) {
      if (t.nodes[i].empty()) continue;
      if (std::abs(SignedAngleBruteForce({SphereTree{1, 2, {t.nodes[i]}}}, x, mu) - theta) < 1e-12)
        return (t.nodes[i].centre - x).normalized();
    }
  return Eigen::Vector3d::Zero();
}

// The shading of one lobe through theta(mu): value and d/dmu, d/dlambda
// against central differences, in double precision, at points near and far
// from shadow boundaries (away from the min's switching points).
TEST(SgShading, LobeShadingDerivativesThroughTheta) {
  const std::vector<SphereTree> trees = {testing::TestCasterTree()};
  const Eigen::Vector3d n = Eigen::Vector3d::UnitZ();
  int checked = 0;
  for (const Eigen::Vector3d& x : {Eigen::Vector3d(0.3, 0.2, 0), Eigen::Vector3d(-0.5, 0.1, 0), Eigen::Vector3d(0.9, -0.7, 0)})
    for (double lambda : {2.0, 8.0})
      for (const Eigen::Vector3d& mu0 : {Eigen::Vector3d(-0.5, -0.3, 0.8), Eigen::Vector3d(0.6, -0.1, 0.7)}) {
        const Eigen::Vector3d mu = mu0.normalized();
        auto shade = [&](const Eigen::Vector3d& m, double l, bool grad) {
          const Eigen::Vector3d mm = m.normalized();
          const double theta = SignedAngleBruteForce(trees, x, mm);
          Eigen::Vector3d dtheta = Eigen::Vector3d::Zero();
          if (grad) {
            const Eigen::Vector3d u = BruteWitness(trees, x, mm);
            const double c = u.dot(mm);
            dtheta = -u / std::sqrt(1 - c * c);
          }
          return ShadeLobe(EvalProductLobe(mm, l, n, CosineModel::kExact), theta, dtheta);
        };
        const LobeShading s = shade(mu, lambda, true);
        const double h = 1e-6;
        const double fdl = (shade(mu, lambda + h, false).value - shade(mu, lambda - h, false).value) / (2 * h);
        EXPECT_LT(RelErr(s.dvalue_dlambda, fdl), 1e-4);
        // Derivative along two tangent directions (the value depends on mu/|mu|).
        const Eigen::Vector3d t1 = mu.unitOrthogonal(), t2 = mu.cross(t1);
        for (const Eigen::Vector3d& t : {t1, t2}) {
          const double fd = (shade(mu + h * t, lambda, false).value - shade(mu - h * t, lambda, false).value) / (2 * h);
          EXPECT_LT(std::abs(s.dvalue_dmu.dot(t) - fd), 1e-4 * std::max(std::abs(fd), 1e-3 * s.value))
              << "x " << x.transpose() << " mu " << mu.transpose() << " lambda " << lambda;
          ++checked;
        }
      }
  EXPECT_EQ(checked, 24);
}

// Past the sigmoid's saturation ShadeLobe returns the unoccluded integral
// without evaluating the sigmoid: no step where it starts, with and without
// the occluder cap.
TEST(SgShading, SaturatedVisibilityJoinsTheSigmoidWithoutAStep) {
  const Eigen::Vector3d n = Eigen::Vector3d::UnitZ();
  int checked = 0;
  for (double lambda : {0.5, 8.0, 250.0})
    for (double occluder_cos : {kNoOcclusionCap, 0.9, 0.2}) {
      const ProductLobe p = EvalProductLobe(Eigen::Vector3d(0.3, -0.2, 0.9).normalized(), lambda, n, CosineModel::kExact);
      const double at = kSigmoidSaturation / VisibilitySteepness(p.lambda_prime);
      const Eigen::Vector3d dtheta(0.4, -1.1, 0.2);
      const LobeShading below = ShadeLobe(p, at * (1 - 1e-9), dtheta, occluder_cos);
      const LobeShading past = ShadeLobe(p, at * (1 + 1e-9), dtheta, occluder_cos);
      EXPECT_EQ(past.value, p.scale);
      EXPECT_EQ(past.dvalue_dlambda, p.dscale_dlambda);
      EXPECT_LT(std::abs(below.value - past.value), 1e-12 * p.scale) << lambda << " " << occluder_cos;
      EXPECT_LT(std::abs(below.dvalue_dlambda - past.dvalue_dlambda), 1e-9 * (std::abs(p.dscale_dlambda) + p.scale));
      // What is left of the sigmoid's slope there is 1e-13 of its steepest.
      const double k = VisibilitySteepness(p.lambda_prime);
      EXPECT_LT((below.dvalue_dmu - past.dvalue_dmu).norm(), 1e-12 * (p.dscale_dmu.norm() + p.scale * k * dtheta.norm()));
      // Short of saturation the sigmoid still acts.
      EXPECT_LT(ShadeLobe(p, 0.5 * at, dtheta, occluder_cos).value, p.scale);
      ++checked;
    }
  EXPECT_EQ(checked, 9);
}

// EvalProductLobe keeps e^{-2 lambda'} for the occluder cap; a ProductLobe
// filled in by hand (exp_minus_2lp unset) shades the same, in and out of
// shadow (theta < 0 and > 0 take the sigmoid's two branches).
TEST(SgShading, OccluderCapWithAndWithoutTheKeptExponential) {
  const Eigen::Vector3d n = Eigen::Vector3d::UnitZ(), dtheta(0.4, -1.1, 0.2);
  for (double lambda : {0.5, 8.0, 250.0}) {
    const ProductLobe kept = EvalProductLobe(Eigen::Vector3d(0.3, -0.2, 0.9).normalized(), lambda, n, CosineModel::kExact);
    ASSERT_EQ(kept.exp_minus_2lp, std::exp(-2 * kept.lambda_prime));
    ProductLobe unset = kept;
    unset.exp_minus_2lp = -1;
    for (double theta : {-0.05, -0.001, 0.0, 0.002, 0.04})
      for (double occluder_cos : {0.9, 0.2}) {
        const LobeShading a = ShadeLobe(kept, theta, dtheta, occluder_cos), b = ShadeLobe(unset, theta, dtheta, occluder_cos);
        EXPECT_EQ(a.value, b.value) << lambda << " " << theta;
        EXPECT_EQ(a.dvalue_dlambda, b.dvalue_dlambda);
        EXPECT_EQ(a.dvalue_dmu, b.dvalue_dmu);
        if (theta <= 0) {
          EXPECT_LT(a.value, kept.scale);  // in shadow: the cap and the sigmoid act
        }
      }
  }
}

// `sg` caps the sigmoid's steepness (kSgMaxVisibilitySteepness); the paper's
// model does not. A sharp lobe then keeps a finite shadow edge whose width
// the cap sets, its derivatives stay consistent, and the occluder searches
// stop where the capped sigmoid saturates; a broad lobe is shaded as before.
TEST(SgShading, SgCapsTheSigmoidSteepnessOfSharpLobes) {
  const Eigen::Vector3d n = Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d mu = Eigen::Vector3d(0.3, -0.2, 0.9).normalized();
  const Eigen::Vector3d dtheta(0.4, -1.1, 0.2);
  const ProductLobe paper = EvalProductLobe(mu, 250.0, n, CosineModel::kExact, true, kUncappedSteepness);
  const ProductLobe sg = EvalProductLobe(mu, 250.0, n, CosineModel::kExact, true, kSgMaxVisibilitySteepness);
  EXPECT_GT(paper.steepness(), 1e6);
  EXPECT_EQ(sg.steepness(), kSgMaxVisibilitySteepness);
  EXPECT_EQ(sg.dsteepness(), 0.0);
  // 1e-3 rad outside the occluder: the paper's edge is long past, sg's is not.
  const double theta = 1e-3;
  EXPECT_EQ(ShadeLobe(paper, theta, dtheta).value, paper.scale);
  EXPECT_NEAR(ShadeLobe(sg, theta, dtheta).value / sg.scale, 1 / (1 + std::exp(-kSgMaxVisibilitySteepness * theta)),
              1e-12);
  EXPECT_FLOAT_EQ(VisibilityCap(sg), static_cast<float>(kSigmoidSaturation / kSgMaxVisibilitySteepness));
  EXPECT_EQ(ShadeLobe(sg, VisibilityCap(sg) * (1 + 1e-6), dtheta).value, sg.scale);
  // The capped lobe's sharpness derivative (the steepness constant there)
  // against central differences, with and without the occluder cap.
  for (double occluder_cos : {kNoOcclusionCap, 0.95}) {
    const double h = 1e-4;
    auto value = [&](double l) {
      return ShadeLobe(EvalProductLobe(mu, l, n, CosineModel::kExact, true, kSgMaxVisibilitySteepness), -theta, dtheta,
                       occluder_cos).value;
    };
    const LobeShading s = ShadeLobe(sg, -theta, dtheta, occluder_cos);
    EXPECT_LT(RelErr(s.dvalue_dlambda, (value(250.0 + h) - value(250.0 - h)) / (2 * h)), 1e-5) << occluder_cos;
  }
  // Below the cap (a broad lobe) both models shade alike.
  const ProductLobe broad_paper = EvalProductLobe(mu, 2.0, n, CosineModel::kExact, true, kUncappedSteepness);
  const ProductLobe broad_sg = EvalProductLobe(mu, 2.0, n, CosineModel::kExact, true, kSgMaxVisibilitySteepness);
  EXPECT_EQ(ShadeLobe(broad_paper, -0.05, dtheta, 0.6).value, ShadeLobe(broad_sg, -0.05, dtheta, 0.6).value);
}

// MseAndGradient assembles the per-lobe derivatives; theta is single
// precision there, so the check is looser than the double-precision ones.
TEST(ShadowPlane, MseGradientMatchesFiniteDifferences) {
  ShadowPlaneModel model = TestPlaneModel(24, CosineModel::kExact);
  model.upper_hemisphere_only = false;
  SgLighting truth;
  truth.lobes.push_back({Eigen::Vector3d(0.5, 0.2, 0.84).normalized(), 6.0, Eigen::Vector3d(2, 1.5, 1)});
  std::vector<Eigen::Vector3f> targets = RenderShadowPlane(model, truth);
  SgLighting guess = truth;
  guess.lobes[0].axis = Eigen::Vector3d(0.45, 0.25, 0.85).normalized();
  guess.lobes[0].sharpness = 5.0;
  guess.lobes[0].amplitude = Eigen::Vector3d(1.8, 1.6, 0.9);
  std::vector<size_t> all(model.points.size());
  for (size_t i = 0; i < all.size(); ++i) all[i] = i;
  Eigen::MatrixXd grad;
  MseAndGradient(model, guess, all, targets, &grad);
  auto loss = [&](const SgLighting& l) { return MseAndGradient(model, l, all, targets, nullptr); };
  for (int d = 0; d < 3; ++d) {
    SgLighting a = guess, b = guess;
    a.lobes[0].amplitude[d] += 1e-4;
    b.lobes[0].amplitude[d] -= 1e-4;
    EXPECT_LT(RelErr(grad(0, 4 + d), (loss(a) - loss(b)) / 2e-4), 1e-4);
  }
  SgLighting a = guess, b = guess;
  a.lobes[0].sharpness += 1e-3;
  b.lobes[0].sharpness -= 1e-3;
  EXPECT_LT(RelErr(grad(0, 3), (loss(a) - loss(b)) / 2e-3), 2e-2);
  const Eigen::Vector3d t = guess.lobes[0].axis.unitOrthogonal();
  a = guess, b = guess;
  a.lobes[0].axis = (guess.lobes[0].axis + 1e-3 * t).normalized();
  b.lobes[0].axis = (guess.lobes[0].axis - 1e-3 * t).normalized();
  EXPECT_LT(RelErr(grad.row(0).segment<3>(0).dot(t), (loss(a) - loss(b)) / 2e-3), 2e-2);
}

TEST(ShadowPlane, NoOccluderMeansFullIrradiance) {
  ShadowPlaneModel model = TestPlaneModel(4, CosineModel::kExact);
  model.occluders.clear();
  SgLighting l;
  l.lobes.push_back({Eigen::Vector3d::UnitZ(), 5000.0, Eigen::Vector3d::Constant(5000 / (2 * M_PI))});
  // A near-delta light of irradiance 1 straight above: L = albedo / pi.
  const auto r = RenderShadowPlane(model, l);
  EXPECT_NEAR(r[0].x(), 0.8 / M_PI, 1e-3);
}

// The compositor's pair: the plane without a second caster and with it,
// the second render searching the added tree only.
TEST(ShadowPlane, RenderAddingOccludersMatchesARenderOfThemAll) {
  ShadowPlaneModel model = TestPlaneModel(40, CosineModel::kExact);
  model.cap_occlusion = true;
  model.upper_hemisphere_only = false;
  model.max_steepness = kSgMaxVisibilitySteepness;
  model.occluder_cos = OccluderConeCosines(model.occluders, model.points);
  Eigen::Matrix4d shift = Eigen::Matrix4d::Identity();
  shift.block<3, 1>(0, 3) = Eigen::Vector3d(0.7, -0.4, 0);
  const std::vector<SphereTree> more = {TransformSphereTree(TestCasterTree(), shift)};
  SgLighting l;
  l.lobes.push_back({Eigen::Vector3d(0.4, 0.3, 0.87).normalized(), 300.0, Eigen::Vector3d(40, 38, 35)});
  l.lobes.push_back({Eigen::Vector3d(-0.5, 0.1, 0.86).normalized(), 30.0, Eigen::Vector3d(3, 3, 4)});
  l.lobes.push_back({Eigen::Vector3d(0.1, -0.2, 0.97).normalized(), 2.0, Eigen::Vector3d(0.5, 0.6, 0.9)});
  std::vector<Eigen::Vector3f> without, with;
  RenderShadowPlaneAdding(model, more, l, &without, &with);

  ShadowPlaneModel all = model;
  all.occluders.push_back(more[0]);
  all.occluder_cos = OccluderConeCosines(all.occluders, all.points);
  const std::vector<Eigen::Vector3f> without_ref = RenderShadowPlane(model, l), with_ref = RenderShadowPlane(all, l);
  ASSERT_EQ(without.size(), model.points.size());
  ASSERT_EQ(with.size(), model.points.size());
  int shadowed = 0;
  for (size_t k = 0; k < model.points.size(); ++k) {
    EXPECT_EQ(without[k], without_ref[k]) << k;
    EXPECT_LT((with[k] - with_ref[k]).norm(), 1e-6 * with_ref[k].norm() + 1e-12) << k;
    shadowed += (with[k] - without[k]).norm() > 1e-3 * without[k].norm();
  }
  // The added caster's shadow is in view.
  EXPECT_GT(shadowed, 20);
}

}  // namespace
}  // namespace shadowsg
