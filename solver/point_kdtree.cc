#include "solver/point_kdtree.h"

#include <algorithm>
#include <limits>
#include <numeric>
#include <queue>
#include <utility>

namespace shadowsg {
namespace {

// Points per leaf: small enough to prune well, large enough that the node
// array stays a fraction of the point array.
constexpr int kLeafSize = 8;

}  // namespace

PointKdTree::PointKdTree(std::vector<Eigen::Vector3d> points) : points_(std::move(points)) {
  order_.resize(points_.size());
  std::iota(order_.begin(), order_.end(), 0);
  nodes_.reserve(2 * points_.size() / kLeafSize + 2);
  if (!points_.empty()) Build(0, static_cast<int>(points_.size()));
}

int PointKdTree::Build(int begin, int end) {
  const int id = static_cast<int>(nodes_.size());
  Node node;
  node.begin = begin;
  node.end = end;
  node.lo = node.hi = points_[order_[begin]];
  for (int i = begin; i < end; ++i) {
    node.lo = node.lo.cwiseMin(points_[order_[i]]);
    node.hi = node.hi.cwiseMax(points_[order_[i]]);
  }
  nodes_.push_back(node);
  if (end - begin <= kLeafSize) return id;
  int axis;
  (node.hi - node.lo).maxCoeff(&axis);
  const int mid = (begin + end) / 2;
  std::nth_element(order_.begin() + begin, order_.begin() + mid, order_.begin() + end,
                   [&](int a, int b) { return points_[a][axis] < points_[b][axis]; });
  const int left = Build(begin, mid);
  const int right = Build(mid, end);
  nodes_[id].left = left;
  nodes_[id].right = right;
  return id;
}

int PointKdTree::Nearest(const Eigen::Vector3d& q, double* distance2) const {
  int best = -1;
  double best_d2 = std::numeric_limits<double>::infinity();
  if (!nodes_.empty()) {
    // Depth-first, nearer child first; a node is skipped when its box is farther than the best.
    int stack[128];  // median splits: depth <= log2(size), at most one pending sibling per level
    int top = 0;
    stack[top++] = 0;
    while (top > 0) {
      const Node& n = nodes_[stack[--top]];
      if (BoxDistance2(n, q) >= best_d2) continue;
      if (n.left < 0) {
        for (int i = n.begin; i < n.end; ++i) {
          const double d2 = (points_[order_[i]] - q).squaredNorm();
          if (d2 < best_d2) best_d2 = d2, best = order_[i];
        }
        continue;
      }
      const double dl = BoxDistance2(nodes_[n.left], q), dr = BoxDistance2(nodes_[n.right], q);
      if (dl < dr) {
        stack[top++] = n.right;
        stack[top++] = n.left;
      } else {
        stack[top++] = n.left;
        stack[top++] = n.right;
      }
    }
  }
  if (distance2) *distance2 = best_d2;
  return best;
}

std::vector<int> PointKdTree::KNearest(const Eigen::Vector3d& q, int k) const {
  std::priority_queue<std::pair<double, int>> heap;  // max-heap of the k best
  auto worst = [&] {
    return static_cast<int>(heap.size()) < k ? std::numeric_limits<double>::infinity() : heap.top().first;
  };
  if (!nodes_.empty() && k > 0) {
    std::vector<int> stack = {0};
    while (!stack.empty()) {
      const Node& n = nodes_[stack.back()];
      stack.pop_back();
      if (BoxDistance2(n, q) >= worst()) continue;
      if (n.left < 0) {
        for (int i = n.begin; i < n.end; ++i) {
          const double d2 = (points_[order_[i]] - q).squaredNorm();
          if (d2 < worst()) {
            heap.push({d2, order_[i]});
            if (static_cast<int>(heap.size()) > k) heap.pop();
          }
        }
        continue;
      }
      const bool left_first = BoxDistance2(nodes_[n.left], q) < BoxDistance2(nodes_[n.right], q);
      stack.push_back(left_first ? n.right : n.left);
      stack.push_back(left_first ? n.left : n.right);
    }
  }
  std::vector<int> out(heap.size());
  for (size_t i = out.size(); i-- > 0; heap.pop()) out[i] = heap.top().second;
  return out;
}

void PointKdTree::WithinRadius(const Eigen::Vector3d& q, double r, std::vector<int>* out) const {
  if (nodes_.empty()) return;
  const double r2 = r * r;
  std::vector<int> stack = {0};
  while (!stack.empty()) {
    const Node& n = nodes_[stack.back()];
    stack.pop_back();
    if (BoxDistance2(n, q) > r2) continue;
    if (n.left < 0) {
      for (int i = n.begin; i < n.end; ++i)
        if ((points_[order_[i]] - q).squaredNorm() <= r2) out->push_back(order_[i]);
      continue;
    }
    stack.push_back(n.right);
    stack.push_back(n.left);
  }
}

}  // namespace shadowsg
