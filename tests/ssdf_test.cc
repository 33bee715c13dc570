#include "solver/ssdf.h"

#include <gtest/gtest.h>

#include "solver/primitives.h"
#include "solver/sphere_tree_build.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

namespace shadowsg {
namespace {

constexpr double kPi = 3.14159265358979323846;

Eigen::Vector3d RandomUnit(std::mt19937_64& rng) {
  std::normal_distribution<double> n;
  return Eigen::Vector3d(n(rng), n(rng), n(rng)).normalized();
}

// A random complete tree over a cloud of leaves. With `enclosing`, each parent
// is a sphere around its children (as a builder makes); without, parents are
// arbitrary spheres that do NOT enclose them (as a file may hold), and some
// slots are empty at every level.
SphereTree RandomTree(std::mt19937_64& rng, int levels, int branching, bool enclosing, const Eigen::Vector3d& at) {
  SphereTree t;
  t.levels = levels;
  t.branching = branching;
  t.nodes.resize(SphereTree::NodeCount(levels, branching));
  std::uniform_real_distribution<double> u(0, 1);
  // Leaves clustered by subtree so the bounds are informative.
  const size_t leaf_begin = t.LevelBegin(levels - 1);
  for (size_t i = leaf_begin; i < t.nodes.size(); ++i) {
    const size_t group = (i - leaf_begin) / branching;
    std::mt19937_64 grng(group * 7919 + 1);
    const Eigen::Vector3d g = at + 0.8 * RandomUnit(grng) * u(grng);
    t.nodes[i].centre = g + 0.15 * RandomUnit(rng) * u(rng);
    t.nodes[i].radius = u(rng) < 0.1 ? 0.0 : 0.02 + 0.08 * u(rng);
  }
  for (size_t i = leaf_begin; i-- > 0;) {
    if (enclosing) {
      Eigen::Vector3d c = Eigen::Vector3d::Zero();
      int n = 0;
      for (int k = 0; k < branching; ++k)
        if (!t.nodes[t.FirstChild(i) + k].empty()) c += t.nodes[t.FirstChild(i) + k].centre, ++n;
      if (n == 0) continue;
      c /= n;
      double r = 0;
      for (int k = 0; k < branching; ++k) {
        const Sphere& s = t.nodes[t.FirstChild(i) + k];
        if (!s.empty()) r = std::max(r, (s.centre - c).norm() + s.radius);
      }
      t.nodes[i] = {c, r};
    } else {
      t.nodes[i].centre = at + 0.5 * RandomUnit(rng);
      t.nodes[i].radius = u(rng) < 0.1 ? -1.0 : 0.05 * u(rng);
    }
  }
  return t;
}

std::vector<SphereTree> TestTrees(uint64_t seed) {
  std::mt19937_64 rng(seed);
  return {RandomTree(rng, 4, 8, true, Eigen::Vector3d(0, 0, 1)),
          RandomTree(rng, 3, 8, false, Eigen::Vector3d(1.2, 0.3, 0.9)),
          RandomTree(rng, 3, 4, true, Eigen::Vector3d(-1, 0.5, 0.4))};
}

// Plane points around the trees, some inside the clouds.
std::vector<Eigen::Vector3d> TestPoints(std::mt19937_64& rng, int n) {
  std::uniform_real_distribution<double> u(-2, 2);
  std::vector<Eigen::Vector3d> p;
  for (int i = 0; i < n; ++i) p.emplace_back(u(rng), u(rng), i % 5 == 0 ? 0.5 * (u(rng) + 2) : 0.0);
  return p;
}

// Each non-empty leaf of the trees as a tree of its own: the brute force's
// theta of one is that leaf's.
std::vector<SphereTree> LeafTrees(const std::vector<SphereTree>& trees) {
  std::vector<SphereTree> leaves;
  for (const SphereTree& t : trees)
    for (size_t i = t.LevelBegin(t.levels - 1); i < t.nodes.size(); ++i)
      if (!t.nodes[i].empty()) leaves.push_back({1, t.branching, {t.nodes[i]}});
  return leaves;
}

TEST(Ssdf, SingleSphereMatchesClosedForm) {
  SphereTree t;
  t.levels = 1;
  t.branching = 8;
  t.nodes = {{Eigen::Vector3d(0, 0, 2), 1.0}};
  const Eigen::Vector3d x = Eigen::Vector3d::Zero();
  // Straight at the centre: -asin(1/2).
  EXPECT_NEAR(SignedAngleToOccluders({t}, x, Eigen::Vector3d::UnitZ()), -kPi / 6, 1e-12);
  // 90 degrees away: pi/2 - pi/6.
  EXPECT_NEAR(SignedAngleToOccluders({t}, x, Eigen::Vector3d::UnitX()), kPi / 3, 1e-12);
  // Not normalised on input.
  EXPECT_NEAR(SignedAngleToOccluders({t}, x, Eigen::Vector3d(0, 0, 5)), -kPi / 6, 1e-12);
  // Inside the sphere: the cone is a hemisphere.
  EXPECT_NEAR(SignedAngleToOccluders({t}, Eigen::Vector3d(0, 0, 1.5), Eigen::Vector3d::UnitZ()), -kPi / 2, 1e-12);
}

TEST(Ssdf, NoOccluderIsInfinite) {
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_EQ(SignedAngleToOccluders({}, Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ()), inf);
  SphereTree empty;
  empty.levels = 2;
  empty.branching = 2;
  empty.nodes.resize(3);  // all radius 0
  EXPECT_EQ(SignedAngleToOccluders({empty}, Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ()), inf);
  EXPECT_EQ(SignedAngleBruteForce({empty}, Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitZ()), inf);
  Eigen::MatrixXf out;
  SignedAngles({empty}, {Eigen::Vector3d::Zero()}, {Eigen::Vector3d::UnitZ()}, &out);
  ASSERT_EQ(out.rows(), 1);
  EXPECT_EQ(out(0, 0), std::numeric_limits<float>::infinity());
}

TEST(Ssdf, SubtreeBoundsEncloseEveryLeaf) {
  for (const SphereTree& t : TestTrees(3)) {
    const std::vector<Sphere> b = SubtreeBounds(t);
    const size_t leaf_begin = t.LevelBegin(t.levels - 1);
    for (size_t leaf = leaf_begin; leaf < t.nodes.size(); ++leaf) {
      if (t.nodes[leaf].empty()) continue;
      for (size_t i = leaf; i > 0;) {
        i = (i - 1) / t.branching;
        ASSERT_FALSE(b[i].empty());
        EXPECT_LE((t.nodes[leaf].centre - b[i].centre).norm() + t.nodes[leaf].radius, b[i].radius * (1 + 1e-12));
      }
    }
  }
}

TEST(Ssdf, ExactEqualsBruteForce) {
  const auto trees = TestTrees(11);
  std::mt19937_64 rng(5);
  const auto points = TestPoints(rng, 300);
  for (const auto& x : points)
    for (int k = 0; k < 20; ++k) {
      const Eigen::Vector3d mu = RandomUnit(rng);
      const double exact = SignedAngleToOccluders(trees, x, mu, SsdfSearch::kExact);
      ASSERT_NEAR(exact, SignedAngleBruteForce(trees, x, mu), 1e-9);
      EXPECT_GE(SignedAngleToOccluders(trees, x, mu, SsdfSearch::kCoarseToFine), exact - 1e-12);
    }
}

TEST(Ssdf, CoarseToFineIsOftenExact) {
  // The reference descent is an approximation, but on trees whose parents
  // enclose their children it should find the minimum most of the time.
  std::mt19937_64 rng(8);
  const std::vector<SphereTree> trees = {RandomTree(rng, 4, 8, true, Eigen::Vector3d(0, 0, 1))};
  const auto points = TestPoints(rng, 200);
  int exact = 0, total = 0;
  for (const auto& x : points)
    for (int k = 0; k < 10; ++k, ++total) {
      const Eigen::Vector3d mu = RandomUnit(rng);
      exact += std::abs(SignedAngleToOccluders(trees, x, mu, SsdfSearch::kCoarseToFine) -
                        SignedAngleToOccluders(trees, x, mu)) < 1e-12;
    }
  EXPECT_GT(exact, total * 0.8);
}

TEST(Ssdf, BatchMatchesSingle) {
  const auto trees = TestTrees(21);
  std::mt19937_64 rng(9);
  const auto points = TestPoints(rng, 500);
  std::vector<Eigen::Vector3d> axes;
  for (int i = 0; i < 40; ++i) axes.push_back(RandomUnit(rng) * (i % 3 + 1));  // not all unit
  axes.push_back(Eigen::Vector3d::UnitZ());
  // 41 axes: each point's table tightened; 8: the subtrees' enclosing cones.
  std::vector<Eigen::Vector3d> few(axes.begin(), axes.begin() + 8);
  for (SsdfSearch search : {SsdfSearch::kExact, SsdfSearch::kCoarseToFine})
    for (const auto* some : {&axes, &few}) {
      Eigen::MatrixXf out;
      SignedAngles(trees, points, *some, &out, search);
      ASSERT_EQ(out.rows(), static_cast<long>(points.size()));
      ASSERT_EQ(out.cols(), static_cast<long>(some->size()));
      double worst = 0;
      for (size_t p = 0; p < points.size(); ++p)
        for (size_t a = 0; a < some->size(); ++a)
          worst =
              std::max(worst, std::abs(out(p, a) - SignedAngleToOccluders(trees, points[p], (*some)[a], search)));
      // Single precision: float rounding of directions and angles.
      EXPECT_LT(worst, 2e-5) << (search == SsdfSearch::kExact ? "exact" : "coarse-to-fine") << ", "
                             << some->size() << " axes";
    }
}

// theta over more occluders from theta over some: the search of the others
// starts below what is known and returns the smaller.
TEST(Ssdf, KnownAnglesOfSomeTreesJoinTheOthers) {
  const auto trees = TestTrees(33);
  const std::vector<SphereTree> first = {trees[0]}, others = {trees[1], trees[2]};
  std::mt19937_64 rng(4);
  const auto points = TestPoints(rng, 400);
  std::vector<Eigen::Vector3d> axes;
  for (int i = 0; i < 40; ++i) axes.push_back(RandomUnit(rng));
  std::vector<float> caps(axes.size());
  for (size_t a = 0; a < caps.size(); ++a) caps[a] = 0.05f + 0.1f * static_cast<float>(a % 7);
  const std::vector<Eigen::Vector3d> few(axes.begin(), axes.begin() + 8);
  const std::vector<float> few_caps(caps.begin(), caps.begin() + 8);
  for (SsdfSearch search : {SsdfSearch::kExact, SsdfSearch::kCoarseToFine})
    for (int variant = 0; variant < 3; ++variant) {
      // Many uncapped axes (tightened tables), few uncapped, few capped.
      const auto& ax = variant == 0 ? axes : few;
      const std::vector<float>* cp = variant == 2 ? &few_caps : nullptr;
      Eigen::MatrixXf known, joined, all;
      SignedAnglesWithWitness(first, points, ax, &known, nullptr, search, cp);
      SignedAnglesWithWitness(others, points, ax, &joined, nullptr, search, cp, CapSides::kAbove, &known);
      SignedAnglesWithWitness(trees, points, ax, &all, nullptr, search, cp);
      int lowered = 0;
      for (long p = 0; p < all.rows(); ++p)
        for (long a = 0; a < all.cols(); ++a) {
          ASSERT_EQ(joined(p, a), all(p, a)) << "point " << p << " axis " << a << " variant " << variant;
          lowered += joined(p, a) < known(p, a);
        }
      // The other trees' leaves decide some of them.
      EXPECT_GT(lowered, 50) << variant;
    }
}

TEST(Ssdf, HintsGiveTheSameAnglesAsAFreshSearch) {
  // A solver's axes move a little per iteration; the hints of the last call
  // skip points whose lower bound stays above the cap and bound the rest.
  // The steps here are larger than the cap, so points cross it both ways:
  // a floor not lowered by the axis's drift would skip points now in shadow.
  const auto trees = TestTrees(31);
  std::mt19937_64 rng(12);
  const auto points = TestPoints(rng, 400);
  const OccluderCones cones(trees, points);
  std::vector<Eigen::Vector3d> axes = {Eigen::Vector3d(0.3, 0.1, 1).normalized(),
                                       Eigen::Vector3d(-0.5, 0.4, 0.8).normalized(), Eigen::Vector3d(1, -1, 0.3)};
  const std::vector<float> caps = {0.15f, 0.4f, 0.05f};
  OccluderCones::AngleHints hints;
  const Eigen::AngleAxisd turn(0.08, Eigen::Vector3d(1, 2, 0.5).normalized());
  long skipped_rows = 0, in_shadow = 0, witness_differs = 0, pairs = 0;
  for (int step = 0; step < 8; ++step) {
    Eigen::MatrixXf fresh, hinted;
    std::vector<Eigen::Vector3f> fresh_w, hinted_w;
    cones.Angles(axes, &fresh, &fresh_w, &caps);
    cones.Angles(axes, &hinted, &hinted_w, &caps, &hints);
    ASSERT_EQ(hints.axes.size(), axes.size());
    for (size_t p = 0; p < points.size(); ++p)
      for (size_t a = 0; a < axes.size(); ++a) {
        const size_t i = p * axes.size() + a;
        // The same minimum up to the search's float slack; the leaf that
        // attains it may differ where two leaves tie within rounding.
        ASSERT_NEAR(hinted(p, a), fresh(p, a), 1e-5) << "step " << step << " point " << p << " axis " << a;
        witness_differs += !hinted_w[i].isApprox(fresh_w[i]);
        ++pairs;
        const double truth = SignedAngleBruteForce(trees, points[p], axes[a]);
        // The floor bounds theta from below, and is theta where a leaf is below the cap.
        EXPECT_LE(hints.floor[i], truth + 1e-5);
        if (hints.leaf[i] == OccluderCones::kNoLeaf) {
          EXPECT_GE(hints.floor[i], caps[a]);
          skipped_rows += hints.floor[i] > caps[a] + 0.2;  // far enough to skip after the next turn
        } else {
          EXPECT_NEAR(hints.floor[i], truth, 1e-5);
          ++in_shadow;
        }
      }
    for (auto& a : axes) a = turn * a;
  }
  EXPECT_GT(skipped_rows, 100);
  EXPECT_GT(in_shadow, 100);
  EXPECT_LE(witness_differs, pairs / 200);
}

// Where a leaf attains theta, the hints' rival bounds every other leaf's
// theta from below; with an LM-sized turn it holds on through the next call
// on many points (those skip the search), and the hinted angles stay those of
// a fresh search.
TEST(Ssdf, HintsRivalBoundsTheOtherLeaves) {
  const auto trees = TestTrees(31);
  std::mt19937_64 rng(14);
  const auto points = TestPoints(rng, 300);
  const OccluderCones cones(trees, points);
  std::vector<Eigen::Vector3d> axes = {Eigen::Vector3d(0.3, 0.1, 1).normalized(),
                                       Eigen::Vector3d(-0.5, 0.4, 0.8).normalized()};
  const std::vector<float> caps = {0.3f, 0.3f};
  const std::vector<SphereTree> leaves = LeafTrees(trees);
  OccluderCones::AngleHints hints;
  const Eigen::AngleAxisd turn(0.003, Eigen::Vector3d(1, 2, 0.5).normalized());
  long found = 0, held = 0;
  for (int step = 0; step < 4; ++step) {
    const OccluderCones::AngleHints last = hints;
    Eigen::MatrixXf fresh, hinted;
    cones.Angles(axes, &fresh, nullptr, &caps);
    cones.Angles(axes, &hinted, nullptr, &caps, &hints);
    ASSERT_EQ(hints.rival.size(), hints.leaf.size());
    for (size_t p = 0; p < points.size(); ++p)
      for (size_t a = 0; a < axes.size(); ++a) {
        const size_t i = p * axes.size() + a;
        ASSERT_NEAR(hinted(p, a), fresh(p, a), 1e-5) << "step " << step << " point " << p << " axis " << a;
        if (hints.leaf[i] == OccluderCones::kNoLeaf) continue;
        ++found;
        // The second lowest leaf: the argmin is the lowest (up to ties).
        std::vector<double> theta;
        for (const SphereTree& one : leaves) theta.push_back(SignedAngleBruteForce({one}, points[p], axes[a]));
        std::nth_element(theta.begin(), theta.begin() + 1, theta.end());
        EXPECT_LE(hints.rival[i], theta[1] + 1e-5) << "step " << step << " point " << p << " axis " << a;
        EXPECT_GE(hints.rival[i], hints.floor[i] - 1e-5);
        // Kept through the turn: the same leaf, its rival lowered by the drift.
        held += step > 0 && last.leaf[i] == hints.leaf[i] && hints.rival[i] < last.rival[i] &&
                hints.rival[i] > last.rival[i] - 0.0031f;
      }
    for (auto& a : axes) a = turn * a;
  }
  EXPECT_GT(found, 200);
  EXPECT_GT(held, found / 10);
}

// With CapSides::kBoth a search may stop at the first leaf at or below minus
// the cap (a sigmoid saturated at 0 there): theta is then that leaf's, above
// the true minimum; between the caps it is the minimum, above them the cap,
// with hints (which must not claim bounds they do not have) and without.
TEST(Ssdf, BothSidedCapsStopAtADeepLeaf) {
  const auto trees = TestTrees(31);
  std::mt19937_64 rng(16);
  const auto points = TestPoints(rng, 250);
  const OccluderCones cones(trees, points);
  std::vector<Eigen::Vector3d> axes = {Eigen::Vector3d(0.3, 0.1, 1).normalized(),
                                       Eigen::Vector3d(-0.5, 0.4, 0.8).normalized(), Eigen::Vector3d(1, -1, 0.3)};
  const std::vector<float> caps = {0.02f, 0.1f, 0.05f};
  const std::vector<SphereTree> leaves = LeafTrees(trees);
  OccluderCones::AngleHints hints;
  const Eigen::AngleAxisd turn(0.01, Eigen::Vector3d(1, 2, 0.5).normalized());
  long deep = 0, stopped = 0;
  for (int step = 0; step < 4; ++step) {
    Eigen::MatrixXf exact, fresh, hinted;
    std::vector<Eigen::Vector3f> fresh_w, hinted_w;
    cones.Angles(axes, &exact, nullptr, &caps);
    cones.Angles(axes, &fresh, &fresh_w, &caps, nullptr, CapSides::kBoth);
    cones.Angles(axes, &hinted, &hinted_w, &caps, &hints, CapSides::kBoth);
    for (size_t p = 0; p < points.size(); ++p)
      for (size_t a = 0; a < axes.size(); ++a) {
        const size_t i = p * axes.size() + a;
        const double truth = SignedAngleBruteForce(trees, points[p], axes[a]);
        EXPECT_LE(hints.floor[i], truth + 1e-5);
        const float e = exact(p, a);
        if (e > -caps[a] + 1e-5f) {
          ASSERT_NEAR(fresh(p, a), e, 1e-5) << "step " << step << " point " << p << " axis " << a;
          ASSERT_NEAR(hinted(p, a), e, 1e-5) << "step " << step << " point " << p << " axis " << a;
          continue;
        }
        ++deep;
        for (const auto& [theta, w] : {std::pair{fresh(p, a), fresh_w[i]}, std::pair{hinted(p, a), hinted_w[i]}}) {
          EXPECT_LE(theta, -caps[a] + 1e-5f);
          EXPECT_GE(theta, e - 1e-5f);
          // Some leaf's theta, and the witness points at that leaf's centre.
          double nearest = 1e9;
          for (const SphereTree& one : leaves) {
            const Eigen::Vector3d u = (one.nodes[0].centre - points[p]).normalized();
            if ((u.cast<float>() - w).norm() < 1e-4f)
              nearest = std::min(nearest, std::abs(SignedAngleBruteForce({one}, points[p], axes[a]) - theta));
          }
          EXPECT_LT(nearest, 1e-5) << "step " << step << " point " << p << " axis " << a;
          stopped += theta > e + 1e-4f;
        }
      }
    for (auto& a : axes) a = turn * a;
  }
  EXPECT_GT(deep, 50) << stopped;
  EXPECT_GT(stopped, 5) << deep;  // the early stop does happen
}

// A dictionary's many axes are searched with each point's leaf cones in a
// table, a few axes with the cones computed where the search reaches them:
// the same cones either way, so the same minimum to the bit.
TEST(Ssdf, ManyAxesAtOnceMatchAFewAtATime) {
  const auto trees = TestTrees(37);
  std::mt19937_64 rng(21);
  const auto points = TestPoints(rng, 300);
  const OccluderCones cones(trees, points);
  std::vector<Eigen::Vector3d> axes;
  std::vector<float> caps;
  for (int a = 0; a < 40; ++a) {
    Eigen::Vector3d d = RandomUnit(rng);
    d.z() = std::abs(d.z()) + 0.1;
    axes.push_back(d.normalized());
    caps.push_back(a % 3 == 0 ? 3.0f : 0.2f + 0.02f * a);
  }
  Eigen::MatrixXf all;
  std::vector<Eigen::Vector3f> all_w;
  cones.Angles(axes, &all, &all_w, &caps);
  long witness_differs = 0, in_shadow = 0;
  for (size_t begin = 0; begin < axes.size(); begin += 4) {
    const std::vector<Eigen::Vector3d> few(axes.begin() + begin, axes.begin() + begin + 4);
    const std::vector<float> few_caps(caps.begin() + begin, caps.begin() + begin + 4);
    Eigen::MatrixXf part;
    std::vector<Eigen::Vector3f> part_w;
    cones.Angles(few, &part, &part_w, &few_caps);
    for (size_t p = 0; p < points.size(); ++p)
      for (size_t a = 0; a < few.size(); ++a) {
        ASSERT_EQ(part(p, a), all(p, begin + a)) << "point " << p << " axis " << begin + a;
        in_shadow += part(p, a) < few_caps[a];
        witness_differs += part_w[p * few.size() + a] != all_w[p * axes.size() + begin + a];
      }
  }
  EXPECT_GT(in_shadow, 1000);
  EXPECT_LE(witness_differs, in_shadow / 200);  // ties only
}

// A range of the prepared points gives those rows of the whole call.
TEST(Ssdf, AnglesOfARangeAreThoseRows) {
  const auto trees = TestTrees(23);
  std::mt19937_64 rng(9);
  const auto points = TestPoints(rng, 120);
  const OccluderCones cones(trees, points);
  const std::vector<Eigen::Vector3d> axes = {Eigen::Vector3d(0.3, 0.1, 1).normalized(),
                                            Eigen::Vector3d(-0.6, 0.2, 0.7).normalized()};
  const std::vector<float> caps = {0.3f, 2.0f};
  Eigen::MatrixXf all, part;
  cones.Angles(axes, &all, nullptr, &caps);
  cones.AnglesOfRange(axes, 37, 90, &part, &caps);
  ASSERT_EQ(part.rows(), 53);
  ASSERT_EQ(part.cols(), 2);
  EXPECT_EQ(part, all.middleRows(37, 53));
  cones.AnglesOfRange(axes, 120, 120, &part, &caps);
  EXPECT_EQ(part.rows(), 0);
}

TEST(Ssdf, PerAxisHintsJoinAndSplit) {
  // A solver keeps one-axis hints per lobe and searches its lobes together;
  // lobes come and go between calls (a fresh one joins without hints).
  const auto trees = TestTrees(41);
  std::mt19937_64 rng(14);
  const auto points = TestPoints(rng, 300);
  const OccluderCones cones(trees, points);
  std::vector<Eigen::Vector3d> axes = {Eigen::Vector3d(0.2, -0.3, 1).normalized(),
                                       Eigen::Vector3d(0.6, 0.5, 0.7).normalized()};
  const std::vector<float> caps = {0.2f, 0.1f};
  std::vector<OccluderCones::AngleHints> kept(2), alone(2);
  long leaf_differs = 0, pairs = 0;
  const Eigen::AngleAxisd turn(0.06, Eigen::Vector3d(-1, 1, 0.2).normalized());
  for (int step = 0; step < 5; ++step) {
    if (step == 3) kept[1] = {};  // as a lobe new to the model
    std::vector<OccluderCones::AngleHints*> one_axis = {&kept[0], &kept[1]};
    OccluderCones::AngleHints joined = JoinHints(one_axis, points.size());
    Eigen::MatrixXf theta, fresh;
    cones.Angles(axes, &theta, nullptr, &caps, &joined);
    SplitHints(joined, one_axis);
    cones.Angles(axes, &fresh, nullptr, &caps);
    for (size_t a = 0; a < axes.size(); ++a) {
      ASSERT_EQ(kept[a].axes.size(), 1u);
      EXPECT_TRUE(kept[a].axes[0].isApprox(axes[a]));
      ASSERT_EQ(kept[a].leaf.size(), points.size());
      Eigen::MatrixXf one;
      const std::vector<float> cap = {caps[a]};
      cones.Angles({axes[a]}, &one, nullptr, &cap, &alone[a]);
      for (size_t p = 0; p < points.size(); ++p) {
        ASSERT_NEAR(theta(p, a), fresh(p, a), 1e-5) << "step " << step << " point " << p;
        leaf_differs += kept[a].leaf[p] != alone[a].leaf[p];
        ++pairs;
        EXPECT_LE(kept[a].floor[p], SignedAngleBruteForce(trees, points[p], axes[a]) + 1e-5);
      }
    }
    for (auto& a : axes) a = turn * a;
  }
  EXPECT_LE(leaf_differs, pairs / 200);  // ties within rounding only
  // A call that learnt nothing (no trees searched with hints) leaves no stale hints behind.
  OccluderCones::AngleHints nothing;
  std::vector<OccluderCones::AngleHints*> one_axis = {&kept[0], &kept[1]};
  SplitHints(nothing, one_axis);
  EXPECT_TRUE(kept[0].axes.empty() && kept[1].leaf.empty());
}

TEST(Ssdf, JoinedHintsArePointMajorAndSplitBackUnchanged) {
  // Enough points x axes for the copies to run on the threads.
  const size_t points = 9000;
  std::vector<OccluderCones::AngleHints> one(3);
  for (size_t a = 0; a < one.size(); ++a) {
    if (a == 1) continue;  // a lobe without hints joins as a fresh column
    one[a].axes = {Eigen::Vector3d(0.1 * a, 0.2, 1).normalized()};
    for (size_t p = 0; p < points; ++p) {
      one[a].leaf.push_back(static_cast<uint32_t>(7 * p + a));
      one[a].floor.push_back(0.001f * static_cast<float>(p) - static_cast<float>(a));
      one[a].rival.push_back(0.002f * static_cast<float>(p) + static_cast<float>(a));
    }
  }
  std::vector<OccluderCones::AngleHints*> ptrs = {&one[0], &one[1], &one[2]};
  const OccluderCones::AngleHints joined = JoinHints(ptrs, points);
  ASSERT_EQ(joined.leaf.size(), points * 3);
  for (size_t p = 0; p < points; ++p) {
    EXPECT_EQ(joined.leaf[p * 3 + 0], one[0].leaf[p]);
    EXPECT_EQ(joined.leaf[p * 3 + 1], OccluderCones::kNoLeaf);
    EXPECT_EQ(joined.floor[p * 3 + 2], one[2].floor[p]);
    EXPECT_EQ(joined.rival[p * 3 + 2], one[2].rival[p]);
  }
  const std::vector<OccluderCones::AngleHints> before = one;
  SplitHints(joined, ptrs);
  EXPECT_EQ(one[0].leaf, before[0].leaf);
  EXPECT_EQ(one[2].floor, before[2].floor);
  EXPECT_EQ(one[2].rival, before[2].rival);
  ASSERT_EQ(one[1].leaf.size(), points);  // the fresh column comes back as one
  EXPECT_EQ(one[1].leaf[points - 1], OccluderCones::kNoLeaf);
}

TEST(Ssdf, BatchPrecisionNearTouchingSphere) {
  // A sphere resting on the plane: points close to the contact point are where
  // asin(r/d) is ill-conditioned; the float path must keep ~1e-5 there too.
  SphereTree t;
  t.levels = 1;
  t.branching = 8;
  t.nodes = {{Eigen::Vector3d(0, 0, 1), 1.0}};
  std::vector<Eigen::Vector3d> points;
  for (double e : {1e-7, 1e-5, 1e-3, 1e-1}) points.emplace_back(std::sqrt(e), 0, 0);
  const std::vector<Eigen::Vector3d> axes = {Eigen::Vector3d::UnitZ(), Eigen::Vector3d(1, 0, 1).normalized(),
                                             Eigen::Vector3d(-1, 0, 0.01).normalized()};
  Eigen::MatrixXf out;
  SignedAngles({t}, points, axes, &out);
  for (size_t p = 0; p < points.size(); ++p)
    for (size_t a = 0; a < axes.size(); ++a)
      EXPECT_NEAR(out(p, a), SignedAngleBruteForce({t}, points[p], axes[a]), 1e-5);
}

TEST(Ssdf, BuiltTreeOnAPlane) {
  // A built tree (children inside parents, so bounds are the nodes
  // themselves) of a torus standing on z = 0, seen from plane points, and a
  // second tree beside it.
  SphereTreeBuildOptions o;
  o.surface_points = 8000;
  o.medial_spheres = 2000;
  const SphereTree object = BuildSphereTree(MakeTorus(0.5, 0.2, 32, 16), o);
  Eigen::Matrix4d stand = Eigen::Matrix4d::Identity();
  stand.block<3, 3>(0, 0) = Eigen::AngleAxisd(kPi / 2, Eigen::Vector3d::UnitX()).toRotationMatrix();
  stand(2, 3) = 0.7;
  Eigen::Matrix4d beside = stand;
  beside(0, 3) = 1.5;
  beside.block<3, 3>(0, 0) *= 0.5;
  const std::vector<SphereTree> trees = {TransformSphereTree(object, stand), TransformSphereTree(object, beside)};
  std::mt19937_64 rng(4);
  std::uniform_real_distribution<double> u(-2.5, 2.5);
  std::vector<Eigen::Vector3d> points, axes;
  for (int i = 0; i < 200; ++i) points.emplace_back(u(rng), u(rng), 0.0);
  for (int i = 0; i < 40; ++i) {
    Eigen::Vector3d a = RandomUnit(rng);
    a.z() = std::abs(a.z());
    axes.push_back(a);
  }
  Eigen::MatrixXf exact, c2f;
  SignedAngles(trees, points, axes, &exact);
  SignedAngles(trees, points, axes, &c2f, SsdfSearch::kCoarseToFine);
  int c2f_exact = 0;
  for (size_t p = 0; p < points.size(); ++p)
    for (size_t a = 0; a < axes.size(); ++a) {
      const double brute = SignedAngleBruteForce(trees, points[p], axes[a]);
      ASSERT_NEAR(SignedAngleToOccluders(trees, points[p], axes[a]), brute, 1e-9);
      ASSERT_NEAR(exact(p, a), brute, 2e-5);
      EXPECT_GE(c2f(p, a), exact(p, a) - 2e-5);
      c2f_exact += c2f(p, a) == exact(p, a);
    }
  EXPECT_GT(c2f_exact, 0.5 * points.size() * axes.size());
}

}  // namespace
}  // namespace shadowsg
