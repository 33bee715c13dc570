// Triangle meshes in memory (object or world coordinates).
#pragma once

#include <Eigen/Dense>
#include <vector>

namespace shadowsg {

struct TriangleMesh {
  std::vector<Eigen::Vector3d> vertices;
  std::vector<Eigen::Vector3i> faces;  // counter-clockwise seen from outside
};

TriangleMesh TransformMesh(const TriangleMesh& mesh, const Eigen::Matrix4d& transform);
// Signed volume (divergence theorem); positive for an outward-oriented closed mesh.
double MeshVolume(const TriangleMesh& mesh);
double MeshArea(const TriangleMesh& mesh);
// Edges used by exactly one face: 0 for a watertight mesh.
int CountBoundaryEdges(const TriangleMesh& mesh);
void MeshBounds(const TriangleMesh& mesh, Eigen::Vector3d* lo, Eigen::Vector3d* hi);

}  // namespace shadowsg
