#include "solver/lights.h"

#include <cmath>

#include "solver/envmap.h"

namespace shadowsg {

std::optional<double> IntersectAreaLight(const AreaLight& a, const Eigen::Vector3d& o, const Eigen::Vector3d& d) {
  const Eigen::Vector3d n = a.Normal();
  const double denom = n.dot(d);
  if (denom >= 0) return std::nullopt;  // seen from behind or edge-on
  const double t = n.dot(a.centre - o) / denom;
  if (t <= 0) return std::nullopt;
  const Eigen::Vector3d q = o + t * d - a.centre;
  // half_u and half_v need not be orthogonal: solve q = s half_u + r half_v.
  const Eigen::Matrix2d g{{a.half_u.squaredNorm(), a.half_u.dot(a.half_v)},
                          {a.half_u.dot(a.half_v), a.half_v.squaredNorm()}};
  const Eigen::Vector2d sr = g.ldlt().solve(Eigen::Vector2d(q.dot(a.half_u), q.dot(a.half_v)));
  if (std::abs(sr.x()) > 1 || std::abs(sr.y()) > 1) return std::nullopt;
  return t;
}

Eigen::Vector3d LightSet::DistantRadiance(const Eigen::Vector3d& dir) const {
  Eigen::Vector3d l = Eigen::Vector3d::Zero();
  if (sg) l += EvalSg(*sg, dir);
  if (env) l += SampleEnvMap(*env, dir);
  return l;
}

}  // namespace shadowsg
