#include "solver/scene.h"

#include <cmath>

#include "calib/conventions.h"

namespace shadowsg {

bool PlaneRectContains(const Plane& plane, const Eigen::Vector3d& p) {
  const Eigen::Vector3d local = MinimalRotationToZ(plane.normal) * (p - plane.xyz);
  return std::abs(local.x()) <= plane.scale.x() && std::abs(local.y()) <= plane.scale.y();
}

std::optional<double> IntersectPlane(const Plane& plane, const Eigen::Vector3d& origin,
                                     const Eigen::Vector3d& dir) {
  const double denom = plane.normal.dot(dir);
  if (std::abs(denom) < 1e-12) return std::nullopt;
  const double t = plane.normal.dot(plane.xyz - origin) / denom;
  if (t <= 0) return std::nullopt;
  return t;
}

std::vector<const SceneObject*> Scene::Casters() const {
  std::vector<const SceneObject*> out;
  for (const auto& o : objects)
    if (o.is_train) out.push_back(&o);
  return out;
}

std::vector<const SceneObject*> Scene::VirtualObjects() const {
  std::vector<const SceneObject*> out;
  for (const auto& o : objects)
    if (!o.is_train) out.push_back(&o);
  return out;
}

}  // namespace shadowsg
