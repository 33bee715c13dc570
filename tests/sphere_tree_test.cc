#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <sstream>

#include "calib/error.h"
#include "solver/mesh_distance.h"
#include "solver/point_kdtree.h"
#include "solver/primitives.h"
#include "solver/sphere_tree_build.h"
#include "solver/sphere_tree_fit.h"
#include "solver/surface_samples.h"
#include "stages/io/mesh_io.h"
#include "stages/io/sph_io.h"

namespace shadowsg {
namespace {

constexpr double kPi = 3.14159265358979323846;
// Allowance for rounding in "inside a sphere", relative to the bbox diagonal.
constexpr double kInsideSlack = 1e-9;

double Diagonal(const TriangleMesh& m) {
  Eigen::Vector3d lo, hi;
  MeshBounds(m, &lo, &hi);
  return (hi - lo).norm();
}

// Smaller than the defaults, for tests that check structure, not tightness.
SphereTreeBuildOptions Quick() {
  SphereTreeBuildOptions o;
  o.surface_points = 10000;
  o.medial_spheres = 2000;
  return o;
}

// Index of a non-empty sphere of `level` holding p, or -1.
int Holder(const SphereTree& t, int level, const Eigen::Vector3d& p, double slack) {
  for (size_t i = t.LevelBegin(level); i < t.LevelEnd(level); ++i)
    if (!t.nodes[i].empty() && (p - t.nodes[i].centre).norm() <= t.nodes[i].radius + slack) return static_cast<int>(i);
  return -1;
}

TriangleMesh Spot() { return ReadMesh(std::string(SHADOWSG_SOURCE_DIR) + "/data/sample/spot.obj"); }

// Builds with the default options and checks that every level covers every
// vertex and dense random surface points (not the builder's grid), and that the
// leaves are tight: union/mesh volume and worst protrusion below bounds measured
// with the default options (Release, seed 0) plus a margin.
void ExpectCoveringAndTight(const TriangleMesh& mesh, double max_volume_ratio, double max_protrusion) {
  SphereTreeBuildSummary summary;
  const SphereTree t = BuildSphereTree(mesh, SphereTreeBuildOptions{}, {}, &summary);
  ASSERT_EQ(t.levels, 4);
  ASSERT_EQ(t.branching, 8);
  ASSERT_EQ(t.nodes.size(), 585u);
  EXPECT_EQ(summary.boundary_edges, 0);
  EXPECT_GT(summary.leaves, 64);
  const double slack = kInsideSlack * Diagonal(mesh);
  const auto samples = SampleSurfaceUniform(mesh, 30000, 12345);
  for (int level = 0; level < t.levels; ++level) {
    int missed = 0;
    for (int v : ReferencedVertices(mesh)) missed += Holder(t, level, mesh.vertices[v], slack) < 0;
    for (const auto& p : samples) missed += Holder(t, level, p, slack) < 0;
    EXPECT_EQ(missed, 0) << "level " << level;
  }
  const SphereTreeFit fit = EvaluateSphereTreeFit(mesh, t);  // 100000 more surface points
  EXPECT_EQ(fit.surface_coverage, 1.0);
  EXPECT_EQ(fit.vertex_coverage, 1.0);
  EXPECT_GT(fit.inside_covered, 0.999);
  EXPECT_LT(fit.volume_ratio, max_volume_ratio);
  EXPECT_GT(fit.volume_ratio, 1.0 - 4 * fit.volume_ratio_error);
  EXPECT_LT(fit.max_protrusion, max_protrusion);
}

// Measured: union/mesh 1.02-1.04, worst protrusion 0.002-0.006 of the diagonal.
TEST(SphereTreeBuild, TorusCoveredTightly) { ExpectCoveringAndTight(MakeTorus(0.5, 0.15, 48, 24), 1.08, 0.012); }
// Measured: 1.09-1.10 and 0.020 (sharp edges and corners need small, many leaves).
TEST(SphereTreeBuild, BoxCoveredTightly) { ExpectCoveringAndTight(MakeBox(Eigen::Vector3d(0.5, 0.3, 0.2)), 1.15, 0.03); }
// Measured: 1.05-1.06 and 0.006-0.010.
TEST(SphereTreeBuild, SpotCoveredTightly) { ExpectCoveringAndTight(Spot(), 1.10, 0.015); }

TEST(SphereTreeBuild, ChildrenLieInsideTheirParents) {
  const SphereTree t = BuildSphereTree(MakeTorus(0.5, 0.15, 32, 16), Quick());
  for (size_t i = 0; i < t.LevelBegin(t.levels - 1); ++i)
    for (int k = 0; k < t.branching; ++k) {
      const Sphere& c = t.nodes[t.FirstChild(i) + k];
      if (c.empty()) continue;
      ASSERT_FALSE(t.nodes[i].empty());
      EXPECT_LE((c.centre - t.nodes[i].centre).norm() + c.radius, t.nodes[i].radius * (1 + 1e-12));
    }
}

TEST(SphereTreeBuild, DeterministicAcrossThreadCounts) {
  const TriangleMesh m = MakeTorus(0.5, 0.2, 32, 16);
  SphereTreeBuildOptions o = Quick();
  o.seed = 7;
  const int threads = omp_get_max_threads();
  omp_set_num_threads(1);
  const SphereTree a = BuildSphereTree(m, o);
  omp_set_num_threads(std::max(2, threads));
  const SphereTree b = BuildSphereTree(m, o);
  omp_set_num_threads(threads);
  ASSERT_EQ(a.nodes.size(), b.nodes.size());
  for (size_t i = 0; i < a.nodes.size(); ++i) {
    EXPECT_EQ(a.nodes[i].centre, b.nodes[i].centre) << i;
    EXPECT_EQ(a.nodes[i].radius, b.nodes[i].radius) << i;
  }
}

TEST(SphereTreeBuild, SphRoundTrip) {
  const SphereTree t = BuildSphereTree(MakeBox(Eigen::Vector3d(0.5, 0.5, 0.5)), Quick());
  std::stringstream s;
  WriteSph(s, t);
  const SphereTree r = ReadSph(s, "memory");
  ASSERT_EQ(r.levels, t.levels);
  ASSERT_EQ(r.branching, t.branching);
  ASSERT_EQ(r.nodes.size(), t.nodes.size());
  for (size_t i = 0; i < t.nodes.size(); ++i) {
    EXPECT_EQ(r.nodes[i].empty(), t.nodes[i].empty()) << i;
    if (t.nodes[i].empty()) continue;
    EXPECT_LT((r.nodes[i].centre - t.nodes[i].centre).norm(), 1e-8) << i;
    EXPECT_NEAR(r.nodes[i].radius, t.nodes[i].radius, 1e-8) << i;
  }
}

// A scan is far finer than the builder's grid. Its tree is built from an
// even subset of its vertices and should be as tight as a coarser mesh's of
// the same shape (measured: union/mesh 1.009 against 1.044, mean protrusion
// 0.0003 against 0.0018) while still covering every vertex and surface point.
TEST(SphereTreeBuild, AFineMeshIsThinnedAndAsTight) {
  const SphereTreeBuildOptions o = Quick();  // 10000 grid points, 2000 seeds
  const TriangleMesh coarse = MakeTorus(0.5, 0.15, 64, 32);   // 2048 vertices: a grid of 10000
  const TriangleMesh fine = MakeTorus(0.5, 0.15, 256, 128);   // 32768 vertices
  SphereTreeBuildSummary sc, sf;
  const SphereTree tc = BuildSphereTree(coarse, o, {}, &sc);
  const SphereTree tf = BuildSphereTree(fine, o, {}, &sf);
  EXPECT_EQ(sc.cover_points, sc.surface_points);
  EXPECT_EQ(sf.surface_points, 32768);
  EXPECT_GT(sf.cover_points, o.surface_points / 2);
  EXPECT_LT(sf.cover_points, 2 * o.surface_points);
  const SphereTreeFit fc = EvaluateSphereTreeFit(coarse, tc), ff = EvaluateSphereTreeFit(fine, tf);
  std::printf("coarse: %d leaves, %d medial, union/mesh %.3f, protrusion max %.4f mean %.4f\n", sc.leaves,
              sc.medial_spheres, fc.volume_ratio, fc.max_protrusion, fc.mean_protrusion);
  std::printf("fine: %d leaves, %d medial, %d cover points, union/mesh %.3f, protrusion max %.4f mean %.4f\n",
              sf.leaves, sf.medial_spheres, sf.cover_points, ff.volume_ratio, ff.max_protrusion, ff.mean_protrusion);
  EXPECT_EQ(ff.surface_coverage, 1.0);
  EXPECT_EQ(ff.vertex_coverage, 1.0);
  EXPECT_LT(ff.volume_ratio, fc.volume_ratio + 0.02);
  EXPECT_LT(ff.mean_protrusion, 1.25 * fc.mean_protrusion);
  const double slack = kInsideSlack * Diagonal(fine);
  int missed = 0;
  for (const auto& v : fine.vertices) missed += Holder(tf, tf.levels - 1, v, slack) < 0;
  EXPECT_EQ(missed, 0);
}

// A grid that is all mesh vertices (more vertices than surface_points, too
// few to be thinned) has no other points to seed medial balls from; the
// vertices give the whole seed budget. Measured on Spot: 656 distinct balls,
// union/mesh 1.088; with a quarter of the seeds 329 and 1.157.
TEST(SphereTreeBuild, AGridOfVerticesAloneGetsEverySeed) {
  SphereTreeBuildOptions o;
  o.surface_points = 2500;  // Spot has 2930 vertices
  o.medial_spheres = 2000;
  SphereTreeBuildSummary sum;
  const TriangleMesh spot = Spot();
  const SphereTree t = BuildSphereTree(spot, o, {}, &sum);
  EXPECT_EQ(sum.cover_points, sum.surface_points);
  EXPECT_GT(sum.medial_spheres, 500);
  EXPECT_LT(EvaluateSphereTreeFit(spot, t).volume_ratio, 1.12);
}

TEST(SphereTreeBuild, OtherShapesAndSizes) {
  SphereTreeBuildOptions o;
  o.levels = 3;
  o.branching = 4;
  o.surface_points = 5000;
  o.medial_spheres = 1000;
  const TriangleMesh cone = MakeCone(0.3, 0.8, 24);
  const SphereTree t = BuildSphereTree(cone, o);
  EXPECT_EQ(t.nodes.size(), 21u);
  const double slack = kInsideSlack * Diagonal(cone);
  for (const auto& p : SampleSurfaceUniform(cone, 20000, 3)) ASSERT_GE(Holder(t, 2, p, slack), 0);
  // A root-only tree is one sphere around everything.
  o.levels = 1;
  const SphereTree root = BuildSphereTree(cone, o);
  ASSERT_EQ(root.nodes.size(), 1u);
  for (const auto& v : cone.vertices) EXPECT_GE(Holder(root, 0, v, slack), 0);
}

TEST(SphereTreeBuild, OpenAndInvertedMeshesStillCovered) {
  SphereTreeBuildOptions o;
  o.surface_points = 8000;
  o.medial_spheres = 2000;
  TriangleMesh open = MakeBox(Eigen::Vector3d(0.5, 0.4, 0.3));
  open.faces.pop_back();
  SphereTreeBuildSummary s;
  const SphereTree a = BuildSphereTree(open, o, {}, &s);
  EXPECT_GT(s.boundary_edges, 0);
  TriangleMesh inverted = MakeTorus(0.5, 0.2, 24, 12);
  for (auto& f : inverted.faces) std::swap(f[1], f[2]);
  const SphereTree b = BuildSphereTree(inverted, o, {}, &s);
  EXPECT_TRUE(s.inverted);
  for (const auto& [mesh, tree] : {std::pair{&open, &a}, std::pair{&inverted, &b}}) {
    const double slack = kInsideSlack * Diagonal(*mesh);
    for (const auto& p : SampleSurfaceUniform(*mesh, 20000, 4)) ASSERT_GE(Holder(*tree, tree->levels - 1, p, slack), 0);
  }
  // Inverted: the spheres are still inside, not outside, the torus.
  EXPECT_LT(EvaluateSphereTreeFit(inverted, b).volume_ratio, 1.2);
}

TEST(SphereTreeBuild, RejectsBadInput) {
  SphereTreeBuildOptions o;
  std::string why;
  o.levels = 0;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_THROW(BuildSphereTree(MakeBox(Eigen::Vector3d::Ones()), o), InputError);
  o = {};
  o.branching = 1;
  EXPECT_FALSE(o.IsValid(&why));
  o = {};
  EXPECT_TRUE(o.IsValid(&why));
  EXPECT_THROW(BuildSphereTree(TriangleMesh{}, o), InputError);
  TriangleMesh bad = MakeBox(Eigen::Vector3d::Ones());
  bad.faces[0][1] = 99;
  EXPECT_THROW(BuildSphereTree(bad, o), InputError);
  TriangleMesh flat;
  flat.vertices = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}};
  flat.faces = {{0, 1, 2}};
  EXPECT_THROW(BuildSphereTree(flat, o), InputError);
  TriangleMesh nan = MakeBox(Eigen::Vector3d::Ones());
  nan.vertices[0].x() = std::nan("");
  EXPECT_THROW(BuildSphereTree(nan, o), InputError);
}

