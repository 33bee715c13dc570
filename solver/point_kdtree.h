// A static k-d tree over 3-D points for nearest-neighbour queries (the sphere
// tree builder's shrinking balls and the fit's distance to the surface).
#pragma once

#include <Eigen/Dense>
#include <vector>

namespace shadowsg {

class PointKdTree {
 public:
  PointKdTree() = default;
  explicit PointKdTree(std::vector<Eigen::Vector3d> points);

  // Index of the point nearest to q (-1 when empty); *distance2 its squared distance.
  int Nearest(const Eigen::Vector3d& q, double* distance2 = nullptr) const;
  // The k nearest points, nearest first (fewer when the tree holds fewer).
  std::vector<int> KNearest(const Eigen::Vector3d& q, int k) const;
  // Every point within distance r of q (appended to *out, in no order).
  void WithinRadius(const Eigen::Vector3d& q, double r, std::vector<int>* out) const;

  const std::vector<Eigen::Vector3d>& points() const { return points_; }
  size_t size() const { return points_.size(); }

 private:
  struct Node {
    int begin = 0, end = 0;     // range of order_ (leaf) ...
    int left = -1, right = -1;  // ... or children
    Eigen::Vector3d lo, hi;     // tight bounds of the node's points: prunes far queries well
  };
  double BoxDistance2(const Node& n, const Eigen::Vector3d& q) const {
    return (n.lo - q).cwiseMax(q - n.hi).cwiseMax(0.0).squaredNorm();
  }
  int Build(int begin, int end);

  std::vector<Eigen::Vector3d> points_;
  std::vector<int> order_;
  std::vector<Node> nodes_;
};

}  // namespace shadowsg
