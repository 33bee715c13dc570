// Points on a triangle mesh's surface: a deterministic grid that tiles every
// face with small "micro-triangles" (the sphere-tree builder covers those, so
// it covers the whole surface, not only the points), and random area-uniform
// samples (for checks that must not reuse the builder's points).
#pragma once

#include <Eigen/Dense>
#include <cstdint>
#include <vector>

#include "solver/mesh.h"

namespace shadowsg {

struct SurfaceGrid {
  // The mesh's referenced vertices come first (vertex_of[i] >= 0), then the
  // points added inside faces and on their edges (vertex_of[i] = -1).
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector3d> normals;  // unit, outward as the faces wind; zero on degenerate faces
  std::vector<int> face;                 // the face a point was made on (a vertex: one incident face)
  std::vector<int> vertex_of;            // mesh vertex index, or -1
  // Triples of point indices; together they tile every face, each edge at most `spacing` long.
  std::vector<Eigen::Vector3i> micro_triangles;
  double spacing = 0;
};

// A grid of about target_points points (never fewer than the referenced
// vertices). InputError for a mesh without faces or with a bad index.
SurfaceGrid SampleSurfaceGrid(const TriangleMesh& mesh, int target_points);

// n points uniform by area, deterministic in seed; *faces (optional) gets the face of each.
std::vector<Eigen::Vector3d> SampleSurfaceUniform(const TriangleMesh& mesh, int n, uint64_t seed,
                                                  std::vector<int>* faces = nullptr);

// Indices of the vertices some face uses (a mesh may carry stray vertices).
std::vector<int> ReferencedVertices(const TriangleMesh& mesh);

// Faces whose index is out of range or whose coordinates are not finite: InputError naming `what`.
void CheckMeshIndices(const TriangleMesh& mesh, const std::string& what);

}  // namespace shadowsg
