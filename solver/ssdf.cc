#include "solver/ssdf.h"

#include <omp.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <new>
#include <numeric>

#include "calib/error.h"
#include "solver/enclosing_sphere.h"

// The search's kernels below are also compiled for x86-64-v3 (AVX2 with FMA)
// and chosen at load time (GCC function multiversioning) in a build for plain
// x86-64 (SHADOWSG_AVX2 off). One clone for the level, not "avx2,fma", which
// made two clones, AVX2 without FMA and FMA without AVX2. A build for
// x86-64-v3 has no clones: they would all be the same code behind an
// indirect call.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !(defined(__AVX2__) && defined(__FMA__))
#define SHADOWSG_KERNEL_CLONES __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define SHADOWSG_KERNEL_CLONES
#endif

namespace shadowsg {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr float kInfF = std::numeric_limits<float>::infinity();
constexpr double kPi = 3.14159265358979323846;
constexpr float kPiF = static_cast<float>(kPi);
constexpr float kHalfPiF = static_cast<float>(kPi / 2);

// Steps of the enclosing-sphere walk for a subtree whose own sphere does not
// enclose its children: trades tightness (~1/sqrt(n)) for time, per tree.
constexpr int kEnclosingIterations = 32;
// A node counts as enclosing its children when it misses by no more than
// rounding (a transformed tree); its bound is recomputed exactly anyway.
constexpr double kEnclosesTolerance = 1e-9;

// A float cone table is evaluated with float rounding (~1e-7 rad per term); a
// subtree is skipped only when its bound beats the best by more than this, so
// rounding in the bound never hides the true minimum.
constexpr float kBoundSlackF = 4e-6f;
// How far above the cap a hint's floor must stay for PointAngles to skip the
// search: well above float rounding of theta.
constexpr float kHintMargin = 1e-4f;

// Added to a cap computed in float (angles good to ~1e-7 rad) so that it
// certainly contains its children's caps.
constexpr float kCapSlack = 2e-6f;

// Marks a bounding sphere that contains x: its cone is no bound at all, and
// any value below the smallest possible leaf theta (-pi/2) forces a descent.
constexpr double kContainsPoint = -10.0;

// ---------------------------------------------------------------- double path

// Angle between s (any length) and the unit axis mu, stable near 0 and pi.
double AxisAngle(const Eigen::Vector3d& s, const Eigen::Vector3d& mu) {
  const double d = s.norm();
  if (d == 0) return std::acos(std::clamp(mu.z(), -1.0, 1.0));  // x at the centre: seen along +z (header)
  return std::atan2(s.cross(mu).norm(), s.dot(mu));
}

double LeafTheta(const Sphere& sp, const Eigen::Vector3d& x, const Eigen::Vector3d& mu) {
  if (sp.empty()) return kInf;
  const Eigen::Vector3d s = sp.centre - x;
  const double d = s.norm();
  const double half = d <= sp.radius ? kPi / 2 : std::asin(sp.radius / d);
  return AxisAngle(s, mu) - half;
}

// Lower bound of every leaf theta below a node whose leaves `bound` encloses:
// the cone of an enclosed sphere lies inside the cone of the enclosing one,
// and a signed angular distance can only shrink when its set grows. When x is
// inside `bound` there is no cone, hence no bound.
double BoundTheta(const Sphere& bound, const Eigen::Vector3d& x, const Eigen::Vector3d& mu) {
  if (bound.empty()) return kInf;
  const Eigen::Vector3d s = bound.centre - x;
  const double d = s.norm();
  if (d <= bound.radius) return kContainsPoint;
  return AxisAngle(s, mu) - std::asin(bound.radius / d);
}

bool TreeUsable(const SphereTree& t) {
  return t.levels >= 1 && t.branching >= 1 && t.nodes.size() == SphereTree::NodeCount(t.levels, t.branching);
}

void CheckTrees(const std::vector<SphereTree>& trees) {
  for (const auto& t : trees) SHADOWSG_CHECK(t.nodes.empty() || TreeUsable(t));
}

void ExactSearch(const SphereTree& tree, const std::vector<Sphere>& bounds, size_t node, int level,
                 const Eigen::Vector3d& x, const Eigen::Vector3d& mu, double* best) {
  const int B = tree.branching;
  const size_t first = tree.FirstChild(node);
  if (level + 1 == tree.levels - 1) {
    for (int k = 0; k < B; ++k) *best = std::min(*best, LeafTheta(tree.nodes[first + k], x, mu));
    return;
  }
  std::vector<std::pair<double, size_t>> kids;
  kids.reserve(B);
  for (int k = 0; k < B; ++k) {
    const double v = BoundTheta(bounds[first + k], x, mu);
    if (v < *best) kids.emplace_back(v, first + k);
  }
  std::sort(kids.begin(), kids.end());
  for (const auto& [v, child] : kids) {
    if (v >= *best) break;
    ExactSearch(tree, bounds, child, level + 1, x, mu, best);
  }
}

double ExactTree(const SphereTree& tree, const Eigen::Vector3d& x, const Eigen::Vector3d& mu, double best) {
  if (tree.nodes.empty()) return best;
  if (tree.levels == 1) return std::min(best, LeafTheta(tree.nodes[0], x, mu));
  const std::vector<Sphere> bounds = SubtreeBounds(tree);
  if (BoundTheta(bounds[0], x, mu) < best) ExactSearch(tree, bounds, 0, 0, x, mu, &best);
  return best;
}

// The reference descent on one tree, with the nodes' own spheres.
double CoarseToFineTree(const SphereTree& tree, const Eigen::Vector3d& x, const Eigen::Vector3d& mu) {
  if (tree.nodes.empty()) return kInf;
  if (tree.levels == 1) return LeafTheta(tree.nodes[0], x, mu);
  const int B = tree.branching;
  std::vector<size_t> frontier = {0};
  std::vector<std::pair<double, size_t>> scored;
  for (int level = 1; level < tree.levels; ++level) {
    scored.clear();
    for (size_t parent : frontier)
      for (int k = 0; k < B; ++k) {
        const size_t c = tree.FirstChild(parent) + k;
        const double v = LeafTheta(tree.nodes[c], x, mu);
        if (v < kInf) scored.emplace_back(v, c);
      }
    if (scored.empty()) return kInf;
    if (level == tree.levels - 1) return std::min_element(scored.begin(), scored.end())->first;
    const size_t keep = std::min<size_t>(kCoarseToFineKeep, scored.size());
    std::partial_sort(scored.begin(), scored.begin() + keep, scored.end());
    frontier.clear();
    for (size_t i = 0; i < keep; ++i) frontier.push_back(scored[i].second);
  }
  return kInf;
}

// ----------------------------------------------------------------- float path

// asin on [0, 1] in float after Cephes asinf (S. Moshier): relative error about
// 1 ulp. `half_complement` = (1 - x) / 2, passed separately so callers that
// know it more precisely than 1 - x in float (x near 1) keep that precision.
inline float AsinUnit(float x, float half_complement) {
  const bool big = x > 0.5f;
  const float root = std::sqrt(half_complement);  // both branches computed: keeps the loop branch-free
  const float z = big ? half_complement : x * x;
  const float s = big ? root : x;
  const float p =
      ((((4.2163199048e-2f * z + 2.4181311049e-2f) * z + 4.5470025998e-2f) * z + 7.4953002686e-2f) * z +
       1.6666752422e-1f) *
          z * s +
      s;
  return big ? kHalfPiF - 2 * p : p;
}

// Storage aligned to `kAlign` bytes (a std::vector allocator).
template <typename T, size_t kAlign>
struct AlignedAllocator {
  using value_type = T;
  template <typename U>
  struct rebind {
    using other = AlignedAllocator<U, kAlign>;
  };
  AlignedAllocator() = default;
  template <typename U>
  AlignedAllocator(const AlignedAllocator<U, kAlign>&) {}
  T* allocate(size_t n) { return static_cast<T*>(::operator new(n * sizeof(T), std::align_val_t(kAlign))); }
  void deallocate(T* p, size_t) { ::operator delete(p, std::align_val_t(kAlign)); }
  template <typename U>
  bool operator==(const AlignedAllocator<U, kAlign>&) const { return true; }
  template <typename U>
  bool operator!=(const AlignedAllocator<U, kAlign>&) const { return false; }
};

// The per-point cone table of every node of every tree: unit direction u to
// the centre and half-angle alpha, so that theta = angle(u, mu) - alpha.
// Empty: alpha = -inf (theta = +inf).
//
// Nodes are stored in blocks of kLanes: block b holds the ux of nodes
// [kLanes b, kLanes b + kLanes), then their uy, uz and alpha, in 128 bytes
// (two cache lines, which the adjacent-line prefetcher fetches together).
// Flatten places every tree so that each sibling group of branching 8
// starts a block: a node's expansion reads one block, and a single node's
// four values share it. With one array per value (the former layout) each
// read touched four lines; the tables of a fit set (~56 MB for 6000 points)
// do not fit in cache, and those misses were the search's largest cost.
// The block layout, shared by ConeTable and SphereBlocks: four values a node,
// kLanes nodes a block, each value's lanes side by side.
constexpr size_t kLanes = 8;
// Start of node i's block, and the index of its value v (0-3).
constexpr size_t BlockStart(size_t i) { return (i / kLanes) * 4 * kLanes; }
constexpr size_t BlockAt(size_t i, int v) { return BlockStart(i) + v * kLanes + i % kLanes; }

struct ConeTable {
  static constexpr size_t kLanes = shadowsg::kLanes;
  std::vector<float, AlignedAllocator<float, 128>> data;
  void Resize(size_t n) { data.assign((n + kLanes - 1) / kLanes * 4 * kLanes, 0.0f); }
  // Index of value `v` (0: ux, 1: uy, 2: uz, 3: alpha) of node i.
  static size_t At(size_t i, int v) { return BlockAt(i, v); }
  float ux(size_t i) const { return data[At(i, 0)]; }
  float uy(size_t i) const { return data[At(i, 1)]; }
  float uz(size_t i) const { return data[At(i, 2)]; }
  float alpha(size_t i) const { return data[At(i, 3)]; }
  float& alpha(size_t i) { return data[At(i, 3)]; }
  void Set(size_t i, const Eigen::Vector3f& u, float a) {
    data[At(i, 0)] = u.x();
    data[At(i, 1)] = u.y();
    data[At(i, 2)] = u.z();
    data[At(i, 3)] = a;
  }
};

struct FlatTree {
  int levels = 0, branching = 0;
  size_t inner = 0;       // table index of the root (inner nodes, in the tree's order); unused when levels == 1
  size_t leaf_begin = 0;  // local index of the first leaf
  size_t leaves = 0;      // index of the first leaf in FlatTrees::leaves
  // Local index l to table index (inner nodes) or leaf index (l >= leaf_begin).
  size_t Inner(size_t l) const { return inner + l; }
  size_t Leaf(size_t l) const { return leaves + (l - leaf_begin); }
};

// Spheres shared by every point (the inner nodes', the leaves'), in blocks
// of kLanes as a ConeTable's (centre x, y, z, radius; double, so that a cone
// computed from them is as precise as a table's). Radius 0: an empty slot.
struct SphereBlocks {
  static constexpr size_t kLanes = shadowsg::kLanes;
  std::vector<double, AlignedAllocator<double, 64>> data;
  size_t count = 0;
  static size_t At(size_t i, int v) { return BlockAt(i, v); }
  static size_t Block(size_t i) { return BlockStart(i); }
  void Push(const Eigen::Vector3d& c, double r) {
    if (count % kLanes == 0) data.resize(data.size() + 4 * kLanes, 0.0);
    data[At(count, 0)] = c.x();
    data[At(count, 1)] = c.y();
    data[At(count, 2)] = c.z();
    data[At(count, 3)] = r;
    ++count;
  }
};

// The trees flattened. Inner nodes (levels above the last) get a cone per
// point in a ConeTable: for kExact the subtree bounds, for kCoarseToFine the
// nodes' own spheres. Leaves (the last level, the occluders themselves) are
// not kept in the points' tables: their cones are computed from SphereBlocks
// where a search reaches them, or for one point at a time into a leaf table
// where a call searches many axes (FillLeafTable). They are seven eighths of
// a tree's nodes, and a kept table of every node (9.4 KB a point, 56 MB for
// 6000 fit pixels) did not fit in cache; the search waited on memory more
// than it computed.
struct FlatTrees {
  std::vector<FlatTree> trees;
  SphereBlocks inner;   // inner nodes, table-indexed (radius 0: empty, also the alignment slots)
  SphereBlocks leaves;
  // kExact: inner nodes are subtree bounds, and a point inside one has no
  // bound from it; kCoarseToFine: they are the nodes' own spheres, and a
  // point inside one gets the leaf rule.
  bool exact = false;
};

FlatTrees Flatten(const std::vector<SphereTree>& world_trees, SsdfSearch search) {
  FlatTrees f;
  for (const auto& t : world_trees) {
    if (t.nodes.empty()) continue;
    // Empty slots before the root and the first leaf, so that with branching
    // 8 every sibling group starts a block (of the table, of the leaves): the
    // root's children (table index root + 1) and the first leaf group.
    auto pad = [](size_t size, size_t first) { return (kLanes - (size + first) % kLanes) % kLanes; };
    for (size_t k = pad(f.inner.count, 1); k > 0; --k) f.inner.Push(Eigen::Vector3d::Zero(), 0.0);
    const size_t leaf_begin = t.LevelBegin(t.levels - 1);
    for (size_t k = pad(f.leaves.count, 0); k > 0; --k) f.leaves.Push(Eigen::Vector3d::Zero(), 0.0);
    FlatTree ft{t.levels, t.branching, f.inner.count, leaf_begin, f.leaves.count};
    const std::vector<Sphere> spheres = search == SsdfSearch::kExact ? SubtreeBounds(t) : t.nodes;
    for (size_t i = 0; i < spheres.size(); ++i) {
      const double r = spheres[i].empty() ? 0.0 : spheres[i].radius;
      if (i >= leaf_begin) {
        f.leaves.Push(spheres[i].centre, r);
        continue;
      }
      f.inner.Push(spheres[i].centre, r);
    }
    f.trees.push_back(ft);
  }
  f.exact = search == SsdfSearch::kExact;
  return f;
}

// Angle between unit vectors in float, 2 asin(|u - v| / 2) (precise near 0 and pi).
inline float UnitAngle(float ux, float uy, float uz, float vx, float vy, float vz) {
  const float dot = ux * vx + uy * vy + uz * vz;
  const float sgn = dot >= 0 ? -1.0f : 1.0f;
  const float wx = ux + sgn * vx, wy = uy + sgn * vy, wz = uz + sgn * vz;
  const float h = 0.5f * std::sqrt(wx * wx + wy * wy + wz * wz);
  const float a = 2 * AsinUnit(h, 0.5f * (1 - h));
  return dot >= 0 ? a : kPiF - a;
}

// A leaf's cone seen from x: unit direction to the centre and half-angle
// (pi/2 when x is inside, the direction +z when x is the centre, -inf when
// empty). Branch-free, for the vectorised search kernel.
struct Cone {
  float ux, uy, uz, alpha;
};
inline Cone LeafCone(const double* block, size_t lane, double px, double py, double pz) {
  constexpr size_t L = SphereBlocks::kLanes;
  const double sx = block[lane] - px, sy = block[L + lane] - py, sz = block[2 * L + lane] - pz;
  const double r = block[3 * L + lane];
  const double d = std::sqrt(sx * sx + sy * sy + sz * sz);
  const double inv = d > 0 ? 1 / d : 0.0;
  const float inside_alpha = kHalfPiF;
  const float outside_alpha = AsinUnit(static_cast<float>(r * inv), static_cast<float>(0.5 * (d - r) * inv));
  Cone c;
  c.ux = static_cast<float>(sx * inv);
  c.uy = static_cast<float>(sy * inv);
  c.uz = d > 0 ? static_cast<float>(sz * inv) : 1.0f;
  c.alpha = r <= 0 ? -kInfF : d <= r ? inside_alpha : outside_alpha;
  return c;
}
inline Cone LeafConeAt(const SphereBlocks& l, size_t i, const double* x) {
  return LeafCone(l.data.data() + SphereBlocks::Block(i), i % SphereBlocks::kLanes, x[0], x[1], x[2]);
}

// The cones of the block of leaves starting at `begin` (a multiple of kLanes)
// seen from x, written as a ConeTable block (kLanes each of ux, uy, uz,
// alpha): the same arithmetic as LeafConeAt, lane by lane.
SHADOWSG_KERNEL_CLONES
void LeafConeBlock(const SphereBlocks& l, size_t begin, const double* x, float* cones) {
  constexpr size_t L = SphereBlocks::kLanes;
  const double* block = l.data.data() + SphereBlocks::Block(begin);
  const double px = x[0], py = x[1], pz = x[2];
#pragma omp simd
  for (size_t j = 0; j < L; ++j) {
    const Cone c = LeafCone(block, j, px, py, pz);
    cones[j] = c.ux;
    cones[L + j] = c.uy;
    cones[2 * L + j] = c.uz;
    cones[3 * L + j] = c.alpha;
  }
}

// The cones of the block of inner nodes starting at `begin` (a multiple of
// kLanes) seen from x, as LeafConeBlock writes a leaf block's, except that a
// point inside a sphere gets inside_alpha about the direction to its centre
// (+z at the centre) and an empty slot the direction 0. The direction is
// s / d here and s * (1 / d) in LeafCone: each keeps the rounding its tables
// always had (the fit's lobes follow the last bits of the bounds).
SHADOWSG_KERNEL_CLONES
void InnerConeBlock(const SphereBlocks& spheres, size_t begin, const double* x, float inside_alpha, float* cones) {
  constexpr size_t L = SphereBlocks::kLanes;
  const double* block = spheres.data.data() + SphereBlocks::Block(begin);
  const double px = x[0], py = x[1], pz = x[2];
#pragma omp simd
  for (size_t j = 0; j < L; ++j) {
    const double sx = block[j] - px, sy = block[L + j] - py, sz = block[2 * L + j] - pz;
    const double r = block[3 * L + j];
    const double d = std::sqrt(sx * sx + sy * sy + sz * sz);
    const bool empty = r <= 0, at_centre = !(d > 0), inside = d <= r;
    const double q = at_centre ? 1.0 : d;
    cones[j] = empty || at_centre ? 0.0f : static_cast<float>(sx / q);
    cones[L + j] = empty || at_centre ? 0.0f : static_cast<float>(sy / q);
    cones[2 * L + j] = empty ? 0.0f : at_centre ? 1.0f : static_cast<float>(sz / q);
    const float outside = AsinUnit(static_cast<float>(r / q), static_cast<float>(0.5 * (d - r) / q));
    cones[3 * L + j] = empty ? -kInfF : inside ? inside_alpha : outside;
  }
}

// For a block of cones (as LeafConeBlock writes them), each cone's angle from
// the unit direction u plus its half-angle: the term of TightenBounds' cap,
// the same arithmetic as UnitAngle, lane by lane.
SHADOWSG_KERNEL_CLONES
void ConeCapTerms(const float* cones, float ux, float uy, float uz, float* term) {
  constexpr size_t L = ConeTable::kLanes;
#pragma omp simd
  for (size_t j = 0; j < L; ++j)
    term[j] = UnitAngle(ux, uy, uz, cones[j], cones[L + j], cones[2 * L + j]) + cones[3 * L + j];
}

// Seen from one point, the cones of a node's children lie inside the cap
// around the node's direction u of half-angle max_k(angle(u, u_k) + alpha_k),
// so that cap bounds the subtree too; it is often much narrower than the
// cone of the enclosing sphere (for points near the object always), and it
// is a bound even when the point is inside that sphere. Bottom-up, so each
// level uses the tightened caps of the one below.
void TightenBounds(const FlatTrees& f, const double* x, const ConeTable* leaf_table, ConeTable* t) {
  for (const FlatTree& tr : f.trees) {
    for (size_t local = tr.leaf_begin; local-- > 0;) {
      const size_t i = tr.Inner(local);
      if (!(t->alpha(i) > -kInfF)) continue;  // empty subtree
      const size_t first = local * tr.branching + 1;
      float cap = 0;
      if (first >= tr.leaf_begin && tr.branching == static_cast<int>(SphereBlocks::kLanes) &&
          tr.Leaf(first) % SphereBlocks::kLanes == 0) {
        // A whole block of leaves (seven eighths of the children a point's
        // table visits): their cones at once, or the leaf table's block.
        constexpr size_t L = SphereBlocks::kLanes;
        alignas(32) float block[4 * L];
        const float* cones = block;
        if (leaf_table) cones = leaf_table->data.data() + ConeTable::At(tr.Leaf(first), 0);
        else LeafConeBlock(f.leaves, tr.Leaf(first), x, block);
        float term[L];
        ConeCapTerms(cones, t->ux(i), t->uy(i), t->uz(i), term);
        for (size_t k = 0; k < L; ++k)
          if (cones[3 * L + k] > -kInfF) cap = std::max(cap, term[k]);
      } else {
        for (int k = 0; k < tr.branching; ++k) {
          const size_t c = first + k;
          const ConeTable* from = c >= tr.leaf_begin ? leaf_table : t;
          const size_t at = c >= tr.leaf_begin ? tr.Leaf(c) : tr.Inner(c);
          const Cone child = from ? Cone{from->ux(at), from->uy(at), from->uz(at), from->alpha(at)}
                                  : LeafConeAt(f.leaves, at, x);
          if (!(child.alpha > -kInfF)) continue;
          cap = std::max(cap, UnitAngle(t->ux(i), t->uy(i), t->uz(i), child.ux, child.uy, child.uz) + child.alpha);
        }
      }
      t->alpha(i) = std::min(t->alpha(i), cap + kCapSlack);
    }
  }
}

// Every leaf's cone seen from x (the blocks' padding lanes get empty cones).
void FillLeafTable(const FlatTrees& f, const double* x, ConeTable* leaf_table) {
  for (size_t b = 0; b < f.leaves.count; b += SphereBlocks::kLanes)
    LeafConeBlock(f.leaves, b, x, leaf_table->data.data() + ConeTable::At(b, 0));
}

// The point's cones of the inner nodes and, with leaf_table, of the leaves.
// tighten (kExact): TightenBounds; without, the inner nodes' cones are their
// subtrees' enclosing spheres'.
void FillConeTable(const FlatTrees& f, const Eigen::Vector3d& x, ConeTable* t, ConeTable* leaf_table = nullptr,
                   bool tighten = true) {
  if (leaf_table) FillLeafTable(f, x.data(), leaf_table);
  // A point inside a subtree bound has no bound from it (kExact): +10 rad
  // forces the descent; inside a node's own sphere (kCoarseToFine) the leaf rule.
  const float inside_alpha = f.exact ? static_cast<float>(-kContainsPoint) : kHalfPiF;
  for (size_t b = 0; b < f.inner.count; b += SphereBlocks::kLanes)
    InnerConeBlock(f.inner, b, x.data(), inside_alpha, t->data.data() + ConeTable::At(b, 0));
  if (f.exact && tighten) TightenBounds(f, x.data(), leaf_table, t);
}

// theta = angle(u, m) - alpha for unit u and m. The angle is 2 asin(|u - m| / 2)
// (or pi minus that for u + m), which keeps float precision near 0 and pi
// where acos(u . m) would not.
inline float ConeThetaOf(float ux, float uy, float uz, float alpha, float mx, float my, float mz) {
  const float dot = ux * mx + uy * my + uz * mz;
  const float sgn = dot >= 0 ? -1.0f : 1.0f;
  const float vx = ux + sgn * mx, vy = uy + sgn * my, vz = uz + sgn * mz;
  const float h = 0.5f * std::sqrt(vx * vx + vy * vy + vz * vz);  // sin of half the angle, <= 0.7072
  const float a = 2 * AsinUnit(h, 0.5f * (1 - h));
  return (dot >= 0 ? a : kPiF - a) - alpha;
}
inline float ConeThetaOf(const Cone& c, float mx, float my, float mz) {
  return ConeThetaOf(c.ux, c.uy, c.uz, c.alpha, mx, my, mz);
}

// theta of table nodes [begin, begin + n) for the unit axis m.
template <int kFixed>
inline void ConeThetasN(const ConeTable& t, size_t begin, int n_runtime, float mx, float my, float mz, float* out) {
  const int n = kFixed > 0 ? kFixed : n_runtime;
  // kFixed == kLanes: one whole block (the caller checks); otherwise node by
  // node, a block's values kLanes apart.
  const float* block = t.data.data() + ConeTable::At(begin, 0);
  const float* ux = block;
  const float* uy = block + ConeTable::kLanes;
  const float* uz = block + 2 * ConeTable::kLanes;
  const float* al = block + 3 * ConeTable::kLanes;
  if (kFixed == 0 && (begin % ConeTable::kLanes + n > ConeTable::kLanes)) {
    for (int j = 0; j < n; ++j) ConeThetasN<1>(t, begin + j, 1, mx, my, mz, out + j);
    return;
  }
#pragma omp simd
  for (int j = 0; j < n; ++j) out[j] = ConeThetaOf(ux[j], uy[j], uz[j], al[j], mx, my, mz);
}

// theta of leaves [begin, begin + n) seen from x, for the unit axis m.
template <int kFixed>
inline void LeafThetasN(const SphereBlocks& l, size_t begin, int n_runtime, const double* x, float mx, float my,
                        float mz, float* out) {
  const int n = kFixed > 0 ? kFixed : n_runtime;
  if (kFixed == 0 && (begin % SphereBlocks::kLanes + n > SphereBlocks::kLanes)) {
    for (int j = 0; j < n; ++j) LeafThetasN<1>(l, begin + j, 1, x, mx, my, mz, out + j);
    return;
  }
  const double* block = l.data.data() + SphereBlocks::Block(begin);
  const size_t lane0 = begin % SphereBlocks::kLanes;
  const double px = x[0], py = x[1], pz = x[2];
#pragma omp simd
  for (int j = 0; j < n; ++j) {
    const Cone c = LeafCone(block, lane0 + j, px, py, pz);
    out[j] = ConeThetaOf(c, mx, my, mz);
  }
}

// The search's kernels (SHADOWSG_KERNEL_CLONES: in a plain x86-64 build the
// clones measured 1.2x on the whole search). Branching 8, the project's and
// the reference's, gets a fixed-width loop.
SHADOWSG_KERNEL_CLONES
void ConeThetas(const ConeTable& t, size_t begin, int n, float mx, float my, float mz, float* out) {
  if (n == static_cast<int>(ConeTable::kLanes) && begin % ConeTable::kLanes == 0)
    ConeThetasN<ConeTable::kLanes>(t, begin, n, mx, my, mz, out);
  else
    ConeThetasN<0>(t, begin, n, mx, my, mz, out);
}

SHADOWSG_KERNEL_CLONES
void LeafThetas(const SphereBlocks& l, size_t begin, int n, const double* x, float mx, float my, float mz, float* out) {
  if (n == static_cast<int>(SphereBlocks::kLanes) && begin % SphereBlocks::kLanes == 0)
    LeafThetasN<SphereBlocks::kLanes>(l, begin, n, x, mx, my, mz, out);
  else
    LeafThetasN<0>(l, begin, n, x, mx, my, mz, out);
}

inline float ConeTheta(const ConeTable& t, size_t i, float mx, float my, float mz) {
  return ConeThetaOf(t.ux(i), t.uy(i), t.uz(i), t.alpha(i), mx, my, mz);
}

inline float LeafTheta(const SphereBlocks& l, size_t i, const double* x, float mx, float my, float mz) {
  return ConeThetaOf(LeafConeAt(l, i, x), mx, my, mz);
}

// What one point's searches read: the trees, the point's table of inner
// cones, and the point itself for the leaves' cones, or a table of those
// (leaf_table, indexed as FlatTrees::leaves): a caller that searches many
// axes from one point at once reads them from cache; a fit's prepared points,
// each searched for a few axes per call, compute them (FlatTrees).
struct SearchPoint {
  const FlatTrees& flat;
  const ConeTable& table;
  const double* x;
  const ConeTable* leaf_table = nullptr;

