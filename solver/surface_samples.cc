#include "solver/surface_samples.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "calib/error.h"
#include "solver/sampling.h"

namespace shadowsg {
namespace {

// Each face's longest edge: what its subdivisions depend on.
std::vector<double> LongestEdges(const TriangleMesh& m) {
  std::vector<double> out(m.faces.size());
  for (size_t i = 0; i < m.faces.size(); ++i) {
    const Eigen::Vector3d& a = m.vertices[m.faces[i][0]];
    const Eigen::Vector3d& b = m.vertices[m.faces[i][1]];
    const Eigen::Vector3d& c = m.vertices[m.faces[i][2]];
    out[i] = std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()});
  }
  return out;
}

// Grid subdivisions of a face so that its micro-triangle edges are <= spacing.
int Subdivisions(double longest_edge, double spacing) {
  return std::max(1, static_cast<int>(std::ceil(longest_edge / spacing)));
}

// Points a grid of this spacing adds beyond the vertices.
double ExtraPoints(const std::vector<double>& longest_edges, double spacing) {
  double n = 0;
  for (const double e : longest_edges) {
    const double s = Subdivisions(e, spacing);
    n += (s + 1) * (s + 2) / 2 - 3;
  }
  return n;
}

// Bisection steps on log(spacing): the point count only needs to be near the target.
constexpr int kSpacingSearchSteps = 30;

}  // namespace

void CheckMeshIndices(const TriangleMesh& mesh, const std::string& what) {
  if (mesh.faces.empty()) throw InputError(what, "mesh has no faces");
  const int nv = static_cast<int>(mesh.vertices.size());
  for (const auto& v : mesh.vertices)
    if (!v.allFinite()) throw InputError(what, "mesh has a non-finite vertex");
  for (size_t i = 0; i < mesh.faces.size(); ++i)
    for (int k = 0; k < 3; ++k)
      if (mesh.faces[i][k] < 0 || mesh.faces[i][k] >= nv)
        throw InputError(what, "face " + std::to_string(i) + " uses vertex " + std::to_string(mesh.faces[i][k]) +
                                   " of " + std::to_string(nv));
}

std::vector<int> ReferencedVertices(const TriangleMesh& mesh) {
  std::vector<char> used(mesh.vertices.size(), 0);
  for (const auto& f : mesh.faces)
    for (int k = 0; k < 3; ++k) used[f[k]] = 1;
  std::vector<int> out;
  for (size_t i = 0; i < used.size(); ++i)
    if (used[i]) out.push_back(static_cast<int>(i));
  return out;
}

