// A sphere tree (Bradshaw & O'Sullivan 2004): a complete B-ary tree stored
// breadth-first, root first; the children of node i are B*i+1 ... B*i+B.
// A node with radius <= 0 is an empty slot (absent, not a point occluder).
#pragma once

#include <Eigen/Dense>
#include <vector>

namespace shadowsg {

struct Sphere {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  double radius = 0;  // <= 0: empty slot
  bool empty() const { return radius <= 0; }
};

struct SphereTree {
  int levels = 0;     // including the root level, as in the .sph header
  int branching = 0;  // B
  std::vector<Sphere> nodes;

  // Number of nodes of a complete tree: (B^L - 1) / (B - 1).
  static size_t NodeCount(int levels, int branching);
  size_t LevelBegin(int level) const;  // index of the first node of a level (root = level 0)
  size_t LevelEnd(int level) const;
  size_t FirstChild(size_t i) const { return static_cast<size_t>(branching) * i + 1; }
  bool IsLeafLevel(size_t i) const { return i >= LevelBegin(levels - 1); }
};

// The tree moved by a similarity transform (uniform scale taken from the
// first column's norm, as the reference code does).
SphereTree TransformSphereTree(const SphereTree& tree, const Eigen::Matrix4d& transform);

}  // namespace shadowsg