  void Leaves(size_t begin, int n, float mx, float my, float mz, float* out) const {
    if (leaf_table) ConeThetas(*leaf_table, begin, n, mx, my, mz, out);
    else LeafThetas(flat.leaves, begin, n, x, mx, my, mz, out);
  }
  float Leaf(size_t i, float mx, float my, float mz) const {
    return leaf_table ? ConeTheta(*leaf_table, i, mx, my, mz) : LeafTheta(flat.leaves, i, x, mx, my, mz);
  }
  Cone LeafCone(size_t i) const {
    if (leaf_table) return {leaf_table->ux(i), leaf_table->uy(i), leaf_table->uz(i), leaf_table->alpha(i)};
    return LeafConeAt(flat.leaves, i, x);
  }
};

struct StackEntry {
  float bound;
  int level;
  size_t node;  // local index in the tree
};

constexpr size_t kNoneLeaf = std::numeric_limits<size_t>::max();

// SignedAnglesWithWitness tightens a point's table for at least kTightenAxes
// axes whose cap is at least kWideCap (rad) or absent; OccluderCones::Search
// tables a point's leaf cones for at least kTightenAxes axes.
constexpr int kTightenAxes = 24;
constexpr float kWideCap = 0.5f;

// Best-first depth-first branch-and-bound over one tree; updates *best and
// *best_leaf (leaf index, kNoneLeaf: none yet), lowers *floor to a lower
// bound on the theta of every leaf other than *best_leaf that the search did
// not beat *best with (pruned subtrees' bounds, leaves' own values), and
// *displaced to the lowest value of a leaf that was *best_leaf and lost it:
// min(floor, displaced) bounds every leaf but the final one. The stack holds
// at most B entries per level. Once *best is at or below `stop` the search
// ends there (floor and displaced are then no bounds).
void ExactTreeF(const SearchPoint& sp, const FlatTree& tr, float mx, float my, float mz, float stop,
                std::vector<StackEntry>* stack, float* best_out, size_t* best_leaf_out, float* floor_out,
                float* displaced_out) {
  // Locals, written back once: through the pointers every update of the
  // floor was a store the next iteration had to load (measured: the search's
  // hottest instructions).
  float best = *best_out, floor = *floor_out, displaced = *displaced_out;
  size_t best_leaf = *best_leaf_out;
  auto offer = [&](float v, size_t leaf) {
    if (v < best) {
      if (best_leaf != kNoneLeaf) displaced = std::min(displaced, best);
      best = v, best_leaf = leaf;
    } else if (leaf != best_leaf) {
      floor = std::min(floor, v);
    }
  };
  auto store = [&] {
    *best_out = best;
    *best_leaf_out = best_leaf;
    *floor_out = floor;
    *displaced_out = displaced;
  };
  if (tr.levels == 1) {
    offer(sp.Leaf(tr.leaves, mx, my, mz), tr.leaves);
    store();
    return;
  }
  const int B = tr.branching;
  const int leaf_parent_level = tr.levels - 2;
  if (stack->size() < static_cast<size_t>(B * tr.levels)) stack->resize(B * tr.levels);
  StackEntry* st = stack->data();
  int top = 0;
  std::array<float, 64> vals;
  std::array<int, 64> order;
  const float root = ConeTheta(sp.table, tr.Inner(0), mx, my, mz);
  if (root - kBoundSlackF < best) st[top++] = {root, 0, 0};
  else floor = std::min(floor, root - kBoundSlackF);
  while (top > 0) {
    const StackEntry e = st[--top];
    if (e.bound - kBoundSlackF >= best) {
      floor = std::min(floor, e.bound - kBoundSlackF);
      continue;
    }
    const size_t first = e.node * B + 1;  // local
    if (e.level == leaf_parent_level) {
      const size_t leaf = tr.Leaf(first);
      sp.Leaves(leaf, B, mx, my, mz, vals.data());
      for (int k = 0; k < B; ++k) offer(vals[k], leaf + k);
      if (best <= stop) break;
      continue;
    }
    ConeThetas(sp.table, tr.Inner(first), B, mx, my, mz, vals.data());
    // Survivors in decreasing bound (insertion sort: at most B), so the most
    // promising child is on top of the stack.
    int m = 0;
    const float limit = best + kBoundSlackF;
    for (int k = 0; k < B; ++k) {
      const float v = vals[k];
      if (!(v < limit)) {
        floor = std::min(floor, v - kBoundSlackF);
        continue;
      }
      int pos = m++;
      while (pos > 0 && vals[order[pos - 1]] < v) {
        order[pos] = order[pos - 1];
        --pos;
      }
      order[pos] = k;
    }
    for (int k = 0; k < m; ++k) st[top++] = {vals[order[k]], e.level + 1, first + order[k]};
  }
  store();
}

// kCoarseToFine on one tree; *argmin gets the leaf index of the result when it
// is finite.
float CoarseToFineTreeF(const SearchPoint& sp, const FlatTree& tr, float mx, float my, float mz, size_t* argmin) {
  if (tr.levels == 1) {
    *argmin = tr.leaves;
    return sp.Leaf(tr.leaves, mx, my, mz);
  }
  const int B = tr.branching;
  std::array<size_t, kCoarseToFineKeep> frontier = {0};  // local indices
  int nf = 1;
  std::array<float, 64> vals;
  std::array<std::pair<float, size_t>, kCoarseToFineKeep + 1> keep;
  for (int level = 1; level < tr.levels; ++level) {
    const bool last = level == tr.levels - 1;
    int nk = 0;
    float level_min = kInfF;
    for (int p = 0; p < nf; ++p) {
      const size_t first = frontier[p] * B + 1;
      if (last) sp.Leaves(tr.Leaf(first), B, mx, my, mz, vals.data());
      else ConeThetas(sp.table, tr.Inner(first), B, mx, my, mz, vals.data());
      for (int k = 0; k < B; ++k) {
        const float v = vals[k];
        if (!(v < kInfF)) continue;
        if (v < level_min) {
          level_min = v;
          if (last) *argmin = tr.Leaf(first + k);
        }
        // Insertion into the sorted best-k list; ties keep the earlier node, as a stable sort would.
        int pos = nk;
        while (pos > 0 && keep[pos - 1].first > v) {
          keep[pos] = keep[pos - 1];
          --pos;
        }
        keep[pos] = {v, first + k};
        nk = std::min(nk + 1, kCoarseToFineKeep);
      }
    }
    if (nk == 0) return kInfF;
    if (last) return level_min;
    nf = nk;
    for (int i = 0; i < nk; ++i) frontier[i] = keep[i].second;
  }
  return kInfF;
}

// An order of the axes in which neighbours are close on the sphere (snake
// through latitude bands), so the previous axis's best leaf is a tight first
// bound for the next.
std::vector<int> CoherentAxisOrder(const std::vector<Eigen::Vector3f>& axes) {
  const int n = static_cast<int>(axes.size());
  const int bands = std::max(1, static_cast<int>(std::sqrt(n / 2.0)));
  std::vector<std::pair<double, int>> key(n);
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3f& a = axes[i];
    const int band = std::min(bands - 1, static_cast<int>((a.z() + 1) / 2 * bands));
    double phi = std::atan2(a.y(), a.x()) / (2 * kPi) + 0.5;  // [0, 1]
    if (band % 2) phi = 1 - phi;
    key[i] = {band + phi * 0.999, i};
  }
  std::sort(key.begin(), key.end());
  std::vector<int> order(n);
  for (int i = 0; i < n; ++i) order[i] = key[i].second;
  return order;
}

}  // namespace