TEST(SphereTreeFit, KnownSpheres) {
  const TriangleMesh ball = MakeIcosphere(1.0, 4);
  const double v = MeshVolume(ball);
  SphereTree t;
  t.levels = 1;
  t.branching = 8;
  t.nodes = {{Eigen::Vector3d::Zero(), 1.0}};  // the circumsphere
  SphereTreeFitOptions o;
  o.volume_samples = 400000;
  SphereTreeFit f = EvaluateSphereTreeFit(ball, t, 0, o);
  EXPECT_NEAR(f.volume_ratio, 4.0 / 3.0 * kPi / v, 4 * f.volume_ratio_error + 1e-3);
  EXPECT_EQ(f.vertex_coverage, 1.0);
  EXPECT_EQ(f.surface_coverage, 1.0);
  EXPECT_GT(f.inside_covered, 0.9999);
  // It sticks out by at most the gap between the sphere and the facets.
  EXPECT_LT(f.max_protrusion * 2, 0.01);
  // Half the radius: an eighth of the volume, no surface, no protrusion.
  t.nodes[0].radius = 0.5;
  f = EvaluateSphereTreeFit(ball, t, 0, o);
  EXPECT_NEAR(f.inside_covered, 0.125 * 4.0 / 3.0 * kPi / v, 0.01);
  EXPECT_EQ(f.surface_coverage, 0.0);
  EXPECT_EQ(f.max_protrusion, 0.0);
  EXPECT_NEAR(f.outside_ratio, 0.0, 1e-12);
  // Off to the side by 2 radii: all of it outside, reaching 1 + 1 = 2 beyond the surface.
  t.nodes[0] = {Eigen::Vector3d(3, 0, 0), 1.0};
  f = EvaluateSphereTreeFit(ball, t, 0, o);
  EXPECT_NEAR(f.max_protrusion * 2 * std::sqrt(3.0), 3.0, 0.05);  // farthest point at 4, surface at 1
  EXPECT_THROW(EvaluateSphereTreeFit(ball, t, 1, o), InputError);
}

