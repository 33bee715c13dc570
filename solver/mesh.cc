#include "solver/mesh.h"

#include <algorithm>
#include <map>
#include <utility>

namespace shadowsg {

TriangleMesh TransformMesh(const TriangleMesh& mesh, const Eigen::Matrix4d& T) {
  TriangleMesh out = mesh;
  for (auto& v : out.vertices) v = T.block<3, 3>(0, 0) * v + T.block<3, 1>(0, 3);
  // A reflection flips the winding; keep faces outward.
  if (T.block<3, 3>(0, 0).determinant() < 0)
    for (auto& f : out.faces) std::swap(f[1], f[2]);
  return out;
}

double MeshVolume(const TriangleMesh& mesh) {
  double v = 0;
  for (const auto& f : mesh.faces)
    v += mesh.vertices[f[0]].dot(mesh.vertices[f[1]].cross(mesh.vertices[f[2]]));
  return v / 6.0;
}

double MeshArea(const TriangleMesh& mesh) {
  double a = 0;
  for (const auto& f : mesh.faces)
    a += (mesh.vertices[f[1]] - mesh.vertices[f[0]]).cross(mesh.vertices[f[2]] - mesh.vertices[f[0]]).norm();
  return a / 2.0;
}

int CountBoundaryEdges(const TriangleMesh& mesh) {
  std::map<std::pair<int, int>, int> uses;
  for (const auto& f : mesh.faces)
    for (int k = 0; k < 3; ++k) {
      int a = f[k], b = f[(k + 1) % 3];
      ++uses[{std::min(a, b), std::max(a, b)}];
    }
  return static_cast<int>(std::count_if(uses.begin(), uses.end(), [](const auto& e) { return e.second == 1; }));
}

void MeshBounds(const TriangleMesh& mesh, Eigen::Vector3d* lo, Eigen::Vector3d* hi) {
  *lo = Eigen::Vector3d::Constant(1e300);
  *hi = Eigen::Vector3d::Constant(-1e300);
  for (const auto& v : mesh.vertices) {
    *lo = lo->cwiseMin(v);
    *hi = hi->cwiseMax(v);
  }
}

}  // namespace shadowsg