std::vector<Sphere> SubtreeBounds(const SphereTree& tree) {
  SHADOWSG_CHECK(TreeUsable(tree));
  std::vector<Sphere> bounds(tree.nodes.size());
  const size_t leaf_begin = tree.LevelBegin(tree.levels - 1);
  for (size_t i = leaf_begin; i < tree.nodes.size(); ++i)
    if (!tree.nodes[i].empty()) bounds[i] = tree.nodes[i];
  std::vector<const Sphere*> kids;
  for (size_t i = leaf_begin; i-- > 0;) {
    kids.clear();
    for (int k = 0; k < tree.branching; ++k) {
      const Sphere& c = bounds[tree.FirstChild(i) + k];
      if (!c.empty()) kids.push_back(&c);
    }
    if (kids.empty()) continue;  // no leaf below: stays empty
    auto radius_about = [&](const Eigen::Vector3d& c) {
      double r = 0;
      for (const Sphere* s : kids) r = std::max(r, (s->centre - c).norm() + s->radius);
      return r;
    };
    if (kids.size() == 1) {
      bounds[i] = *kids[0];
      continue;
    }
    // A node that already encloses its children (every tree this project
    // builds, up to the rounding of a transform) is kept, shrunk to touch the
    // farthest child.
    const Sphere& own = tree.nodes[i];
    Sphere about_own{own.centre, kInf};
    if (!own.empty()) {
      about_own.radius = radius_about(own.centre);
      if (about_own.radius <= own.radius * (1 + kEnclosesTolerance)) {
        bounds[i] = about_own;
        continue;
      }
    }
    // Otherwise a sphere around the children's bounds.
    std::vector<Sphere> kid_spheres;
    for (const Sphere* s : kids) kid_spheres.push_back(*s);
    const Sphere walked = EnclosingSphere(kid_spheres, kEnclosingIterations);
    bounds[i] = walked.radius < about_own.radius ? walked : about_own;
  }
  return bounds;
}

