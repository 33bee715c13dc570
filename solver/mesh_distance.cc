#include "solver/mesh_distance.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace shadowsg {

Eigen::Vector3d ClosestPointOnTriangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                       const Eigen::Vector3d& c) {
  const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + ab * (d1 / (d1 - d3));
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + ac * (d2 / (d2 - d6));
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
  const double denom = va + vb + vc;
  if (denom == 0) return a;  // degenerate face: all its points are near a
  return a + ab * (vb / denom) + ac * (vc / denom);
}

MeshDistance::MeshDistance(const TriangleMesh& mesh, const SurfaceGrid& grid)
    : mesh_(mesh), faces_of_point_(grid.points.size()), tree_(grid.points), spacing_(grid.spacing) {
  std::vector<int> point_of_vertex(mesh.vertices.size(), -1);
  for (size_t i = 0; i < grid.points.size(); ++i) {
    if (grid.vertex_of[i] >= 0)
      point_of_vertex[grid.vertex_of[i]] = static_cast<int>(i);
    else
      faces_of_point_[i].push_back(grid.face[i]);
  }
  for (size_t f = 0; f < mesh.faces.size(); ++f)
    for (int k = 0; k < 3; ++k) faces_of_point_[point_of_vertex[mesh.faces[f][k]]].push_back(static_cast<int>(f));
}

double MeshDistance::Distance(const Eigen::Vector3d& q) const {
  double d2;
  if (tree_.Nearest(q, &d2) < 0) return std::numeric_limits<double>::infinity();
  std::vector<int> near;
  tree_.WithinRadius(q, std::sqrt(d2) + spacing_, &near);
  std::vector<int> faces;
  for (int p : near) faces.insert(faces.end(), faces_of_point_[p].begin(), faces_of_point_[p].end());
  std::sort(faces.begin(), faces.end());
  faces.erase(std::unique(faces.begin(), faces.end()), faces.end());
  double best = d2;
  for (int f : faces) {
    const auto& t = mesh_.faces[f];
    best = std::min(best, (ClosestPointOnTriangle(q, mesh_.vertices[t[0]], mesh_.vertices[t[1]], mesh_.vertices[t[2]]) - q)
                              .squaredNorm());
  }
  return std::sqrt(best);
}

}  // namespace shadowsg
