// The shadow-plane pixels of a scene (metrics.md): camera rays that hit the
// plane rectangle before any caster (is_train object), intersected with the
// scene's mask when it has one.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "solver/ray_caster.h"
#include "solver/scene.h"

namespace shadowsg {

struct PlanePixels {
  int width = 0, height = 0;
  std::vector<int> pixel;               // linear pixel index y * width + x
  std::vector<Eigen::Vector3d> point;   // world-space hit on the plane
  size_t size() const { return pixel.size(); }
};

// A ray caster over the world meshes of the given objects (geometry ids follow
// the order of `objects`).
RayCaster BuildRayCaster(const std::vector<const SceneObject*>& objects);

PlanePixels FindPlanePixels(const Scene& scene, const RayCaster& casters);
// 1-channel image: 1 on plane pixels, 0 elsewhere.
Image PlanePixelMask(const PlanePixels& pixels);

}  // namespace shadowsg
