#include "solver/enclosing_sphere.h"

#include <algorithm>

#include "calib/error.h"

namespace shadowsg {

Sphere EnclosingSphere(const std::vector<Sphere>& spheres, int iterations) {
  SHADOWSG_CHECK(!spheres.empty());
  if (spheres.size() == 1) return {spheres[0].centre, std::max(0.0, spheres[0].radius)};
  auto radius_about = [&](const Eigen::Vector3d& c, const Sphere** far) {
    double r = -1;
    for (const Sphere& s : spheres) {
      const double d = (s.centre - c).norm() + std::max(0.0, s.radius);
      if (d > r) r = d, *far = &s;
    }
    return r;
  };
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (const Sphere& s : spheres) c += s.centre;
  c /= static_cast<double>(spheres.size());
  const Sphere* far = nullptr;
  Sphere best{c, radius_about(c, &far)};
  for (int it = 1; it <= iterations; ++it) {
    // Towards the farthest point of the farthest sphere, by a step 1/(it+1).
    const Eigen::Vector3d to = far->centre - c;
    const double len = to.norm();
    const Eigen::Vector3d target = len > 0 ? Eigen::Vector3d(far->centre + to / len * std::max(0.0, far->radius))
                                           : far->centre;
    c += (target - c) / (it + 1.0);
    const double r = radius_about(c, &far);
    if (r < best.radius) best = {c, r};
  }
  return best;
}

}  // namespace shadowsg
