#include "solver/sampling.h"

#include <algorithm>
#include <cmath>

#include "calib/error.h"

namespace shadowsg {

namespace {

// Largest double below 1, so that samples stay in [0, 1).
constexpr double kOneMinusEpsilon = 0x1.fffffffffffffp-1;
// Golden-ratio increment of SplitMix64 (Steele et al. 2014).
constexpr uint64_t kGolden = 0x9E3779B97F4A7C15ull;

}  // namespace

uint64_t Mix64(uint64_t x) {
  x += kGolden;
  x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
  x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
  return x ^ (x >> 31);
}

RandomStream::RandomStream(uint64_t seed, uint64_t pixel, uint64_t sample)
    : key_(Mix64(Mix64(Mix64(seed) ^ pixel) ^ sample)) {}

double RandomStream::Uniform() {
  const uint64_t bits = Mix64(key_ ^ Mix64(counter_++));
  return std::min(static_cast<double>(bits >> 11) * 0x1.0p-53, kOneMinusEpsilon);
}

Distribution1D::Distribution1D(const std::vector<double>& weights) : weights_(weights) {
  SHADOWSG_CHECK(!weights.empty());
  const size_t n = weights.size();
  cdf_.assign(n + 1, 0.0);
  for (size_t i = 0; i < n; ++i) {
    SHADOWSG_CHECK(weights[i] >= 0 && std::isfinite(weights[i]));
    cdf_[i + 1] = cdf_[i] + weights[i];
  }
  total_ = cdf_[n];
  if (total_ <= 0) {
    std::fill(weights_.begin(), weights_.end(), 1.0);
    for (size_t i = 0; i <= n; ++i) cdf_[i] = static_cast<double>(i) / n;
  } else {
    for (size_t i = 1; i <= n; ++i) cdf_[i] /= total_;
  }
  cdf_[n] = 1.0;
}

int Distribution1D::SampleDiscrete(double u, double* probability) const {
  // The last cell whose cdf start is <= u, skipping empty cells.
  const auto it = std::upper_bound(cdf_.begin(), cdf_.end(), u);
  int cell = std::clamp(static_cast<int>(it - cdf_.begin()) - 1, 0, size() - 1);
  while (cell > 0 && cdf_[cell + 1] - cdf_[cell] <= 0) --cell;
  if (probability) *probability = CellProbability(cell);
  return cell;
}

double Distribution1D::CellProbability(int cell) const { return cdf_[cell + 1] - cdf_[cell]; }

double Distribution1D::Sample(double u, double* pdf, int* cell) const {
  double p = 0;
  const int c = SampleDiscrete(u, &p);
  const double offset = p > 0 ? (u - cdf_[c]) / p : 0.5;
  if (pdf) *pdf = p * size();
  if (cell) *cell = c;
  return std::min((c + std::clamp(offset, 0.0, 1.0)) / size(), kOneMinusEpsilon);
}

Distribution2D::Distribution2D(const std::vector<double>& weights, int cols, int rows) : cols_(cols), rows_(rows) {
  SHADOWSG_CHECK(cols > 0 && rows > 0 && weights.size() == static_cast<size_t>(cols) * rows);
  std::vector<double> row_sums(rows, 0.0);
  conditional_.reserve(rows);
  for (int r = 0; r < rows; ++r) {
    std::vector<double> row(weights.begin() + static_cast<size_t>(r) * cols,
                            weights.begin() + static_cast<size_t>(r + 1) * cols);
    for (double w : row) row_sums[r] += w;
    conditional_.emplace_back(row);
  }
  marginal_ = Distribution1D(row_sums);
}

Eigen::Vector2d Distribution2D::Sample(const Eigen::Vector2d& u, double* pdf) const {
  double pdf_row = 0, pdf_col = 0;
  int row = 0;
  const double y = marginal_.Sample(u.y(), &pdf_row, &row);
  const double x = conditional_[row].Sample(u.x(), &pdf_col, nullptr);
  if (pdf) *pdf = pdf_row * pdf_col;
  return {x, y};
}

double Distribution2D::Density(const Eigen::Vector2d& xy) const {
  const int col = std::clamp(static_cast<int>(xy.x() * cols_), 0, cols_ - 1);
  const int row = std::clamp(static_cast<int>(xy.y() * rows_), 0, rows_ - 1);
  return marginal_.Density(row) * conditional_[row].Density(col);
}

void OrthonormalBasis(const Eigen::Vector3d& n, Eigen::Vector3d* t, Eigen::Vector3d* b) {
  const double sign = std::copysign(1.0, n.z());
  const double a = -1.0 / (sign + n.z());
  const double c = n.x() * n.y() * a;
  *t = Eigen::Vector3d(1.0 + sign * n.x() * n.x() * a, sign * c, -sign * n.x());
  *b = Eigen::Vector3d(c, sign + n.y() * n.y() * a, -n.y());
}

namespace {

Eigen::Vector3d FromLocal(const Eigen::Vector3d& n, double cos_theta, double phi) {
  Eigen::Vector3d t, b;
  OrthonormalBasis(n, &t, &b);
  const double sin_theta = std::sqrt(std::max(0.0, 1.0 - cos_theta * cos_theta));
  return (sin_theta * std::cos(phi) * t + sin_theta * std::sin(phi) * b + cos_theta * n).normalized();
}

}  // namespace

Eigen::Vector3d SampleCosineHemisphere(const Eigen::Vector3d& n, const Eigen::Vector2d& u) {
  return FromLocal(n, std::sqrt(1.0 - u.x()), 2 * M_PI * u.y());
}

Eigen::Vector3d SampleUniformCone(const Eigen::Vector3d& axis, double angle, const Eigen::Vector2d& u) {
  const double cos_max = std::cos(angle);
  return FromLocal(axis, 1.0 - u.x() * (1.0 - cos_max), 2 * M_PI * u.y());
}

double UniformConePdf(double angle) { return 1.0 / (2 * M_PI * (1.0 - std::cos(angle))); }

Eigen::Vector3d SampleVmf(const Eigen::Vector3d& axis, double kappa, const Eigen::Vector2d& u) {
  // Inverting the CDF of w = cos(theta): w = 1 + log(u + (1 - u) e^{-2k}) / k.
  const double w = 1.0 + std::log(u.x() + (1.0 - u.x()) * std::exp(-2 * kappa)) / kappa;
  return FromLocal(axis, std::clamp(w, -1.0, 1.0), 2 * M_PI * u.y());
}

double VmfPdf(const Eigen::Vector3d& axis, double kappa, const Eigen::Vector3d& dir) {
  // k / (2 pi (1 - e^{-2k})) exp(k (w.axis - 1)); -expm1 keeps small k accurate.
  return kappa / (2 * M_PI * -std::expm1(-2 * kappa)) * std::exp(kappa * (dir.dot(axis) - 1.0));
}

}  // namespace shadowsg