double SignedAngleBruteForce(const std::vector<SphereTree>& world_trees, const Eigen::Vector3d& x,
                             const Eigen::Vector3d& mu_in) {
  CheckTrees(world_trees);
  const Eigen::Vector3d mu = mu_in.normalized();
  double best = kInf;
  for (const auto& t : world_trees) {
    if (t.nodes.empty()) continue;
    for (size_t i = t.LevelBegin(t.levels - 1); i < t.nodes.size(); ++i)
      best = std::min(best, LeafTheta(t.nodes[i], x, mu));
  }
  return best;
}

double SignedAngleToOccluders(const std::vector<SphereTree>& world_trees, const Eigen::Vector3d& x,
                              const Eigen::Vector3d& mu_in, SsdfSearch search) {
  CheckTrees(world_trees);
  const Eigen::Vector3d mu = mu_in.normalized();
  double best = kInf;
  for (const auto& t : world_trees)
    best = search == SsdfSearch::kExact ? ExactTree(t, x, mu, best) : std::min(best, CoarseToFineTree(t, x, mu));
  return best;
}

void SignedAngles(const std::vector<SphereTree>& world_trees, const std::vector<Eigen::Vector3d>& points,
                  const std::vector<Eigen::Vector3d>& axes, Eigen::MatrixXf* out, SsdfSearch search) {
  SignedAnglesWithWitness(world_trees, points, axes, out, nullptr, search, nullptr);
}

