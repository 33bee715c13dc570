// Exact unsigned distance from a point to a triangle mesh's surface (the
// sphere-tree fit's protrusion), found through a surface grid: the nearest grid
// point bounds the distance, and every face that could be closer has a grid
// point within that bound plus the grid spacing.
#pragma once

#include <Eigen/Dense>
#include <vector>

#include "solver/mesh.h"
#include "solver/point_kdtree.h"
#include "solver/surface_samples.h"

namespace shadowsg {

// The point of triangle abc nearest to p (Ericson, "Real-Time Collision
// Detection", 2005, sec. 5.1.5).
Eigen::Vector3d ClosestPointOnTriangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                       const Eigen::Vector3d& c);

class MeshDistance {
 public:
  // Keeps copies; the grid must have been made from this mesh.
  MeshDistance(const TriangleMesh& mesh, const SurfaceGrid& grid);
  double Distance(const Eigen::Vector3d& q) const;  // thread-safe

 private:
  TriangleMesh mesh_;
  std::vector<std::vector<int>> faces_of_point_;
  PointKdTree tree_;
  double spacing_ = 0;
};

}  // namespace shadowsg
