// Light sources the renderers understand. Estimated lighting is SG or an env
// map; synthetic scenes may add analytic suns and rectangular area lights.
#pragma once

#include <Eigen/Dense>
#include <optional>
#include <vector>

#include "calib/image.h"
#include "solver/sg.h"

namespace shadowsg {

// A distant disc light: `direction` points TOWARDS the light; `irradiance` is
// the RGB irradiance it gives a surface facing it (Blender's sun "strength");
// `angular_radius` in radians (0: a delta light, hard shadows).
struct SunLight {
  Eigen::Vector3d direction = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d irradiance = Eigen::Vector3d::Ones();
  double angular_radius = 0;
};

// A one-sided rectangle centre +- half_u +- half_v emitting `radiance` into the
// half-space its normal (half_u x half_v, normalised) points to.
struct AreaLight {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  Eigen::Vector3d half_u = Eigen::Vector3d::UnitX();
  Eigen::Vector3d half_v = Eigen::Vector3d::UnitY();
  Eigen::Vector3d radiance = Eigen::Vector3d::Ones();

  Eigen::Vector3d Normal() const { return half_u.cross(half_v).normalized(); }
  double Area() const { return 4 * half_u.cross(half_v).norm(); }
};

// Ray parameter t > 0 where origin + t dir meets the light's emitting (front)
// side; nullopt when it misses or sees the back.
std::optional<double> IntersectAreaLight(const AreaLight& light, const Eigen::Vector3d& origin,
                                         const Eigen::Vector3d& dir);

// Everything that lights a scene; any combination may be present.
struct LightSet {
  std::optional<SgLighting> sg;
  std::optional<Image> env;  // equirectangular radiance map, H x 2H
  std::vector<SunLight> suns;
  std::vector<AreaLight> areas;

  bool empty() const { return !sg && !env && suns.empty() && areas.empty(); }
  // Radiance arriving from a distant direction (SG + env map); suns and area
  // lights are sampled separately by the renderers.
  Eigen::Vector3d DistantRadiance(const Eigen::Vector3d& dir) const;
};

}  // namespace shadowsg
