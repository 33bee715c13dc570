#include "solver/sphere_tree_fit.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "calib/error.h"
#include "solver/mesh_distance.h"
#include "solver/ray_caster.h"
#include "solver/sampling.h"
#include "solver/surface_samples.h"

namespace shadowsg {
namespace {

// "Inside a sphere" tolerance for rounding, relative to the bbox diagonal.
constexpr double kContainsSlack = 1e-9;
// Step past a hit when counting crossings (Embree works in float), relative to the diagonal.
constexpr double kParityStep = 1e-6;
// A direction aligned with no axis or diagonal, so parity rays rarely graze edges of axis-aligned meshes.
const Eigen::Vector3d kParityDir = Eigen::Vector3d(0.5412, 0.3127, 0.7809).normalized();
constexpr int kMaxCrossings = 10000;
// Grid points for the exact distance to the surface (speed only, not accuracy).
constexpr int kDistanceGridPoints = 20000;
constexpr uint64_t kVolumeStream = 1, kSurfaceStream = 2;

bool InsideMesh(const RayCaster& rc, const Eigen::Vector3d& p, double step) {
  int crossings = 0;
  double t = 0;
  for (; crossings < kMaxCrossings; ++crossings) {
    const auto hit = rc.Intersect(p, kParityDir, t);
    if (!hit) break;
    t = hit->t + step;
  }
  return crossings % 2 == 1;
}

// Points on the unit sphere, evenly spread (golden-angle spiral).
std::vector<Eigen::Vector3d> FibonacciSphere(int n) {
  std::vector<Eigen::Vector3d> d(n);
  const double golden = 3.14159265358979323846 * (3 - std::sqrt(5.0));
  for (int i = 0; i < n; ++i) {
    const double z = 1 - (2 * i + 1.0) / n, rho = std::sqrt(std::max(0.0, 1 - z * z));
    d[i] = {rho * std::cos(golden * i), rho * std::sin(golden * i), z};
  }
  return d;
}

}  // namespace

bool SphereTreeFitOptions::IsValid(std::string* why) const {
  auto fail = [&](const std::string& w) {
    if (why) *why = w;
    return false;
  };
  if (volume_samples < 1) return fail("volume_samples must be positive");
  if (surface_samples < 1) return fail("surface_samples must be positive");
  if (sphere_directions < 1) return fail("sphere_directions must be positive");
  return true;
}

void SphereTreeFitOptions::Check() const {
  std::string why;
  if (!IsValid(&why)) throw InputError("sphere tree fit options", why);
}

std::string SphereTreeFit::BriefReport() const {
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "level %d: %d spheres, union/mesh volume %.3f (+-%.3f), outside %.3f, inside covered %.4f, "
                "protrusion max %.4f mean %.4f (of bbox diagonal), coverage vertices %.5f surface %.5f%s",
                level, spheres, volume_ratio, volume_ratio_error, outside_ratio, inside_covered, max_protrusion,
                mean_protrusion, vertex_coverage, surface_coverage,
                boundary_edges ? (", OPEN MESH: " + std::to_string(boundary_edges) + " boundary edges").c_str() : "");
  return buf;
}