namespace {

// theta (and the witness direction) of every axis for one point's cone table.
// hint_leaf, hint_floor (optional, in and out, one per axis) and drift (the
// angle each axis moved since the hints were made): OccluderCones::AngleHints.
// sides: CapSides (kBoth: a leaf at or below minus the cap ends the search).
void PointAngles(const SearchPoint& sp, const std::vector<Eigen::Vector3f>& unit, const std::vector<int>& order,
                 SsdfSearch search, const std::vector<float>* caps, CapSides sides, std::vector<StackEntry>* stack,
                 float* out_row, long out_stride, Eigen::Vector3f* witness_row, uint32_t* hint_leaf = nullptr,
                 float* hint_floor = nullptr, float* hint_rival = nullptr, const float* drift = nullptr,
                 const float* known_row = nullptr) {
  const FlatTrees& flat = sp.flat;
  size_t warm = flat.trees[0].leaves;  // leaf indices from here on
  for (int a : order) {
    const float mx = unit[a].x(), my = unit[a].y(), mz = unit[a].z();
    float best;
    size_t argmin = warm;
    // The hinted and the warm leaf's cones, computed once for their theta
    // and, where one is the minimum, its direction.
    size_t hint_cone_leaf = kNoneLeaf, warm_cone_leaf = kNoneLeaf;
    Cone hint_cone{0, 0, 1, -kInfF}, warm_cone{0, 0, 1, -kInfF};
    if (search == SsdfSearch::kExact) {
      best = caps ? (*caps)[a] : kInfF;
      // Deep enough in some leaf's cone, theta need not be the minimum.
      const float stop = caps && sides == CapSides::kBoth ? -best : -kInfF;
      if (known_row) best = std::min(best, known_row[a * out_stride]);
      const uint32_t hinted = hint_leaf && hint_leaf[a] < flat.leaves.count ? hint_leaf[a] : OccluderCones::kNoLeaf;
      float hint_value = kInfF;
      if (hint_floor) {
        // theta moves by at most the angle its axis moved (every leaf's
        // angle does): a floor that far above the cap still proves that no
        // leaf is below it, and the search would return the cap.
        const float floor = hint_floor[a] - drift[a];
        if (floor >= best + kHintMargin) {
          out_row[a * out_stride] = best;
          if (witness_row) witness_row[a] = Eigen::Vector3f::Zero();
          hint_leaf[a] = OccluderCones::kNoLeaf;
          hint_floor[a] = floor;
          continue;
        }
        // Every other leaf's theta moved by at most the drift too: where the
        // hinted leaf's stays below all of theirs, it is still the minimum.
        if (hinted != OccluderCones::kNoLeaf) {
          const float rival = hint_rival[a] - drift[a];
          hint_cone = sp.LeafCone(hinted);
          hint_cone_leaf = hinted;
          hint_value = ConeThetaOf(hint_cone, mx, my, mz);
          const bool deep = hint_value <= stop;
          if (deep || (hint_value < best && hint_value + kHintMargin <= rival)) {
            out_row[a * out_stride] = hint_value;
            if (witness_row) witness_row[a] = Eigen::Vector3f(hint_cone.ux, hint_cone.uy, hint_cone.uz);
            // Deep: another leaf may be lower, so no bound is known.
            hint_floor[a] = deep ? -kInfF : hint_value;
            hint_rival[a] = deep ? -kInfF : rival;
            warm = hinted;
            continue;
          }
        }
      }
      // Start from the cap (no leaf above it matters), the caller's hint or
      // the previous axis's best leaf, whichever is lowest: each prunes the
      // descent, and each is a real leaf's theta, so the minimum is the same.
      argmin = kNoneLeaf;
      if (hinted != OccluderCones::kNoLeaf && hint_value < best) best = hint_value, argmin = hinted;
      if (warm != hinted) {
        warm_cone = sp.LeafCone(warm);
        warm_cone_leaf = warm;
        const float warm_value = ConeThetaOf(warm_cone, mx, my, mz);
        if (warm_value < best) best = warm_value, argmin = warm;
      }
      float floor = kInfF, displaced = kInfF;
      for (const FlatTree& tr : flat.trees) {
        if (best <= stop) break;
        ExactTreeF(sp, tr, mx, my, mz, stop, stack, &best, &argmin, &floor, &displaced);
      }
      if (argmin != kNoneLeaf) warm = argmin;
      if (hint_leaf) {
        const bool deep = best <= stop;  // the search may have ended early: no bounds
        hint_leaf[a] = argmin == kNoneLeaf ? OccluderCones::kNoLeaf : static_cast<uint32_t>(argmin);
        hint_floor[a] = deep ? -kInfF : argmin == kNoneLeaf ? floor : best;
        hint_rival[a] = deep || argmin == kNoneLeaf ? -kInfF : std::min(floor, displaced);
      }
    } else {
      best = kInfF;
      for (const FlatTree& tr : flat.trees) {
        size_t leaf;
        const float v = CoarseToFineTreeF(sp, tr, mx, my, mz, &leaf);
        if (v < best) best = v, argmin = leaf;
      }
      if (known_row && known_row[a * out_stride] < best) best = known_row[a * out_stride], argmin = kNoneLeaf;
    }
    out_row[a * out_stride] = best;
    if (witness_row) {
      witness_row[a] = Eigen::Vector3f::Zero();
      if (argmin != kNoneLeaf) {
        const Cone c = argmin == hint_cone_leaf ? hint_cone : argmin == warm_cone_leaf ? warm_cone : sp.LeafCone(argmin);
        witness_row[a] = Eigen::Vector3f(c.ux, c.uy, c.uz);
      }
    }
  }
}

// Asks for a point's whole table (1.3 KB with one tree of 4 levels),
// one point ahead: the tables of a fit set outgrow the caches.
void PrefetchTable(const ConeTable& t) {
  constexpr size_t kLineFloats = 64 / sizeof(float);
  for (size_t i = 0; i < t.data.size(); i += kLineFloats) __builtin_prefetch(t.data.data() + i);
}

std::vector<Eigen::Vector3f> UnitAxes(const std::vector<Eigen::Vector3d>& axes) {
  std::vector<Eigen::Vector3f> unit(axes.size());
  for (size_t a = 0; a < axes.size(); ++a) unit[a] = axes[a].normalized().cast<float>();
  return unit;
}

}  // namespace

