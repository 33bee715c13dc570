#include "solver/lit_plane_trend.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>

namespace shadowsg {

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
