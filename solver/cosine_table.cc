#include "solver/cosine_table.h"

#include <algorithm>
#include <cmath>

#include "solver/cosine_integral.h"

namespace shadowsg {
namespace {

constexpr float kTable[kCosineTableLambdas * kCosineTableCosines] = {
#include "cosine_table.inc"
};

}  // namespace

const float* SgCosineTableRow(int l) { return &kTable[l * kCosineTableCosines]; }

double SgCosineIntegralTabulated(double lambda, double c) {
  const double power = 2 * M_PI * -std::expm1(-2 * lambda) / lambda;
  const double x =
      std::clamp((std::log(lambda) - kCosineTableLogMin) / (kCosineTableLogMax - kCosineTableLogMin), 0.0, 1.0) *
      (kCosineTableLambdas - 1);
  const double y = (std::clamp(c, -1.0, 1.0) + 1) / 2 * (kCosineTableCosines - 1);
  const int l = std::min(static_cast<int>(x), kCosineTableLambdas - 2);
  const int k = std::min(static_cast<int>(y), kCosineTableCosines - 2);
  const double fx = x - l, fy = y - k;
  const float* f0 = SgCosineTableRow(l);
  const float* f1 = SgCosineTableRow(l + 1);
  const double v = (1 - fx) * ((1 - fy) * f0[k] + fy * f0[k + 1]) + fx * ((1 - fy) * f1[k] + fy * f1[k + 1]);
  return power * v;
}

}  // namespace shadowsg
