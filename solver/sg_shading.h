// The closed-form shadow-plane shading of one SG lobe at one plane point
// (ShadowSG Sec. 3.2, method-notes.md "The forward model"), with analytic
// derivatives. Everything here is per unit amplitude and per unit albedo/pi:
//   L_o(x) = albedo/pi * sum_i a_i * Shading_i(x).
#pragma once

#include <Eigen/Dense>
#include <algorithm>
#include <limits>

namespace shadowsg {

// Clamped cosine as one SG, max(n.w, 0) ~ a_c exp(lambda_c (w.n - 1))
// (Wang et al. 2009, ACM TOG 28(5):133; the values ShadowSG uses).
inline constexpr double kCosineLobeSharpness = 2.133;
inline constexpr double kCosineLobeAmplitude = 1.170;
// Sigmoid steepness k(x) = k3 x^3 + k2 x^2 + k1 x + k0 of the soft visibility
// (Wang 2009; ShadowSG data/k_coeffs_wang.txt), evaluated at lambda'.
inline constexpr double kVisibilityK3 = 0.204;
inline constexpr double kVisibilityK2 = -0.892;
inline constexpr double kVisibilityK1 = 2.995;
inline constexpr double kVisibilityK0 = 0.067;

// ShadeLobe's occluder_cos meaning "no cap" (the paper's visibility).
inline constexpr double kNoOcclusionCap = -2.0;

// sigmoid(z) = 1 - 9e-14 at z = 30: beyond, a lobe is fully visible (its
// shading is its unoccluded integral, to 1e-13 relative; ShadeLobe returns
// that without the sigmoid and the occluder cap's exponentials, and the
// occluder searches stop there: VisibilityCap).
inline constexpr double kSigmoidSaturation = 30.0;

inline constexpr double VisibilitySteepness(double x) {
  return ((kVisibilityK3 * x + kVisibilityK2) * x + kVisibilityK1) * x + kVisibilityK0;
}
inline double VisibilitySteepnessDerivative(double x) {
  return (3 * kVisibilityK3 * x + 2 * kVisibilityK2) * x + kVisibilityK1;
}

// The paper's steepness grows as lambda'^3: 41000 at lambda' = 60, 3.2e6 at
// 250, shadow edges a thousandth of a degree wide that neither a light nor a
// pixel has. `sg` caps it at k(15) = 533, where the sigmoid's 10-90 % edge
// spans 4.4 / 533 rad = 0.47 degrees, about the sun's disc: a sharp lobe's
// shadow keeps a finite edge, so the fit sees how far it is from the data
// there instead of a step. Fast, 10 seeds (solver/EXPERIMENTS.md): three suns +1.2 dB a
// seed on average, sunrise +0.6 with its seed spread 0.72 -> 0.14 dB, sunsky
// level. A cap of 145 (k(10)) cost sunsky 0.3 dB, 1335 (k(20)) gained less.
// Unbounded: the paper's model.
inline constexpr double kSgMaxVisibilitySteepness = VisibilitySteepness(15.0);
inline constexpr double kUncappedSteepness = std::numeric_limits<double>::infinity();

// How the unoccluded integral of a lobe against the clamped cosine is taken:
// the paper's product with the cosine SG (hemisphere integral about the
// product axis, as the reference code), or exactly (solver/cosine_integral.h).
enum class CosineModel { kSgProduct, kExact };

// Unoccluded irradiance factor of the product lobe G_i * G_c, per unit
// amplitude: a_c exp(lambda' - lambda - lambda_c) 2 pi (1 - exp(-lambda')) / lambda'
// with lambda' = |lambda mu + lambda_c n| (the reference code's form).
struct ProductLobe {
  double lambda_prime = 0;
  double scale = 0;
  // Derivatives (mu treated as a free 3-vector evaluated at |mu| = 1).
  double dlambda_prime_dlambda = 0;
  Eigen::Vector3d dlambda_prime_dmu = Eigen::Vector3d::Zero();
  double dscale_dlambda = 0;
  Eigen::Vector3d dscale_dmu = Eigen::Vector3d::Zero();
  // e^{-2 lambda'}, for ShadeLobe's occluder cap at every point (< 0: not
  // computed, ShadeLobe takes it itself).
  double exp_minus_2lp = -1;
  // The visibility sigmoid's steepness is min(k(lambda'), max_steepness).
  double max_steepness = kUncappedSteepness;
  double steepness() const { return std::min(VisibilitySteepness(lambda_prime), max_steepness); }
  // d steepness / d lambda' (0 where capped).
  double dsteepness() const {
    return VisibilitySteepness(lambda_prime) < max_steepness ? VisibilitySteepnessDerivative(lambda_prime) : 0.0;
  }
};
// With CosineModel::kExact, `scale` and its derivatives are the exact
// integral; lambda' (which sets the shadow's softness) stays as above.
// Without `derivatives` the exact integral's derivatives are NaN (they cost
// four more quadratures); the SG product's are always there.
// max_steepness: ProductLobe::max_steepness (the model's; the paper's uncapped).
ProductLobe EvalProductLobe(const Eigen::Vector3d& mu, double lambda, const Eigen::Vector3d& normal,
                            CosineModel cosine = CosineModel::kSgProduct, bool derivatives = true,
                            double max_steepness = kUncappedSteepness);

// Shading of one lobe at one point given theta (signed angle from mu to the
// nearest occluder boundary) and its gradient with respect to mu.
struct LobeShading {
  double value = 0;            // scale * sigma
  double sigma = 0;
  double dvalue_dlambda = 0;
  Eigen::Vector3d dvalue_dmu = Eigen::Vector3d::Zero();
};
//
// occluder_cos (optional, in [-1, 1]): cosine of the half-angle of a cone
// around the whole caster seen from the point. The sigmoid was fitted to a
// half-space boundary (Wang 2009): for a broad lobe behind a small caster it
// removes far more light than the caster's solid angle can block. With the
// cap, the occluded share is limited to F, the largest fraction of the
// product lobe's energy that a cone of that size can hold:
//   V = 1 - (1 - sigma) F,  F = (1 - e^{-lambda'(1 - cos a)}) / (1 - e^{-2 lambda'}).
// Sharp lobes have F = 1 (the paper's model); `sg` uses it, `sg-paper` not.
LobeShading ShadeLobe(const ProductLobe& product, double theta, const Eigen::Vector3d& dtheta_dmu,
                      double occluder_cos = kNoOcclusionCap);

}  // namespace shadowsg