SurfaceGrid SampleSurfaceGrid(const TriangleMesh& mesh, int target_points) {
  CheckMeshIndices(mesh, "surface sampling");
  SurfaceGrid g;
  const std::vector<int> verts = ReferencedVertices(mesh);
  std::vector<int> point_of_vertex(mesh.vertices.size(), -1);
  for (int v : verts) {
    point_of_vertex[v] = static_cast<int>(g.points.size());
    g.points.push_back(mesh.vertices[v]);
    g.normals.push_back(Eigen::Vector3d::Zero());
    g.face.push_back(-1);
    g.vertex_of.push_back(v);
  }
  // Area-weighted vertex normals; each vertex remembers one incident face.
  std::vector<Eigen::Vector3d> face_normal(mesh.faces.size());
  for (size_t i = 0; i < mesh.faces.size(); ++i) {
    const auto& f = mesh.faces[i];
    const Eigen::Vector3d n =
        (mesh.vertices[f[1]] - mesh.vertices[f[0]]).cross(mesh.vertices[f[2]] - mesh.vertices[f[0]]);
    const double len = n.norm();
    face_normal[i] = len > 0 ? Eigen::Vector3d(n / len) : Eigen::Vector3d::Zero();
    for (int k = 0; k < 3; ++k) {
      const int p = point_of_vertex[f[k]];
      g.normals[p] += n;
      if (g.face[p] < 0) g.face[p] = static_cast<int>(i);
    }
  }
  for (auto& n : g.normals)
    if (n.norm() > 0) n.normalize();

  // Spacing for about target_points points in all; at least fine enough that
  // no face is left as a single micro-triangle when points are to spare.
  Eigen::Vector3d lo, hi;
  MeshBounds(mesh, &lo, &hi);
  const double extra_wanted = std::max(0.0, static_cast<double>(target_points) - static_cast<double>(verts.size()));
  const std::vector<double> longest = LongestEdges(mesh);
  double s_lo = std::max((hi - lo).norm(), 1e-300) * 1e-4, s_hi = std::max((hi - lo).norm(), 1e-300) * 2;
  // A mesh with at least target_points vertices (a scan) is its own grid:
  // every face stays whole, which is where the search below ends too.
  for (int it = 0; it < kSpacingSearchSteps && extra_wanted > 0; ++it) {
    const double mid = std::sqrt(s_lo * s_hi);
    (ExtraPoints(longest, mid) > extra_wanted ? s_lo : s_hi) = mid;
  }
  g.spacing = s_hi;

  for (size_t fi = 0; fi < mesh.faces.size(); ++fi) {
    const auto& f = mesh.faces[fi];
    const int n = Subdivisions(longest[fi], g.spacing);
    const Eigen::Vector3d& a = mesh.vertices[f[0]];
    const Eigen::Vector3d& b = mesh.vertices[f[1]];
    const Eigen::Vector3d& c = mesh.vertices[f[2]];
    // Point index of grid node (i, j): a + i/n (b - a) + j/n (c - a), i + j <= n.
    std::vector<int> id((n + 1) * (n + 1), -1);
    auto at = [&](int i, int j) -> int& { return id[i * (n + 1) + j]; };
    for (int i = 0; i <= n; ++i)
      for (int j = 0; i + j <= n; ++j) {
        if (i == 0 && j == 0) {
          at(i, j) = point_of_vertex[f[0]];
        } else if (i == n) {
          at(i, j) = point_of_vertex[f[1]];
        } else if (j == n) {
          at(i, j) = point_of_vertex[f[2]];
        } else {
          at(i, j) = static_cast<int>(g.points.size());
          g.points.push_back(a + (b - a) * (static_cast<double>(i) / n) + (c - a) * (static_cast<double>(j) / n));
          g.normals.push_back(face_normal[fi]);
          g.face.push_back(static_cast<int>(fi));
          g.vertex_of.push_back(-1);
        }
      }
    for (int i = 0; i < n; ++i)
      for (int j = 0; i + j < n; ++j) {
        g.micro_triangles.emplace_back(at(i, j), at(i + 1, j), at(i, j + 1));
        if (i + j + 1 < n) g.micro_triangles.emplace_back(at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
      }
  }
  // The spacing actually reached (the search's value is only an upper bound).
  g.spacing = 0;
  for (const auto& t : g.micro_triangles)
    for (int k = 0; k < 3; ++k) g.spacing = std::max(g.spacing, (g.points[t[k]] - g.points[t[(k + 1) % 3]]).norm());
  return g;
}

std::vector<Eigen::Vector3d> SampleSurfaceUniform(const TriangleMesh& mesh, int n, uint64_t seed,
                                                  std::vector<int>* faces) {
  CheckMeshIndices(mesh, "surface sampling");
  std::vector<double> area(mesh.faces.size());
  for (size_t i = 0; i < mesh.faces.size(); ++i) {
    const auto& f = mesh.faces[i];
    area[i] = (mesh.vertices[f[1]] - mesh.vertices[f[0]]).cross(mesh.vertices[f[2]] - mesh.vertices[f[0]]).norm();
  }
  const Distribution1D pick(area);
  std::vector<Eigen::Vector3d> out(n);
  if (faces) faces->resize(n);
  for (int i = 0; i < n; ++i) {
    RandomStream rng(seed, static_cast<uint64_t>(i), 0);
    double p;
    const int fi = pick.SampleDiscrete(rng.Uniform(), &p);
    const auto& f = mesh.faces[fi];
    // Uniform barycentrics (Osada et al. 2002, "Shape distributions").
    const double r1 = std::sqrt(rng.Uniform()), r2 = rng.Uniform();
    out[i] = (1 - r1) * mesh.vertices[f[0]] + r1 * (1 - r2) * mesh.vertices[f[1]] + r1 * r2 * mesh.vertices[f[2]];
    if (faces) (*faces)[i] = fi;
  }
  return out;
}

}  // namespace shadowsg