void SignedAnglesWithWitness(const std::vector<SphereTree>& world_trees, const std::vector<Eigen::Vector3d>& points,
                             const std::vector<Eigen::Vector3d>& axes, Eigen::MatrixXf* out,
                             std::vector<Eigen::Vector3f>* witness, SsdfSearch search,
                             const std::vector<float>* caps, CapSides sides, const Eigen::MatrixXf* known) {
  CheckTrees(world_trees);
  SHADOWSG_CHECK(!caps || caps->size() == axes.size());
  for (const auto& t : world_trees) SHADOWSG_CHECK(t.nodes.empty() || t.branching <= 64);
  const long np = static_cast<long>(points.size());
  const int na = static_cast<int>(axes.size());
  SHADOWSG_CHECK(!known || (known->rows() == np && known->cols() == na && known != out));
  out->resize(np, na);
  if (witness) witness->assign(static_cast<size_t>(np) * na, Eigen::Vector3f::Zero());
  if (np == 0 || na == 0) return;
  const FlatTrees flat = Flatten(world_trees, search);
  if (flat.trees.empty()) {
    if (known) *out = *known;
    else out->setConstant(kInfF);
    return;
  }
  const std::vector<Eigen::Vector3f> unit = UnitAxes(axes);
  const std::vector<int> order = CoherentAxisOrder(unit);
  // A point's table is tightened (every leaf's cone computed: 512 for a tree
  // of 4 levels of 8) only for enough searches that may descend far (axes
  // without a cap, or with a wide one): a capped search ends at the root's
  // enclosing cone for most plane points. kernels_benchmark, 2 threads, one
  // torus tree: uncapped, 4096 points, 8 / 16 / 32 / 300 axes, 25.5 / 34.4
  // / 54.1 / 388 ms tightened against 18.0 / 32.6 / 64.8 / 567 ms not;
  // RenderShadowPlane (caps of sharpness 30), 65536 points, 8 / 64 lobes,
  // 243 / 505 ms against 69 / 320 ms.
  int wide = 0;
  for (int a = 0; a < na; ++a) wide += !caps || (*caps)[a] >= kWideCap;
  const bool tighten = search == SsdfSearch::kExact && wide >= kTightenAxes;

  // Chunks of neighbouring points: their rows of `out` share cache lines.
  constexpr long kChunk = 32;
#pragma omp parallel
  {
    ConeTable table, leaf_table;
    table.Resize(flat.inner.count);
    // The leaves' cones are kept only where the table is tightened (which
    // computes them all); otherwise a search computes those it reaches.
    if (tighten) leaf_table.Resize(flat.leaves.count);
    ConeTable* const leaves = tighten ? &leaf_table : nullptr;
    std::vector<StackEntry> stack;
    stack.reserve(1024);
#pragma omp for schedule(dynamic, kChunk)
    for (long p = 0; p < np; ++p) {
      FillConeTable(flat, points[p], &table, leaves, tighten);
      PointAngles({flat, table, points[p].data(), leaves}, unit, order, search, caps, sides,
                  &stack, &(*out)(p, 0), out->rows(), witness ? &(*witness)[static_cast<size_t>(p) * na] : nullptr,
                  nullptr, nullptr, nullptr, nullptr, known ? &(*known)(p, 0) : nullptr);
    }
  }
}

