// The signed angular distance theta of the paper (Sec. 3.2, eq. 9-10): from a
// plane point x, the signed angle between a lobe axis mu and the nearest
// occluder boundary, the occluders being the leaf spheres of sphere trees.
// theta > 0: mu is unoccluded by that much; theta < 0: mu points into an
// occluder's cone.
//
// Conventions shared by every function here:
// - trees are in world space; nodes with radius <= 0 are empty slots and are
//   ignored; only the LAST level of a tree holds occluders (as the reference
//   code's sph_level_min / sph_coarse2fine_min use them);
// - theta(x, s) is evaluated as atan2(|u x mu|, u . mu) - asin(min(1, r/|s|)),
//   u = s/|s|, s = c_s - x: the same value as acos(s.mu/|s|) - ..., computed
//   without acos's loss of precision near 0 and pi. If x is inside a sphere the
//   cone is the hemisphere around u (asin(1) = pi/2); if x is its centre, u is
//   taken as +z;
// - mu need not be unit length (it is normalised);
// - with no occluder at all theta is +infinity (sigma = 1).
#pragma once

#include <cstdint>
#include <Eigen/Dense>
#include <memory>
#include <vector>

#include "solver/sphere_tree.h"

namespace shadowsg {

enum class SsdfSearch {
  // Branch-and-bound over each tree: exact (equal to the brute force).
  kExact,
  // The reference code's descent (field-notes 1.4, sph_coarse2fine_min): from
  // level 1 down, keep the best kCoarseToFineKeep nodes of each level and
  // expand their children. Approximate, never below the exact value.
  kCoarseToFine,
};

// The reference code's ssdf_sph_coarse2fine_k.
constexpr int kCoarseToFineKeep = 3;

// Which side of a caller's caps (one per axis, kExact) theta is needed
// exactly on. kAbove: theta at or above the cap is returned as the cap.
// kBoth: besides, where some leaf's theta is at or below minus the cap the
// search may stop at that leaf: theta is then that leaf's, at or below minus
// the cap but not always the minimum, with its witness. For a visibility
// sigmoid that is saturated both ways (1 above the cap, 0 below minus it);
// the sharp lobes' deep shadows then need no search for their deepest leaf.
enum class CapSides { kAbove, kBoth };

// theta(x, mu) = min over the LEAF spheres s of all trees of
//   acos(dot(c_s - x, mu) / |c_s - x|) - asin(min(1, r_s / |c_s - x|))
// (world-space trees; empty slots ignored). kExact: branch-and-bound over the
// tree. A parent sphere need not contain its children (trees read from files
// do not promise it), so the bound of a subtree is the angle to a sphere that
// encloses all of its leaves; it is computed from the tree on every call
// (O(nodes); batch callers use SignedAngles, which computes it once).
// kCoarseToFine: the reference code's search keeping the best 3 nodes per level.
double SignedAngleToOccluders(const std::vector<SphereTree>& world_trees, const Eigen::Vector3d& x,
                              const Eigen::Vector3d& mu, SsdfSearch search = SsdfSearch::kExact);
// Every leaf sphere tried; for tests and checks.
double SignedAngleBruteForce(const std::vector<SphereTree>& world_trees, const Eigen::Vector3d& x,
                             const Eigen::Vector3d& mu);
// theta for every (point, axis) pair, multithreaded (OpenMP): out(p, a), resized
// to points x axes. Hot path of the solver: single precision with per-point
// cone tables (kExact also bounds each subtree, per point, by the cap around
// its children's cones), axes visited in a coherent order with the previous
// axis's best leaf as the first bound, and an AVX2 kernel where the CPU has
// one; agrees with SignedAngleToOccluders to about 1e-5 rad (float).
void SignedAngles(const std::vector<SphereTree>& world_trees, const std::vector<Eigen::Vector3d>& points,
                  const std::vector<Eigen::Vector3d>& axes, Eigen::MatrixXf* out,
                  SsdfSearch search = SsdfSearch::kExact);

// SignedAngles that also returns, for each pair, the unit direction u from the
// point to the centre of the leaf sphere attaining the minimum, in
// witness[p * axes + a] (zero when there is no occluder): the gradient of theta
// with respect to a unit axis mu is -u / sin(angle(u, mu)) (paper eq. 9), the
// subgradient the solvers use.
void SignedAnglesWithWitness(const std::vector<SphereTree>& world_trees, const std::vector<Eigen::Vector3d>& points,
                             const std::vector<Eigen::Vector3d>& axes, Eigen::MatrixXf* out,
                             std::vector<Eigen::Vector3f>* witness, SsdfSearch search = SsdfSearch::kExact,
                             const std::vector<float>* caps = nullptr,  // as OccluderCones::Angles
                             CapSides sides = CapSides::kAbove,
                             const Eigen::MatrixXf* known = nullptr);
// known (optional, points x axes): theta already found for other occluders
// (an earlier call's out). Each result is the smaller of it and these trees'
// theta (the witness zero where known is smaller), and the search skips every
// subtree above it: adding occluders to a theta costs their search alone.

// The cone tables of a fixed set of points, computed once: the occluders seen
// from a plane point never change while the lighting is fitted, so solvers
// that evaluate theta for new axes many times over the same points keep one
// of these (16 bytes per point and inner tree node, 1.3 KB a point for one
// tree of 4 levels of 8; the leaves' cones are computed where a search
// reaches them). Copies share the tables.
class OccluderCones {
 public:
  OccluderCones() = default;
  OccluderCones(const std::vector<SphereTree>& world_trees, const std::vector<Eigen::Vector3d>& points,
                SsdfSearch search = SsdfSearch::kExact);
  size_t size() const;
  // What a search learnt, kept between calls over the same points by a
  // solver whose axes move a little per iteration (kExact only): per (point,
  // axis), [p * axes.size() + a], the leaf that attained the minimum
  // (kNoLeaf: none below the cap), a lower bound on theta (theta itself
  // when a leaf was found), and where a leaf was found a lower bound on the
  // theta of every other leaf (rival), all for `axes`. While the leaf's theta
  // stays below its rival less the axis's drift, it is still the minimum and
  // the search is skipped.
  static constexpr uint32_t kNoLeaf = 0xffffffffu;
  struct AngleHints {
    std::vector<Eigen::Vector3d> axes;  // empty: no hints yet (filled in)
    std::vector<uint32_t> leaf;
    std::vector<float> floor;
    std::vector<float> rival;
  };

