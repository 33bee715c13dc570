#include "solver/scene.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "calib/conventions.h"

namespace shadowsg {

namespace {

// MinimalRotationToZ(plane.normal), kept for the last normal seen on this
// thread: the ray casters ask once a ray, always of one plane (about 1.3
// million rays in a sunsky solve with its insertion preview, where building
// the rotation each time took 2.8 % of the CPU samples).
const Eigen::Matrix3d& PlaneRotation(const Plane& plane) {
  thread_local Eigen::Vector3d normal = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  thread_local Eigen::Matrix3d rotation;
  if (!(plane.normal.array() == normal.array()).all()) {
    rotation = MinimalRotationToZ(plane.normal);
    normal = plane.normal;
  }
  return rotation;
}

}  // namespace

bool PlaneRectContains(const Plane& plane, const Eigen::Vector3d& p) {
  const Eigen::Vector3d local = PlaneRotation(plane) * (p - plane.xyz);
  return std::abs(local.x()) <= plane.scale.x() && std::abs(local.y()) <= plane.scale.y();
}

Eigen::Vector3d PlaneAlbedo(const Plane& plane, const Eigen::Vector3d& p) {
  if (!plane.albedo_texture || plane.albedo_texture->empty()) return plane.diffuse;
  const Image& tex = *plane.albedo_texture;
  const Eigen::Vector3d local = PlaneRotation(plane) * (p - plane.xyz);
  // Texel centres at integers, as for camera pixels.
  const double fu = std::clamp((local.x() / plane.scale.x() + 1) / 2 * tex.width - 0.5, 0.0, tex.width - 1.0);
  const double fv = std::clamp((1 - local.y() / plane.scale.y()) / 2 * tex.height - 0.5, 0.0, tex.height - 1.0);
  const int u0 = static_cast<int>(fu), v0 = static_cast<int>(fv);
  const int u1 = std::min(u0 + 1, tex.width - 1), v1 = std::min(v0 + 1, tex.height - 1);
  const double au = fu - u0, av = fv - v0;
  auto texel = [&](int u, int v) -> Eigen::Vector3d { return tex.rgb(tex.index(u, v)).cast<double>(); };
  const Eigen::Vector3d t = (1 - av) * ((1 - au) * texel(u0, v0) + au * texel(u1, v0)) +
                            av * ((1 - au) * texel(u0, v1) + au * texel(u1, v1));
  return plane.diffuse.cwiseProduct(t);
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
