#include "solver/cosine_integral.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "solver/cosine_table.h"

namespace shadowsg {
namespace {

// 16-point Gauss-Legendre nodes and weights on [-1, 1].
constexpr std::array<double, 8> kNodes = {0.0950125098376374, 0.2816035507792589, 0.4580167776572274,
                                          0.6178762444026438, 0.7554044083550030, 0.8656312023878318,
                                          0.9445750230732326, 0.9894009349916499};
constexpr std::array<double, 8> kWeights = {0.1894506104550685, 0.1826034150449236, 0.1691565193950025,
                                            0.1495959888165767, 0.1246289712555339, 0.0951585116824928,
                                            0.0622535239386479, 0.0271524594117541};

// Geometric refinement levels towards segment ends (see ValueQuadrature),
// and towards each end of the band between the kinks (ValueSplit: 6 gave
// 2e-7 of the lobe's power against a fine quadrature in x split at the
// kinks, lambda 0.5-5000; 4 gave 1.8e-6).
constexpr int kGradedLevels = 24;
constexpr int kBandLevels = 6;

// Integral over the azimuth around mu of max(A + B cos(phi), 0), B >= 0.
double AzimuthIntegral(double A, double B) {
  if (B <= std::abs(A)) return A > 0 ? 2 * M_PI * A : 0.0;
  const double phi0 = std::acos(std::clamp(-A / B, -1.0, 1.0));
  return 2 * (A * phi0 + std::sqrt(std::max(0.0, B * B - A * A)));
}

// One piece [lo, hi] of 16-point Gauss-Legendre, added to *sum node by node.
template <typename F>
void GaussPiece(double lo, double hi, const F& f, double* sum) {
  const double mid = 0.5 * (lo + hi), half = 0.5 * (hi - lo);
  for (size_t k = 0; k < kNodes.size(); ++k)
    for (double sign : {-1.0, 1.0}) *sum += kWeights[k] * half * f(mid + sign * half * kNodes[k]);
}

// The integral over [a, b] on pieces graded geometrically towards b.
template <typename F>
double GradedGauss(double a, double b, const F& f) {
  double sum = 0, lo = a;
  for (int level = 1; level <= kGradedLevels; ++level) {
    const double hi = b - (b - a) * std::ldexp(1.0, -level);
    GaussPiece(lo, hi, f, &sum);
    lo = hi;
  }
  GaussPiece(lo, b, f, &sum);
  return sum;
}

// The same rule graded towards both ends (levels each way from the middle):
// the band's integrand has a square-root kink at both.
template <typename F>
double GradedGaussBothEnds(double a, double b, int levels, const F& f) {
  double sum = 0;
  const double w = b - a;
  for (int level = 1; level <= levels; ++level) {
    GaussPiece(a + w * std::ldexp(1.0, -level - 1), a + w * std::ldexp(1.0, -level), f, &sum);
    GaussPiece(b - w * std::ldexp(1.0, -level), b - w * std::ldexp(1.0, -level - 1), f, &sum);
  }
  GaussPiece(a, a + w * std::ldexp(1.0, -levels - 1), f, &sum);
  GaussPiece(b - w * std::ldexp(1.0, -levels - 1), b, f, &sum);
  return sum;
}

// C's integrand after the substitution u in [0, 1]: exp(-lambda t) dt =
// (1 - e^{-2 lambda}) / lambda du with t = 1 - cos(theta), the azimuth
// integral at cos(theta) = 1 - t(u) (both quadratures below).
struct IntegrandInU {
  double lambda, c, s, q;  // s = sqrt(1 - c^2), q = 1 - e^{-2 lambda}
  IntegrandInU(double lambda_in, double c_in)
      : lambda(lambda_in),
        c(std::clamp(c_in, -1.0, 1.0)),
        s(std::sqrt(std::max(0.0, 1 - c * c))),
        q(-std::expm1(-2 * lambda)) {}
  // t in [0, 2]; u * q can round to 1 for large lambda, where t = 2 (theta = pi).
  double T(double u) const { return u * q < 1 ? std::min(2.0, -std::log1p(-u * q) / lambda) : 2.0; }
  double operator()(double u) const {
    const double x = 1 - T(u);  // cos(theta)
    const double sn = std::sqrt(std::max(0.0, 1 - x * x));
    return AzimuthIntegral(c * x, s * sn);
  }
};

// Below this sharpness the closed form of the outer parts (ValueSplit)
// cancels to ~1e-16 / lambda relative: the whole quadrature instead.
constexpr double kClosedFormMinLambda = 0.01;

// C in u, split where the azimuth integrand has kinks.
double ValueQuadrature(double lambda, double c_in) {
  const IntegrandInU f(lambda, c_in);
  auto u_of_theta = [&](double theta) {
    const double t = 1 - std::cos(theta);
    return -std::expm1(-lambda * t) / f.q;
  };
  // Kinks at theta = |pi/2 - theta_n| and pi/2 + theta_n, theta_n = acos(c).
  const double theta_n = std::acos(f.c);
  std::array<double, 4> cuts = {0.0, u_of_theta(std::abs(M_PI / 2 - theta_n)),
                                theta_n < M_PI / 2 ? u_of_theta(M_PI / 2 + theta_n) : 1.0, 1.0};
  std::sort(cuts.begin(), cuts.end());
  double sum = 0;
  // t(u) has a logarithmic singularity at u = 1 (theta = pi for large
  // lambda): grade the pieces geometrically towards each segment's end.
  for (int seg = 0; seg + 1 < 4; ++seg)
    if (cuts[seg + 1] > cuts[seg]) sum += GradedGauss(cuts[seg], cuts[seg + 1], f);
  return f.q / lambda * sum;
}

// C split at the kinks x = cos(theta) = +-s (s = sin(theta_n)). Outside
// [-s, s] the plane's horizon misses the ring of directions at theta: the
// azimuth integral is 2 pi c x where c x > 0 and 0 elsewhere, so those parts
// are integral of 2 pi c x e^{lambda (x - 1)} dx in closed form. Only the
// band between needs the quadrature (the same rule, in the same u, on 14
// pieces against ValueQuadrature's 75), and for c < 0 the kink at x = -s no
// longer falls inside a piece.
double ValueSplit(double lambda, double c_in) {
  const IntegrandInU f(lambda, c_in);
  const double c = f.c, s = f.s;
  // integral over [a, b] of x e^{lambda (x - 1)} dx, from [e^{lambda (x - 1)} (x / lambda - 1 / lambda^2)].
  auto moment = [&](double a, double b) {
    const double ea = std::exp(lambda * (a - 1)), eb = std::exp(lambda * (b - 1));
    return (b * eb - a * ea) / lambda + eb * std::expm1(-lambda * (b - a)) / (lambda * lambda);
  };
  double outer = 0;
  if (c > 0) outer = 2 * M_PI * c * moment(s, 1.0);
  else if (c < 0) outer = 2 * M_PI * c * moment(-1.0, -s);
  if (!(s > 0)) return outer;
  auto u_of_x = [&](double x) { return -std::expm1(-lambda * (1 - x)) / f.q; };
  const double a = u_of_x(s), b = u_of_x(-s);
  return outer + (b > a ? f.q / lambda * GradedGaussBothEnds(a, b, kBandLevels, f) : 0.0);
}

double Value(double lambda, double c) {
  return lambda < kClosedFormMinLambda ? ValueQuadrature(lambda, c) : ValueSplit(lambda, c);
}

}  // namespace

double SgCosineIntegralValue(double lambda, double c) { return Value(lambda, c); }

CosineIntegral SgCosineIntegral(double lambda, double c) {
  CosineIntegral r;
  r.value = Value(lambda, c);
  // Central differences: the integrand is smooth in lambda and c away from
  // c = +-1, where a one-sided step keeps inside the domain.
  const double hl = 1e-5 * lambda;
  r.dlambda = (Value(lambda + hl, c) - Value(lambda - hl, c)) / (2 * hl);
  const double hc = 1e-6;
  const double c0 = std::clamp(c - hc, -1.0, 1.0), c1 = std::clamp(c + hc, -1.0, 1.0);
  r.dc = (Value(lambda, c1) - Value(lambda, c0)) / (c1 - c0);
  return r;
}

double SgCosineTableEntry(int l, int k) {
  const double lambda = std::exp(kCosineTableLogMin + (kCosineTableLogMax - kCosineTableLogMin) * l /
                                                          (kCosineTableLambdas - 1));
  const double c = -1 + 2.0 * k / (kCosineTableCosines - 1);
  return Value(lambda, c) * lambda / (2 * M_PI * -std::expm1(-2 * lambda));
}

}  // namespace shadowsg
