// The project's one ray caster: Embree over triangle meshes in world space.
// Embree types stay in ray_caster.cc.
#pragma once

#include <Eigen/Dense>
#include <memory>
#include <optional>
#include <vector>

#include "calib/camera.h"
#include "solver/mesh.h"

namespace shadowsg {

struct RayHit {
  double t = 0;
  int geometry = -1;   // id returned by AddMesh
  int primitive = -1;  // triangle index
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  // unit geometric normal, facing the ray
  double u = 0, v = 0;  // barycentrics
};

class RayCaster {
 public:
  RayCaster();
  ~RayCaster();
  RayCaster(RayCaster&&) noexcept;
  RayCaster& operator=(RayCaster&&) noexcept;
  RayCaster(const RayCaster&) = delete;
  RayCaster& operator=(const RayCaster&) = delete;

  // Adds a world-space mesh; returns its geometry id (0, 1, ... in call order).
  int AddMesh(const TriangleMesh& world_mesh);
  // Builds the acceleration structure; call after the last AddMesh.
  void Commit();
  bool empty() const;

  // Thread-safe after Commit.
  std::optional<RayHit> Intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir,
                                  double tnear = 0, double tfar = 1e30) const;
  bool Occluded(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double tnear = 0,
                double tfar = 1e30) const;
  // Visibility of many directions from one point (true = unoccluded), in packets.
  void Visible(const Eigen::Vector3d& origin, const std::vector<Eigen::Vector3d>& dirs,
               double tnear, std::vector<char>* visible) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace shadowsg