struct OccluderCones::Impl {
  FlatTrees flat;
  SsdfSearch search = SsdfSearch::kExact;
  std::vector<Eigen::Vector3d> points;
  std::vector<ConeTable> tables;  // one per point
};

OccluderCones::OccluderCones(const std::vector<SphereTree>& world_trees, const std::vector<Eigen::Vector3d>& points,
                             SsdfSearch search)
    : impl_(std::make_shared<Impl>()) {
  CheckTrees(world_trees);
  for (const auto& t : world_trees) SHADOWSG_CHECK(t.nodes.empty() || t.branching <= 64);
  impl_->search = search;
  impl_->points = points;
  impl_->flat = Flatten(world_trees, search);
  if (impl_->flat.trees.empty()) {
    impl_->tables.resize(points.size());
    return;
  }
  impl_->tables.resize(points.size());
  const long np = static_cast<long>(points.size());
#pragma omp parallel for schedule(dynamic, 64)
  for (long p = 0; p < np; ++p) {
    impl_->tables[p].Resize(impl_->flat.inner.count);
    FillConeTable(impl_->flat, points[p], &impl_->tables[p]);
  }
}

size_t OccluderCones::size() const { return impl_ ? impl_->tables.size() : 0; }

void OccluderCones::Angles(const std::vector<Eigen::Vector3d>& axes, Eigen::MatrixXf* out,
                           std::vector<Eigen::Vector3f>* witness, const std::vector<float>* caps,
                           AngleHints* hints, CapSides sides) const {
  Search(axes, 0, size(), out, witness, caps, hints, sides);
}