TEST(GeometryQueries, KdTreeMatchesBruteForce) {
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<Eigen::Vector3d> pts(3000);
  for (auto& p : pts) p = {u(rng), u(rng), 0.2 * u(rng)};
  const PointKdTree kd(pts);
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3d q(2 * u(rng), 2 * u(rng), 2 * u(rng));
    std::vector<std::pair<double, int>> all;
    for (size_t j = 0; j < pts.size(); ++j) all.emplace_back((pts[j] - q).squaredNorm(), static_cast<int>(j));
    std::sort(all.begin(), all.end());
    double d2;
    EXPECT_EQ(kd.Nearest(q, &d2), all[0].second);
    EXPECT_EQ(d2, all[0].first);
    const auto k = kd.KNearest(q, 5);
    ASSERT_EQ(k.size(), 5u);
    for (int j = 0; j < 5; ++j) EXPECT_EQ(k[j], all[j].second);
    std::vector<int> within;
    const double r = std::sqrt(all[40].first);
    kd.WithinRadius(q, r, &within);
    EXPECT_EQ(within.size(), static_cast<size_t>(std::count_if(all.begin(), all.end(), [&](const auto& a) {
                return a.first <= r * r;
              })));
  }
}

TEST(GeometryQueries, SurfaceGridTilesTheMesh) {
  const TriangleMesh m = MakeCylinder(0.4, 1.0, 16);
  const SurfaceGrid g = SampleSurfaceGrid(m, 3000);
  EXPECT_GT(g.points.size(), 2000u);
  EXPECT_LT(g.points.size(), 4500u);
  double area = 0;
  for (const auto& t : g.micro_triangles) {
    area += 0.5 * (g.points[t[1]] - g.points[t[0]]).cross(g.points[t[2]] - g.points[t[0]]).norm();
    for (int k = 0; k < 3; ++k) EXPECT_LE((g.points[t[k]] - g.points[t[(k + 1) % 3]]).norm(), g.spacing * (1 + 1e-12));
  }
  EXPECT_NEAR(area, MeshArea(m), 1e-9 * MeshArea(m));
  for (size_t i = 0; i < g.points.size(); ++i) EXPECT_NEAR(g.normals[i].norm(), 1.0, 1e-12);
}

// A mesh with more vertices than the target (a scan) is its own grid: every
// face one micro-triangle.
TEST(GeometryQueries, AFineMeshIsItsOwnGrid) {
  const TriangleMesh m = MakeTorus(0.5, 0.15, 64, 32);  // 2048 vertices
  const SurfaceGrid g = SampleSurfaceGrid(m, 1500);
  EXPECT_EQ(g.points.size(), m.vertices.size());
  EXPECT_EQ(g.micro_triangles.size(), m.faces.size());
}

TEST(GeometryQueries, MeshDistanceIsExact) {
  const TriangleMesh box = MakeBox(Eigen::Vector3d(1, 1, 1));
  const MeshDistance d(box, SampleSurfaceGrid(box, 500));
  EXPECT_NEAR(d.Distance({0, 0, 0}), 1.0, 1e-12);
  EXPECT_NEAR(d.Distance({0.3, 0.2, 3}), 2.0, 1e-12);
  EXPECT_NEAR(d.Distance({2, 2, 2}), std::sqrt(3.0), 1e-12);
  EXPECT_NEAR(d.Distance({0.5, 0.9, -0.2}), 0.1, 1e-12);
}

}  // namespace
}  // namespace shadowsg