SphereTreeFit EvaluateSphereTreeFit(const TriangleMesh& mesh, const SphereTree& tree, int level,
                                    const SphereTreeFitOptions& options) {
  options.Check();
  CheckMeshIndices(mesh, "sphere tree fit");
  if (tree.levels < 1 || tree.nodes.size() != SphereTree::NodeCount(tree.levels, tree.branching))
    throw InputError("sphere tree fit", "malformed sphere tree");
  if (level < 0) level = tree.levels - 1;
  if (level >= tree.levels)
    throw InputError("sphere tree fit", "level " + std::to_string(level) + " of a tree with " +
                                            std::to_string(tree.levels) + " levels");
  SphereTreeFit fit;
  fit.level = level;
  fit.boundary_edges = CountBoundaryEdges(mesh);
  fit.mesh_volume = std::abs(MeshVolume(mesh));
  std::vector<Sphere> spheres;
  for (size_t i = tree.LevelBegin(level); i < tree.LevelEnd(level); ++i)
    if (!tree.nodes[i].empty()) spheres.push_back(tree.nodes[i]);
  fit.spheres = static_cast<int>(spheres.size());

  const std::vector<int> verts = ReferencedVertices(mesh);
  Eigen::Vector3d lo = mesh.vertices[verts[0]], hi = lo;
  for (int v : verts) lo = lo.cwiseMin(mesh.vertices[v]), hi = hi.cwiseMax(mesh.vertices[v]);
  const double diag = (hi - lo).norm();
  const double slack = kContainsSlack * diag;
  auto in_union = [&](const Eigen::Vector3d& p) {
    for (const Sphere& s : spheres)
      if ((p - s.centre).squaredNorm() <= (s.radius + slack) * (s.radius + slack)) return true;
    return false;
  };

  RayCaster rc;
  rc.AddMesh(mesh);
  rc.Commit();
  const double step = kParityStep * diag;

  // Coverage.
  long covered = 0;
#pragma omp parallel for reduction(+ : covered)
  for (long i = 0; i < static_cast<long>(verts.size()); ++i) covered += in_union(mesh.vertices[verts[i]]);
  fit.vertex_coverage = static_cast<double>(covered) / verts.size();
  const auto surface = SampleSurfaceUniform(mesh, options.surface_samples, options.seed ^ (kSurfaceStream << 40));
  covered = 0;
#pragma omp parallel for reduction(+ : covered)
  for (long i = 0; i < static_cast<long>(surface.size()); ++i) covered += in_union(surface[i]);
  fit.surface_coverage = static_cast<double>(covered) / surface.size();

  // Volumes by Monte Carlo in the box around mesh and spheres.
  Eigen::Vector3d blo = lo, bhi = hi;
  for (const Sphere& s : spheres) {
    blo = blo.cwiseMin(s.centre - Eigen::Vector3d::Constant(s.radius));
    bhi = bhi.cwiseMax(s.centre + Eigen::Vector3d::Constant(s.radius));
  }
  const double box_volume = (bhi - blo).prod();
  long n_union = 0, n_union_mesh = 0, n_mesh = 0;
  const long n = options.volume_samples;
#pragma omp parallel for reduction(+ : n_union, n_union_mesh, n_mesh) schedule(dynamic, 1024)
  for (long i = 0; i < n; ++i) {
    RandomStream rng(options.seed, (kVolumeStream << 40) ^ static_cast<uint64_t>(i), 0);
    const Eigen::Vector3d u(rng.Uniform(), rng.Uniform(), rng.Uniform());
    const Eigen::Vector3d p = blo + (bhi - blo).cwiseProduct(u);
    const bool in_m = (p.array() >= lo.array()).all() && (p.array() <= hi.array()).all() && InsideMesh(rc, p, step);
    const bool in_u = in_union(p);
    n_union += in_u;
    n_mesh += in_m;
    n_union_mesh += in_u && in_m;
  }
  if (fit.mesh_volume > 0) {
    const double f = static_cast<double>(n_union) / n;
    fit.union_volume = f * box_volume;
    fit.volume_ratio = fit.union_volume / fit.mesh_volume;
    fit.volume_ratio_error = std::sqrt(f * (1 - f) / n) * box_volume / fit.mesh_volume;
    fit.outside_ratio = static_cast<double>(n_union - n_union_mesh) / n * box_volume / fit.mesh_volume;
  }
  fit.inside_covered = n_mesh > 0 ? static_cast<double>(n_union_mesh) / n_mesh : 0.0;

  // Protrusion: the farthest point of each sphere outside the mesh.
  const SurfaceGrid grid = SampleSurfaceGrid(mesh, kDistanceGridPoints);
  const MeshDistance distance(mesh, grid);
  const std::vector<Eigen::Vector3d> dirs = FibonacciSphere(options.sphere_directions);
  std::vector<double> protrusion(spheres.size(), 0);
#pragma omp parallel for schedule(dynamic, 4)
  for (long s = 0; s < static_cast<long>(spheres.size()); ++s)
    for (const auto& d : dirs) {
      const Eigen::Vector3d p = spheres[s].centre + spheres[s].radius * d;
      if (!InsideMesh(rc, p, step)) protrusion[s] = std::max(protrusion[s], distance.Distance(p));
    }
  if (!spheres.empty()) {
    fit.max_protrusion = *std::max_element(protrusion.begin(), protrusion.end()) / diag;
    double sum = 0;
    for (double p : protrusion) sum += p;
    fit.mean_protrusion = sum / spheres.size() / diag;
  }
  return fit;
}

}  // namespace shadowsg