void OccluderCones::AnglesOfRange(const std::vector<Eigen::Vector3d>& axes, size_t begin, size_t end,
                                  Eigen::MatrixXf* out, const std::vector<float>* caps, CapSides sides) const {
  SHADOWSG_CHECK(begin <= end && end <= size());
  Search(axes, begin, end, out, nullptr, caps, nullptr, sides);
}

void OccluderCones::Search(const std::vector<Eigen::Vector3d>& axes, size_t begin, size_t end, Eigen::MatrixXf* out,
                           std::vector<Eigen::Vector3f>* witness, const std::vector<float>* caps,
                           AngleHints* hints, CapSides sides) const {
  SHADOWSG_CHECK(!caps || caps->size() == axes.size());
  SHADOWSG_CHECK(!hints || (begin == 0 && end == size()));
  // Hints made for another number of axes or points, or for the coarse-to-fine
  // search, say nothing about this call: start afresh.
  if (hints && (hints->axes.size() != axes.size() || hints->leaf.size() != size() * axes.size() ||
                hints->floor.size() != hints->leaf.size() || hints->rival.size() != hints->leaf.size() ||
                impl_->search != SsdfSearch::kExact)) {
    hints->axes.clear();
    hints->leaf.assign(size() * axes.size(), kNoLeaf);
    hints->floor.assign(size() * axes.size(), -kInfF);
    hints->rival.assign(size() * axes.size(), -kInfF);
  }
  std::vector<float> drift(axes.size(), 0.0f);
  for (size_t a = 0; hints && a < hints->axes.size(); ++a)
    drift[a] = static_cast<float>(std::atan2(hints->axes[a].normalized().cross(axes[a].normalized()).norm(),
                                             hints->axes[a].normalized().dot(axes[a].normalized())));
  const long np = static_cast<long>(end - begin);
  const int na = static_cast<int>(axes.size());
  out->resize(np, na);
  if (witness) witness->assign(static_cast<size_t>(np) * na, Eigen::Vector3f::Zero());
  if (np == 0 || na == 0) return;
  if (impl_->flat.trees.empty()) {
    out->setConstant(kInfF);
    if (hints) hints->axes = axes;  // leaves none, floors -inf: nothing to learn
    return;
  }
  const std::vector<Eigen::Vector3f> unit = UnitAxes(axes);
  const std::vector<int> order = CoherentAxisOrder(unit);
  // Searched for many axes (a dictionary's), a point's leaf cones are
  // computed once into a table rather than at each visit: the same cones, so
  // the same nodes are visited and the same values found.
  const bool leaf_table = na >= kTightenAxes;
#pragma omp parallel
  {
    std::vector<StackEntry> stack;
    stack.reserve(1024);
    ConeTable leaves;
    if (leaf_table) leaves.Resize(impl_->flat.leaves.count);
#pragma omp for schedule(dynamic, 32)
    for (long q = 0; q < np; ++q) {
      const size_t p = begin + static_cast<size_t>(q), at = static_cast<size_t>(q) * na;
      if (q + 1 < np) PrefetchTable(impl_->tables[p + 1]);
      if (leaf_table) FillLeafTable(impl_->flat, impl_->points[p].data(), &leaves);
      PointAngles({impl_->flat, impl_->tables[p], impl_->points[p].data(), leaf_table ? &leaves : nullptr}, unit,
                  order, impl_->search, caps, sides, &stack,
                  &(*out)(q, 0), out->rows(), witness ? &(*witness)[at] : nullptr,
                  hints ? &hints->leaf[at] : nullptr, hints ? &hints->floor[at] : nullptr,
                  hints ? &hints->rival[at] : nullptr, drift.data());
    }
  }
  if (hints) hints->axes = axes;
}

OccluderCones::AngleHints JoinHints(const std::vector<OccluderCones::AngleHints*>& one_axis, size_t points) {
  const size_t na = one_axis.size();
  OccluderCones::AngleHints joined;
  joined.axes.assign(na, Eigen::Vector3d::UnitZ());  // no floor to lower for a fresh column: any axis
  joined.leaf.assign(points * na, OccluderCones::kNoLeaf);
  joined.floor.assign(points * na, -kInfF);
  joined.rival.assign(points * na, -kInfF);
  std::vector<char> has(na, 0);
  for (size_t a = 0; a < na; ++a) {
    const OccluderCones::AngleHints* h = one_axis[a];
    has[a] = h && h->axes.size() == 1 && h->leaf.size() == points && h->floor.size() == points &&
             h->rival.size() == points;
    if (has[a]) joined.axes[a] = h->axes[0];
  }
  // Points x axes, copied a block of points per thread (a transpose).
#pragma omp parallel for schedule(static) if (points * na > 16384)
  for (long p = 0; p < static_cast<long>(points); ++p)
    for (size_t a = 0; a < na; ++a)
      if (has[a]) {
        joined.leaf[p * na + a] = one_axis[a]->leaf[p];
        joined.floor[p * na + a] = one_axis[a]->floor[p];
        joined.rival[p * na + a] = one_axis[a]->rival[p];
      }
  return joined;
}

void SplitHints(const OccluderCones::AngleHints& joined, const std::vector<OccluderCones::AngleHints*>& one_axis) {
  const size_t na = one_axis.size();
  const bool learnt = joined.axes.size() == na && na > 0 && joined.leaf.size() % na == 0 &&
                      joined.floor.size() == joined.leaf.size() && joined.rival.size() == joined.leaf.size();
  const size_t points = learnt ? joined.leaf.size() / na : 0;
  for (size_t a = 0; a < na; ++a) {
    OccluderCones::AngleHints& h = *one_axis[a];
    h = {};
    if (!learnt) continue;
    h.axes = {joined.axes[a]};
    h.leaf.resize(points);
    h.floor.resize(points);
    h.rival.resize(points);
  }
  if (!learnt) return;
#pragma omp parallel for schedule(static) if (points * na > 16384)
  for (long p = 0; p < static_cast<long>(points); ++p)
    for (size_t a = 0; a < na; ++a)
      one_axis[a]->leaf[p] = joined.leaf[p * na + a], one_axis[a]->floor[p] = joined.floor[p * na + a],
      one_axis[a]->rival[p] = joined.rival[p * na + a];
}

}  // namespace shadowsg
