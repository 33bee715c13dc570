#include "solver/plane_pixels.h"

#include <omp.h>

namespace shadowsg {

RayCaster BuildRayCaster(const std::vector<const SceneObject*>& objects) {
  RayCaster caster;
  for (const auto* o : objects) caster.AddMesh(o->WorldMesh());
  caster.Commit();
  return caster;
}

PlanePixels FindPlanePixels(const Scene& scene, const RayCaster& casters) {
  const Camera& cam = scene.camera;
  const int w = cam.width, h = cam.height;
  std::vector<char> on_plane(static_cast<size_t>(w) * h, 0);
  std::vector<Eigen::Vector3d> points(on_plane.size());
#pragma omp parallel for schedule(dynamic, 8)
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const size_t i = static_cast<size_t>(y) * w + x;
      if (scene.mask && scene.mask->at(x, y, 0) == 0) continue;
      const Ray ray = PixelRay(cam, x, y);
      const auto t = IntersectPlane(scene.plane, ray.origin, ray.dir);
      if (!t) continue;
      const Eigen::Vector3d p = ray.origin + *t * ray.dir;
      if (!PlaneRectContains(scene.plane, p)) continue;
      if (!casters.empty() && casters.Occluded(ray.origin, ray.dir, 0, *t * (1 - 1e-6))) continue;
      on_plane[i] = 1;
      points[i] = p;
    }
  }
  PlanePixels out;
  out.width = w;
  out.height = h;
  for (size_t i = 0; i < on_plane.size(); ++i)
    if (on_plane[i]) {
      out.pixel.push_back(static_cast<int>(i));
      out.point.push_back(points[i]);
    }
  return out;
}

Image PlanePixelMask(const PlanePixels& pixels) {
  Image mask(pixels.width, pixels.height, 1);
  for (int p : pixels.pixel) mask.data[p] = 1.0f;
  return mask;
}

}  // namespace shadowsg
