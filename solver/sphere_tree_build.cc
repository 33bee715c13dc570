#include "solver/sphere_tree_build.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <unordered_set>

#include <Eigen/Eigenvalues>

#include "calib/error.h"
#include "solver/enclosing_sphere.h"
#include "solver/medial_spheres.h"
#include "solver/point_kdtree.h"
#include "solver/ray_caster.h"
#include "solver/sampling.h"
#include "solver/sort_by_key.h"
#include "solver/surface_samples.h"

namespace shadowsg {
namespace {

// Medial balls smaller than this fraction of the bbox diagonal are noise.
constexpr double kMinMedialRadius = 1e-6;
// Rays to the opposite wall start this far (of the diagonal) off the surface,
// past the float rounding of Embree's own hit (~1e-7 relative).
constexpr double kWallRayStart = 1e-5;
// Candidates whose centre and radius agree to this fraction of the grid
// spacing are one candidate (a round part yields thousands of equal balls).
constexpr double kDuplicateCell = 0.5;
// At most 1/kVertexSeedShare of the seeds are mesh vertices (measured on
// Spot, a cow, a cone and a torus: 1/4 to 1/2 beat none on sharp rims and
// cost nothing on smooth meshes).
constexpr int kVertexSeedShare = 4;
// Seeds within this fraction of the grid spacing of an earlier ball's surface
// (and facing its centre) make no new ball.
constexpr double kTouchTolerance = 0.02;
// Bisection steps on the stand-off delta: 2^-16 of the first feasible one.
constexpr int kStandoffBisections = 16;
// Passes that hand a leaf's farthest points to siblings that already hold them.
constexpr int kHandOverPasses = 2;
// Halvings of a micro-triangle that straddles leaves before a leaf is grown
// (each halves the growth it can need).
constexpr int kMicroSplitDepth = 4;
// Enclosing-sphere steps for inner nodes: radius within ~1.5 % of the smallest.
constexpr int kInnerSphereIterations = 4096;
// Memory guard on the candidate x point stand-off lists (8 bytes each,
// 128 MiB): beyond it every other candidate is dropped and the lists rebuilt.
constexpr size_t kMaxListEntries = size_t{1} << 24;

// Without a medial cover, a point may go to (and a micro-triangle be covered
// by) one of this many nearest leaf centres.
constexpr int kFallbackNear = 8;

// Random stream ids, so that each use of the seed draws its own numbers.
constexpr uint64_t kSeedStream = 1;

// A grid of more than this many times surface_points (a scan's vertices) is
// thinned for the medial balls and the leaf cover (EvenSubset).
constexpr double kDenseGrid = 1.5;

using Points = std::vector<Eigen::Vector3d>;

// About `target` of the points, evenly spread: the first point (in index
// order, so mesh vertices first) of each occupied cell of a voxel grid. A
// surface of area A meets about 1.5 A / h^2 cells of size h (1 to sqrt(3)
// per h^2 of area by its orientation). *cell gets h.
std::vector<int> EvenSubset(const Points& pts, double area, int target, double* cell) {
  *cell = std::sqrt(1.5 * area / target);
  std::unordered_set<uint64_t> seen;
  std::vector<int> out;
  for (size_t i = 0; i < pts.size(); ++i) {
    uint64_t key = 0;
    for (int k = 0; k < 3; ++k) key = Mix64(key ^ static_cast<uint64_t>(std::llround(std::floor(pts[i][k] / *cell))));
    if (seen.insert(key).second) out.push_back(static_cast<int>(i));
  }
  return out;
}

struct Candidate {
  Eigen::Vector3d centre;
  double radius;
};

// Balls that agree to within `cell` in centre and radius are merged (the first
// one of a cell is kept: seeds are in random order already).
std::vector<Candidate> DistinctCandidates(const std::vector<MedialSphere>& medial, double cell) {
  std::unordered_set<uint64_t> seen;
  std::vector<Candidate> out;
  for (const auto& m : medial) {
    uint64_t key = 0;
    for (int k = 0; k < 3; ++k) key = Mix64(key ^ static_cast<uint64_t>(std::llround(m.centre[k] / cell)));
    key = Mix64(key ^ static_cast<uint64_t>(std::llround(m.radius / cell)));
    if (seen.insert(key).second) out.push_back({m.centre, m.radius});
  }
  return out;
}

// For each candidate, the points it covers once grown by `cap`, as (stand-off
// |p - c| - r minus the smallest stand-off any candidate achieves at p, point)
// sorted by that value.
using StandoffList = std::vector<std::pair<float, int>>;

bool BuildLists(const PointKdTree& kd, const std::vector<Candidate>& cands, double cap,
                std::vector<StandoffList>* lists) {
  const Points& pts = kd.points();
  lists->assign(cands.size(), {});
  size_t total = 0;
  std::atomic<bool> too_big{false};
#pragma omp parallel
  {
    std::vector<int> near;
#pragma omp for schedule(dynamic, 16) reduction(+ : total)
    for (long i = 0; i < static_cast<long>(cands.size()); ++i) {
      if (too_big) continue;
      near.clear();
      kd.WithinRadius(cands[i].centre, cands[i].radius + cap, &near);
      StandoffList& l = (*lists)[i];
      l.reserve(near.size());
      for (int p : near) l.emplace_back(static_cast<float>((pts[p] - cands[i].centre).norm() - cands[i].radius), p);
      total += l.size();
      if (l.size() > kMaxListEntries) too_big = true;
    }
  }
  if (too_big || total > kMaxListEntries) return false;
  // Stand-offs relative to the point's best: a point that no candidate
  // reaches closely (a sharp rim, a thin fin) gets what its best candidate
  // needs, and the common delta is spent on the rest.
  std::vector<float> best(pts.size(), std::numeric_limits<float>::infinity());
  for (const auto& l : *lists)
    for (const auto& [e, p] : l) best[p] = std::min(best[p], std::max(e, 0.0f));
#pragma omp parallel for schedule(dynamic, 64)
  for (long i = 0; i < static_cast<long>(lists->size()); ++i) {
    StandoffList& l = (*lists)[i];
    for (auto& [e, p] : l) e -= best[p];
    std::sort(l.begin(), l.end());
  }
  return true;
}

// Lazy greedy set cover (Minoux's accelerated greedy: a stale gain is an upper
// bound, as gains only shrink). A candidate covers its list's points with
// stand-off <= delta. True when at most max_picks candidates cover all points.
bool GreedyCover(const std::vector<StandoffList>& lists, int n_points, float delta, int max_picks,
                 std::vector<int>* picks) {
  picks->clear();
  auto prefix = [&](int i) {
    const StandoffList& l = lists[i];
    return static_cast<int>(std::upper_bound(l.begin(), l.end(), std::make_pair(delta, std::numeric_limits<int>::max())) -
                            l.begin());
  };
  std::vector<std::pair<int, int>> heap;  // (gain, -candidate): ties go to the lower index
  for (int i = 0; i < static_cast<int>(lists.size()); ++i)
    if (const int g = prefix(i); g > 0) heap.emplace_back(g, -i);
  std::make_heap(heap.begin(), heap.end());
  std::vector<unsigned char> uncovered(n_points, 1);
  int remaining = n_points;
  while (remaining > 0 && !heap.empty()) {
    std::pop_heap(heap.begin(), heap.end());
    const int i = -heap.back().second;
    heap.pop_back();
    const int n = prefix(i);
    int g = 0;
    for (int k = 0; k < n; ++k) g += uncovered[lists[i][k].second];
    if (g == 0) continue;
    if (!heap.empty() && g < heap.front().first) {
      heap.emplace_back(g, -i);
      std::push_heap(heap.begin(), heap.end());
      continue;
    }
    if (static_cast<int>(picks->size()) == max_picks) return false;
    for (int k = 0; k < n; ++k) uncovered[lists[i][k].second] = 0;
    remaining -= g;
    picks->push_back(i);
  }
  return remaining == 0;
}

// Leaves at the chosen centres: each point to the leaf it protrudes least from
// (stand-off against the medial radius), then each leaf shrunk to its farthest
// point after handing points that another leaf holds anyway to that leaf.
// owner[p] gets the leaf of point p.
std::vector<Sphere> AssignAndShrink(const Points& pts, const std::vector<Candidate>& picks,
                                    const std::vector<std::vector<int>>& near_picks, std::vector<int>* owner) {
  const int k = static_cast<int>(picks.size());
  std::vector<std::vector<int>> regions(k);
  owner->assign(pts.size(), -1);
  for (size_t p = 0; p < pts.size(); ++p) {
    int best = -1;
    double best_e = std::numeric_limits<double>::infinity();
    for (int j : near_picks[p]) {
      const double e = (pts[p] - picks[j].centre).norm() - picks[j].radius;
      if (e < best_e) best_e = e, best = j;
    }
    SHADOWSG_CHECK(best >= 0);
    regions[best].push_back(static_cast<int>(p));
  }
  std::vector<double> radius(k, 0);
  auto farthest = [&](int j) {
    double r = 0;
    for (int p : regions[j]) r = std::max(r, (pts[p] - picks[j].centre).norm());
    return r;
  };
  for (int j = 0; j < k; ++j) radius[j] = farthest(j);
  for (int pass = 0; pass < kHandOverPasses; ++pass)
    for (int j = 0; j < k; ++j) {
      auto& reg = regions[j];
      // Farthest first; ties by point index, so the order does not depend on the last pass's.
      SortByKey(&reg, [&](int p) { return std::make_pair(-(pts[p] - picks[j].centre).squaredNorm(), p); });
      size_t kept = 0;
      for (; kept < reg.size(); ++kept) {
        const int p = reg[kept];
        int holder = -1;
        for (int o : near_picks[p])
          if (o != j && !regions[o].empty() && (pts[p] - picks[o].centre).norm() <= radius[o]) {
            holder = o;
            break;
          }
        if (holder < 0) break;
        regions[holder].push_back(p);
      }
      reg.erase(reg.begin(), reg.begin() + kept);
      radius[j] = farthest(j);
    }
  std::vector<Sphere> leaves(k);
  for (int j = 0; j < k; ++j) {
    leaves[j] = {picks[j].centre, regions[j].empty() ? 0.0 : radius[j]};
    for (int p : regions[j]) (*owner)[p] = j;
  }
  return leaves;
}

// Without usable medial spheres (a degenerate surface): farthest-point
// clusters of the points, each leaf centred on its cluster's mean.
std::vector<Candidate> FallbackCentres(const Points& pts, int k) {
  std::vector<int> centres = {0};
  std::vector<double> d2(pts.size(), std::numeric_limits<double>::infinity());
  while (static_cast<int>(centres.size()) < k) {
    size_t far = 0;
    for (size_t i = 0; i < pts.size(); ++i) {
      d2[i] = std::min(d2[i], (pts[i] - pts[centres.back()]).squaredNorm());
      if (d2[i] > d2[far]) far = i;
    }
    if (d2[far] == 0) break;
    centres.push_back(static_cast<int>(far));
  }
  std::vector<Candidate> out;
  for (int c : centres) out.push_back({pts[c], 0.0});
  return out;
}

// Makes every micro-triangle lie inside one leaf. A triangle inside a leaf
// near one of its corners is done; otherwise it is split in four (to
// kMicroSplitDepth) and, where a piece is still in none of those leaves, the
// one needing the least growth grows. Returns the largest growth.
double CoverMicroTriangles(const SurfaceGrid& grid, const std::vector<int>& owner,
                           const std::vector<std::vector<int>>& near_leaves, std::vector<Sphere>* leaves) {
  const Points& pts = grid.points;
  double largest = 0;
  struct Piece {
    Eigen::Vector3d v[3];
    int depth;
  };
  std::vector<Piece> stack;
  std::vector<int> o;
  for (const auto& t : grid.micro_triangles) {
    if (owner[t[0]] == owner[t[1]] && owner[t[1]] == owner[t[2]]) continue;
    // The leaves that may hold a piece: those near any corner.
    o.clear();
    for (int k = 0; k < 3; ++k) o.insert(o.end(), near_leaves[t[k]].begin(), near_leaves[t[k]].end());
    std::sort(o.begin(), o.end());
    o.erase(std::unique(o.begin(), o.end()), o.end());
    stack.assign(1, Piece{{pts[t[0]], pts[t[1]], pts[t[2]]}, 0});
    while (!stack.empty()) {
      const Piece piece = stack.back();
      stack.pop_back();
      int best = -1;
      double best_growth = std::numeric_limits<double>::infinity(), best_radius = 0;
      for (int j : o) {
        const Sphere& s = (*leaves)[j];
        double need = 0;
        for (const auto& v : piece.v) need = std::max(need, (v - s.centre).norm());
        if (need - s.radius < best_growth) best_growth = need - s.radius, best = j, best_radius = need;
      }
      if (best_growth <= 0) continue;
      if (piece.depth < kMicroSplitDepth) {
        const Eigen::Vector3d m01 = 0.5 * (piece.v[0] + piece.v[1]), m12 = 0.5 * (piece.v[1] + piece.v[2]),
                              m20 = 0.5 * (piece.v[2] + piece.v[0]);
        const int d = piece.depth + 1;
        stack.push_back({{piece.v[0], m01, m20}, d});
        stack.push_back({{m01, piece.v[1], m12}, d});
        stack.push_back({{m20, m12, piece.v[2]}, d});
        stack.push_back({{m01, m12, m20}, d});
        continue;
      }
      largest = std::max(largest, best_growth);
      (*leaves)[best].radius = best_radius;
    }
  }
  return largest;
}

// Splits `items` into `parts` groups of at most `cap` each by recursive
// halving along the widest axis of their centres (balanced, spatially compact).
void SplitBalanced(std::vector<int> items, int parts, size_t cap, const std::vector<Sphere>& leaves,
                   std::vector<std::vector<int>>* out) {
  if (parts == 1) {
    out->push_back(std::move(items));
    return;
  }
  const int left_parts = parts / 2, right_parts = parts - left_parts;
  const size_t n = items.size();
  size_t n_left = (n * left_parts + parts / 2) / parts;
  n_left = std::min(n_left, left_parts * cap);
  n_left = std::max(n_left, n > right_parts * cap ? n - right_parts * cap : size_t{0});
  if (n > 1) {
    Eigen::Vector3d lo = leaves[items[0]].centre, hi = lo;
    for (int i : items) lo = lo.cwiseMin(leaves[i].centre), hi = hi.cwiseMax(leaves[i].centre);
    int axis;
    (hi - lo).maxCoeff(&axis);
    std::stable_sort(items.begin(), items.end(),
                     [&](int a, int b) { return leaves[a].centre[axis] < leaves[b].centre[axis]; });
  }
  std::vector<int> right(items.begin() + n_left, items.end());
  items.resize(n_left);
  SplitBalanced(std::move(items), left_parts, cap, leaves, out);
  SplitBalanced(std::move(right), right_parts, cap, leaves, out);
}

// Places the leaves into the tree's last level, subtree by subtree.
void PlaceLeaves(SphereTree* tree, size_t node, int level, std::vector<int> items, const std::vector<Sphere>& leaves) {
  if (level == tree->levels - 1) {
    SHADOWSG_CHECK(items.size() <= 1);
    if (!items.empty()) tree->nodes[node] = leaves[items[0]];
    return;
  }
  size_t cap = 1;
  for (int l = level + 1; l < tree->levels - 1; ++l) cap *= tree->branching;
  std::vector<std::vector<int>> groups;
  SplitBalanced(std::move(items), tree->branching, cap, leaves, &groups);
  for (int k = 0; k < tree->branching; ++k)
    PlaceLeaves(tree, tree->FirstChild(node) + k, level + 1, std::move(groups[k]), leaves);
}

}  // namespace

bool SphereTreeBuildOptions::IsValid(std::string* why) const {
  auto fail = [&](const std::string& w) {
    if (why) *why = w;
    return false;
  };
  if (levels < 1 || levels > 8) return fail("levels must be in [1, 8], got " + std::to_string(levels));
  if (branching < 2 || branching > 64) return fail("branching must be in [2, 64], got " + std::to_string(branching));
  if (SphereTree::NodeCount(levels, branching) > 2000000)
    return fail("a tree of " + std::to_string(levels) + " levels and branching " + std::to_string(branching) +
                " is too large");
  if (surface_points < 100) return fail("surface_points must be at least 100");
  if (medial_spheres < 1) return fail("medial_spheres must be positive");
  return true;
}

void SphereTreeBuildOptions::Check() const {
  std::string why;
  if (!IsValid(&why)) throw InputError("sphere tree options", why);
}

SphereTree BuildSphereTree(const TriangleMesh& mesh, const SphereTreeBuildOptions& options,
                           const ProgressFn& progress, SphereTreeBuildSummary* summary) {
  const auto start = std::chrono::steady_clock::now();
  options.Check();
  CheckMeshIndices(mesh, "sphere tree");
  if (!(MeshArea(mesh) > 0)) throw InputError("sphere tree", "mesh has zero surface area");
  {
    // Spheres fill a volume: a flat mesh (a card, a single sheet) has none.
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (const auto& v : mesh.vertices) mean += v;
    mean /= static_cast<double>(mesh.vertices.size());
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    for (const auto& v : mesh.vertices) cov += (v - mean) * (v - mean).transpose();
    const Eigen::Vector3d ev = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(cov, Eigen::EigenvaluesOnly).eigenvalues();
    if (!(ev[0] > 1e-12 * ev[2]))
      throw InputError("sphere tree", "the mesh is flat (all vertices on one plane): it encloses no volume to fill "
                                      "with spheres; give the object some thickness");
  }
  SphereTreeBuildSummary sum;
  sum.boundary_edges = CountBoundaryEdges(mesh);
  sum.inverted = MeshVolume(mesh) < 0;

  Report(progress, 0.0, "sampling the surface");
  const SurfaceGrid grid = SampleSurfaceGrid(mesh, options.surface_points);
  const Points& all = grid.points;
  Eigen::Vector3d lo = all[0], hi = all[0];  // bounds of the referenced vertices only
  for (const auto& p : all) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
  const double diag = (hi - lo).norm();
  sum.surface_points = static_cast<int>(all.size());
  sum.spacing = grid.spacing;

  // The points the medial balls and the leaf cover see: the grid, or for a
  // mesh much finer than it (a scan) an even subset of its vertices. On a
  // bunny cut to 1.1M faces the whole grid (556k points) overflowed the
  // cover's lists, which then dropped half the candidates: 322 leaves, mean
  // protrusion 0.0119 of the diagonal against 481 and 0.0063 from the
  // 69k-face original, and 5.2-6.9 s (solver/EXPERIMENTS.md, "Stop 59").
  std::vector<int> cover_index;
  double spacing = grid.spacing;
  if (all.size() > kDenseGrid * options.surface_points) {
    double cell = 0;
    cover_index = EvenSubset(all, MeshArea(mesh), options.surface_points, &cell);
    spacing = std::max(spacing, cell);
  }
  const bool thinned = !cover_index.empty();
  Points thin;
  for (int i : cover_index) thin.push_back(all[i]);
  const Points& pts = thinned ? thin : all;
  sum.cover_points = static_cast<int>(pts.size());
  auto grid_index = [&](size_t i) { return thinned ? static_cast<size_t>(cover_index[i]) : i; };

  Report(progress, 0.1, "medial spheres");
  const PointKdTree kd(pts);
  std::vector<Eigen::Vector3d> inward(pts.size());
  for (size_t i = 0; i < inward.size(); ++i) {
    const Eigen::Vector3d& n = grid.normals[grid_index(i)];
    inward[i] = sum.inverted ? n : Eigen::Vector3d(-n);
  }
  // Seeds: mesh vertices first (corners and rims, where medial balls are
  // small and random points rarely land), up to a share of the budget, then
  // random grid points.
  std::vector<int> seeds;
  {
    std::vector<int> verts, others;
    for (size_t i = 0; i < pts.size(); ++i)
      if (inward[i].squaredNorm() > 0)
        (grid.vertex_of[grid_index(i)] >= 0 ? verts : others).push_back(static_cast<int>(i));
    RandomStream rng(options.seed, kSeedStream, 0);
    auto take_random = [&](std::vector<int>& from, size_t n) {
      n = std::min(n, from.size());
      for (size_t i = 0; i < n; ++i)
        std::swap(from[i], from[std::min(from.size() - 1, i + static_cast<size_t>(rng.Uniform() * (from.size() - i)))]);
      seeds.insert(seeds.end(), from.begin(), from.begin() + n);
      from.erase(from.begin(), from.begin() + n);
    };
    take_random(verts, options.medial_spheres / kVertexSeedShare);
    take_random(others, options.medial_spheres - seeds.size());
    // A grid that is all vertices (a fine mesh) has no other points to give.
    take_random(verts, options.medial_spheres - seeds.size());
  }
  // A ball tangent at p cannot reach past the first wall along the inward
  // normal: half that distance starts the shrinking near its end.
  std::vector<double> start_radius(seeds.size(), diag);
  {
    RayCaster walls;
    walls.AddMesh(mesh);
    walls.Commit();
#pragma omp parallel for schedule(dynamic, 256)
    for (long s = 0; s < static_cast<long>(seeds.size()); ++s) {
      const auto hit = walls.Intersect(pts[seeds[s]], inward[seeds[s]], kWallRayStart * diag);
      if (hit) start_radius[s] = std::min(diag, 0.5 * hit->t);
    }
  }
  std::vector<Candidate> cands = DistinctCandidates(
      ShrinkingBallSpheres(kd, inward, seeds, start_radius, kMinMedialRadius * diag, kTouchTolerance * spacing),
      kDuplicateCell * spacing);
  sum.medial_spheres = static_cast<int>(cands.size());

  // The leaf cover: the smallest common stand-off at which at most max_leaves
  // grown candidates cover every point (Expand).
  Report(progress, 0.3, "leaf cover");
  size_t max_leaves = 1;
  for (int l = 1; l < options.levels; ++l) max_leaves *= options.branching;
  const int n_points = static_cast<int>(pts.size());
  std::vector<StandoffList> lists;
  std::vector<int> picks, trial;
  double cap = spacing;
  bool covered = false;
  while (!cands.empty() && cap <= 2 * diag) {
    if (!BuildLists(kd, cands, cap, &lists)) {
      if (cands.size() <= 2 * max_leaves) break;  // nothing sensible to drop: fall back below
      std::vector<Candidate> half;
      for (size_t i = 0; i < cands.size(); i += 2) half.push_back(cands[i]);
      cands = std::move(half);
      continue;
    }
    if (GreedyCover(lists, n_points, static_cast<float>(cap), static_cast<int>(max_leaves), &picks)) {
      covered = true;
      break;
    }
    cap *= 2;
  }
  std::vector<Candidate> chosen;
  std::vector<std::vector<int>> near_picks(pts.size());
  if (covered) {
    double lo_d = 0, hi_d = cap;
    if (GreedyCover(lists, n_points, 0.0f, static_cast<int>(max_leaves), &trial)) picks = trial, hi_d = 0;
    for (int it = 0; it < kStandoffBisections && hi_d > 0; ++it) {
      const double mid = 0.5 * (lo_d + hi_d);
      if (GreedyCover(lists, n_points, static_cast<float>(mid), static_cast<int>(max_leaves), &trial)) {
        hi_d = mid;
        picks = trial;
      } else {
        lo_d = mid;
      }
    }
    sum.leaf_standoff = hi_d / diag;
    // Every point lies on the list of a pick that covers it; those are the
    // leaves it may go to.
    for (size_t j = 0; j < picks.size(); ++j) {
      chosen.push_back(cands[picks[j]]);
      for (const auto& [e, p] : lists[picks[j]]) near_picks[p].push_back(static_cast<int>(j));
    }
  } else {
    chosen = FallbackCentres(pts, static_cast<int>(max_leaves));
    std::vector<Eigen::Vector3d> centres;
    for (const auto& c : chosen) centres.push_back(c.centre);
    const PointKdTree by_centre(centres);
#pragma omp parallel for schedule(dynamic, 1024)
    for (long p = 0; p < static_cast<long>(pts.size()); ++p) near_picks[p] = by_centre.KNearest(pts[p], kFallbackNear);
  }
  lists.clear();
  lists.shrink_to_fit();
  if (thinned) {
    // Every grid point may go where its nearest cover point may.
    std::vector<std::vector<int>> near_all(all.size());
#pragma omp parallel for schedule(dynamic, 4096)
    for (long p = 0; p < static_cast<long>(all.size()); ++p) near_all[p] = near_picks[kd.Nearest(all[p])];
    near_picks = std::move(near_all);
  }

  Report(progress, 0.8, "covering the surface");
  std::vector<int> owner;
  std::vector<Sphere> leaves = AssignAndShrink(all, chosen, near_picks, &owner);
  sum.leaf_growth = CoverMicroTriangles(grid, owner, near_picks, &leaves) / diag;
  // A leaf holding one point at its centre has radius 0, which reads as an
  // empty slot; it stands for a bit of surface.
  std::vector<int> held(leaves.size(), 0), used;
  for (int o : owner) ++held[o];
  for (size_t j = 0; j < leaves.size(); ++j) {
    if (!held[j] && leaves[j].empty()) continue;  // a pick left without points
    if (leaves[j].empty()) leaves[j].radius = 0.5 * spacing;
    used.push_back(static_cast<int>(j));
  }
  sum.leaves = static_cast<int>(used.size());

  SphereTree tree;
  tree.levels = options.levels;
  tree.branching = options.branching;
  tree.nodes.assign(SphereTree::NodeCount(options.levels, options.branching), Sphere{});
  PlaceLeaves(&tree, 0, 0, used, leaves);
  // Inner nodes enclose their children, from the leaves up.
  for (size_t i = tree.LevelBegin(tree.levels - 1); i-- > 0;) {
    std::vector<Sphere> kids;
    for (int k = 0; k < tree.branching; ++k)
      if (!tree.nodes[tree.FirstChild(i) + k].empty()) kids.push_back(tree.nodes[tree.FirstChild(i) + k]);
    if (!kids.empty()) tree.nodes[i] = EnclosingSphere(kids, kInnerSphereIterations);
  }

  sum.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  Report(progress, 1.0, std::to_string(sum.leaves) + " leaves");
  if (summary) *summary = sum;
  return tree;
}

}  // namespace shadowsg