  // As SignedAnglesWithWitness for the prepared points (witness may be null).
  // caps (kExact only; one per axis, optional): theta values at or above the
  // cap are not needed exactly: the search stops there and returns the cap
  // with a zero witness. The soft visibility sigmoid(k theta) is 1 to double
  // precision beyond a few tens over k, so solvers pass that.
  // hints (optional, in and out): the last call's AngleHints. theta moves by
  // at most the angle its axis moved, so a bound that stays above the new cap
  // skips the search, and a leaf bounds it from the start. theta is that of a
  // search without hints up to float rounding (a tighter first bound may
  // prune a subtree whose bound ties the minimum), and the attaining leaf may
  // differ where two leaves tie.
  // sides: CapSides, for the caps.
  void Angles(const std::vector<Eigen::Vector3d>& axes, Eigen::MatrixXf* theta,
              std::vector<Eigen::Vector3f>* witness, const std::vector<float>* caps = nullptr,
              AngleHints* hints = nullptr, CapSides sides = CapSides::kAbove) const;
  // theta of the points [begin, end) only (rows in that order), without
  // witnesses or hints: a caller that may stop after a few of the points.
  void AnglesOfRange(const std::vector<Eigen::Vector3d>& axes, size_t begin, size_t end, Eigen::MatrixXf* theta,
                     const std::vector<float>* caps = nullptr, CapSides sides = CapSides::kAbove) const;

 private:
  // Angles over the points [begin, end) (hints: the whole range only).
  void Search(const std::vector<Eigen::Vector3d>& axes, size_t begin, size_t end, Eigen::MatrixXf* theta,
              std::vector<Eigen::Vector3f>* witness, const std::vector<float>* caps, AngleHints* hints,
              CapSides sides) const;

  struct Impl;
  std::shared_ptr<Impl> impl_;
};

// One-axis hints (an OccluderCones::AngleHints per lobe, as a solver keeps
// them) side by side for one Angles call, and back. An entry without hints
// for `points` points joins as a fresh column; a call that learnt nothing
// splits into empty entries.
OccluderCones::AngleHints JoinHints(const std::vector<OccluderCones::AngleHints*>& one_axis, size_t points);
void SplitHints(const OccluderCones::AngleHints& joined, const std::vector<OccluderCones::AngleHints*>& one_axis);

// The spheres that bound each subtree for the exact search: node i of the
// result encloses every non-empty leaf below (or at) node i; radius <= 0 where
// the subtree has no leaf. Leaves are copied. Exposed for tests.
std::vector<Sphere> SubtreeBounds(const SphereTree& tree);

}  // namespace shadowsg
