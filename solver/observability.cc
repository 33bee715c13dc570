#include "solver/observability.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>

namespace shadowsg {

double InformativeSkyShare(const Eigen::Vector3d& plane_normal, const std::vector<Eigen::Vector3d>& points,
                           const RayCaster& casters) {
  const Eigen::Vector3d n = plane_normal.normalized();
  const Eigen::Vector3d t = (std::abs(n.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY()).cross(n).normalized();
  const Eigen::Vector3d b = n.cross(t);
  constexpr int kDirs = 1024;
  std::vector<Eigen::Vector3d> dirs;
  std::vector<double> weight;
  const double golden = M_PI * (3 - std::sqrt(5.0));
  for (int i = 0; i < kDirs; ++i) {  // Fibonacci points, uniform in solid angle over the hemisphere
    const double z = 1 - (i + 0.5) / kDirs, r = std::sqrt(std::max(0.0, 1 - z * z)), phi = golden * i;
    dirs.push_back(r * std::cos(phi) * t + r * std::sin(phi) * b + z * n);
    weight.push_back(z);
  }
  const size_t stride = std::max<size_t>(1, points.size() / 512);
  std::vector<int> shadowed(kDirs, 0);
  int sampled = 0;
  std::vector<char> visible;
  for (size_t i = 0; i < points.size(); i += stride, ++sampled) {
    casters.Visible(points[i], dirs, 1e-6, &visible);
    for (int d = 0; d < kDirs; ++d) shadowed[d] += !visible[d];
  }
  double informative = 0, total = 0;
  for (int d = 0; d < kDirs; ++d) {
    total += weight[d];
    if (shadowed[d] > 0 && shadowed[d] < sampled) informative += weight[d];
  }
  return total > 0 ? informative / total : 0;
}

LitPlaneTrend MeasureLitPlaneTrend(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& normal,
                                   const std::vector<double>& irradiance) {
  LitPlaneTrend t;
  const size_t n = std::min(points.size(), irradiance.size());
  std::vector<double> finite;
  for (size_t i = 0; i < n; ++i)
    if (std::isfinite(irradiance[i]) && irradiance[i] > 0) finite.push_back(irradiance[i]);
  if (finite.size() < 16) return t;
  const double top = *std::max_element(finite.begin(), finite.end());
  std::nth_element(finite.begin(), finite.begin() + finite.size() / 2, finite.end());
  const double median = std::max(finite[finite.size() / 2], 1e-6 * top);

  // Plane coordinates: any orthonormal pair perpendicular to the normal.
  const Eigen::Vector3d nz = normal.normalized();
  const Eigen::Vector3d u = nz.unitOrthogonal(), v = nz.cross(u);
  std::vector<size_t> lit;
  for (size_t i = 0; i < n; ++i)
    if (std::isfinite(irradiance[i]) && irradiance[i] >= median && points[i].allFinite()) lit.push_back(i);
  if (lit.size() < 16) return t;
  Eigen::MatrixXd A(static_cast<long>(lit.size()), 3);
  Eigen::VectorXd b(static_cast<long>(lit.size()));
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (size_t i : lit) centre += points[i];
  centre /= static_cast<double>(lit.size());
  for (size_t k = 0; k < lit.size(); ++k) {
    const Eigen::Vector3d p = points[lit[k]] - centre;
    A.row(static_cast<long>(k)) << 1, p.dot(u), p.dot(v);
    b[static_cast<long>(k)] = std::log(irradiance[lit[k]]);
  }
  const Eigen::Vector3d x = A.colPivHouseholderQr().solve(b);
  const Eigen::VectorXd fitted = A * x;
  t.ratio = std::exp(fitted.maxCoeff() - fitted.minCoeff());
  t.lit_pixels = static_cast<int>(lit.size());
  return t;
}

}  // namespace shadowsg
