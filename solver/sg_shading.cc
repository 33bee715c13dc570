#include "solver/sg_shading.h"

#include <cmath>
#include <limits>

#include "solver/cosine_integral.h"

namespace shadowsg {

ProductLobe EvalProductLobe(const Eigen::Vector3d& mu, double lambda, const Eigen::Vector3d& n, CosineModel cosine,
                            bool derivatives, double max_steepness) {
  ProductLobe p;
  p.max_steepness = max_steepness;
  const Eigen::Vector3d v = lambda * mu + kCosineLobeSharpness * n;
  const double lp = v.norm();
  p.lambda_prime = lp;
  p.exp_minus_2lp = std::exp(-2 * lp);
  const double e = std::exp(lp - lambda - kCosineLobeSharpness);
  const double em = std::exp(-lp);
  const double f = 2 * M_PI * (1 - em) / lp;                 // hemisphere integral factor
  const double df = 2 * M_PI * (lp * em - (1 - em)) / (lp * lp);  // d f / d lambda'
  p.scale = kCosineLobeAmplitude * e * f;
  p.dlambda_prime_dlambda = v.dot(mu) / lp;
  p.dlambda_prime_dmu = lambda * v / lp;
  // d scale / d lambda' = a_c e (f + df); d scale / d lambda (explicit) = -scale.
  const double ds_dlp = kCosineLobeAmplitude * e * (f + df);
  p.dscale_dlambda = ds_dlp * p.dlambda_prime_dlambda - p.scale;
  p.dscale_dmu = ds_dlp * p.dlambda_prime_dmu;
  if (cosine == CosineModel::kExact && !derivatives) {
    constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
    p.scale = SgCosineIntegralValue(lambda, mu.dot(n));
    p.dscale_dlambda = kNaN;
    p.dscale_dmu = Eigen::Vector3d::Constant(kNaN);
  } else if (cosine == CosineModel::kExact) {
    const CosineIntegral ci = SgCosineIntegral(lambda, mu.dot(n));
    p.scale = ci.value;
    p.dscale_dlambda = ci.dlambda;
    p.dscale_dmu = ci.dc * n;
  }
  return p;
}

LobeShading ShadeLobe(const ProductLobe& p, double theta, const Eigen::Vector3d& dtheta_dmu, double occluder_cos) {
  LobeShading s;
  const double k = p.steepness();
  const double z = k * theta;
  // Fully visible: no occluder at all, or the sigmoid saturated (most (point,
  // lobe) pairs of a sharp lobe, whose shadow covers little of the plane; the
  // terms dropped are 1e-13 of those kept).
  if (!std::isfinite(theta) || z >= kSigmoidSaturation) {
    s.sigma = 1;
    s.value = p.scale;
    s.dvalue_dlambda = p.dscale_dlambda;
    s.dvalue_dmu = p.dscale_dmu;
    return s;
  }
  const double dk = p.dsteepness();
  // One exponential a point: glibc's exp may set errno, so the compiler
  // does not merge two calls.
  if (z >= 0) {
    s.sigma = 1 / (1 + std::exp(-z));
  } else {
    const double ez = std::exp(z);
    s.sigma = ez / (1 + ez);
  }
  const double dsig_dz = s.sigma * (1 - s.sigma);
  if (occluder_cos < -1) {
    s.value = p.scale * s.sigma;
    s.dvalue_dlambda = p.dscale_dlambda * s.sigma + p.scale * dsig_dz * dk * p.dlambda_prime_dlambda * theta;
    s.dvalue_dmu = p.dscale_dmu * s.sigma + p.scale * dsig_dz * (dk * theta * p.dlambda_prime_dmu + k * dtheta_dmu);
    return s;
  }
  const double lp = p.lambda_prime, h = 1 - occluder_cos;
  const double ea = std::exp(-lp * h), e2 = p.exp_minus_2lp >= 0 ? p.exp_minus_2lp : std::exp(-2 * lp);
  const double den = 1 - e2;
  const double F = (1 - ea) / den;
  const double dF = (h * ea * den - (1 - ea) * 2 * e2) / (den * den);  // dF / d lambda'
  const double V = 1 - (1 - s.sigma) * F;
  // dV = sigma' F dz - (1 - sigma) dF dlambda', dz = dk theta dlambda' + k dtheta.
  const double dV_dlp = dsig_dz * F * dk * theta - (1 - s.sigma) * dF;
  s.sigma = V;
  s.value = p.scale * V;
  s.dvalue_dlambda = p.dscale_dlambda * V + p.scale * dV_dlp * p.dlambda_prime_dlambda;
  s.dvalue_dmu = p.dscale_dmu * V + p.scale * (dV_dlp * p.dlambda_prime_dmu + dsig_dz * F * k * dtheta_dmu);
  return s;
}

}  // namespace shadowsg
