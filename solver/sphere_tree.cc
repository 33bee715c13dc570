#include "solver/sphere_tree.h"

namespace shadowsg {

size_t SphereTree::NodeCount(int levels, int branching) {
  size_t n = 0, level_size = 1;
  for (int l = 0; l < levels; ++l, level_size *= branching) n += level_size;
  return n;
}

size_t SphereTree::LevelBegin(int level) const { return NodeCount(level, branching); }
size_t SphereTree::LevelEnd(int level) const { return NodeCount(level + 1, branching); }

SphereTree TransformSphereTree(const SphereTree& tree, const Eigen::Matrix4d& T) {
  SphereTree out = tree;
  const double s = T.block<3, 1>(0, 0).norm();
  for (auto& n : out.nodes) {
    n.centre = T.block<3, 3>(0, 0) * n.centre + T.block<3, 1>(0, 3);
    n.radius *= s;
  }
  return out;
}

}  // namespace shadowsg
