#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>
#include <random>

#include "solver/nnls.h"
#include "solver/sg_lobe_system.h"

namespace shadowsg {
namespace {

// Backward elimination as defined: every round, every member's removal
// solved afresh by NNLS per channel.
std::vector<long> EliminationByFreshSolves(const LobeNormalEquations& eq) {
  auto error_of = [&](const std::vector<long>& set, std::vector<char>* active) {
    const long m = static_cast<long>(set.size());
    if (active) active->assign(static_cast<size_t>(m), 0);
    double e = 0;
    for (int c = 0; c < 3; ++c) {
      const Eigen::MatrixXd h = eq.gram[c](set, set);
      const Eigen::VectorXd f = eq.atb[c](set);
      const Eigen::VectorXd x = SolveNnls(h, f);
      e += SquaredError(h, f, eq.btb[c], x);
      if (active)
        for (long i = 0; i < m; ++i) (*active)[static_cast<size_t>(i)] |= x[i] > 0;
    }
    return e;
  };
  std::vector<long> set(static_cast<size_t>(eq.atb[0].size()));
  std::iota(set.begin(), set.end(), 0);
  std::vector<long> dropped;
  while (!set.empty()) {
    std::vector<char> active;
    error_of(set, &active);
    if (std::find(active.begin(), active.end(), 0) != active.end()) {
      std::vector<long> kept;
      for (size_t t = 0; t < set.size(); ++t) (active[t] ? kept : dropped).push_back(set[t]);
      set = std::move(kept);
      continue;
    }
    std::vector<double> error;
    for (size_t t = 0; t < set.size(); ++t) {
      std::vector<long> rest = set;
      rest.erase(rest.begin() + static_cast<long>(t));
      error.push_back(error_of(rest, nullptr));
    }
    const size_t drop = static_cast<size_t>(std::min_element(error.begin(), error.end()) - error.begin());
    dropped.push_back(set[drop]);
    set.erase(set.begin() + static_cast<long>(drop));
  }
  return std::vector<long>(dropped.rbegin(), dropped.rend());
}

// Columns like lobes' shading: smooth non-negative bumps over the points,
// some nearly equal (overlapping lobes, whose removal makes a neighbour
// take over or turn negative), targets from a few of them per channel
// plus noise.
LobeNormalEquations RandomLobeSystem(uint64_t seed, long points, long lobes) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  Eigen::MatrixXd a(points, lobes);
  for (long j = 0; j < lobes; ++j) {
    const double centre = u(rng), width = 0.05 + 0.3 * u(rng);
    for (long k = 0; k < points; ++k) {
      const double d = (static_cast<double>(k) / points - centre) / width;
      a(k, j) = std::exp(-d * d) + 0.05 * u(rng);
    }
  }
  LobeNormalEquations eq;
  for (int c = 0; c < 3; ++c) {
    Eigen::VectorXd b = Eigen::VectorXd::Zero(points);
    for (long j = 0; j < lobes; j += 3) b += (0.5 + u(rng) + c * 0.2) * a.col(j);
    for (long k = 0; k < points; ++k) b[k] += 0.02 * (u(rng) - 0.5);
    eq.gram[c] = a.transpose() * a;
    eq.atb[c] = a.transpose() * b;
    eq.btb[c] = b.squaredNorm();
  }
  eq.weight_sum = static_cast<double>(points);
  return eq;
}

TEST(EliminationOrder, SameAsFreshSolvesForEveryRemoval) {
  for (uint64_t seed = 1; seed <= 12; ++seed) {
    const LobeNormalEquations eq = RandomLobeSystem(seed, 300, 10 + static_cast<long>(seed) * 3);
    const std::vector<long> order = EliminationOrder(eq);
    EXPECT_EQ(order, EliminationByFreshSolves(eq)) << "seed " << seed;
    std::vector<long> sorted = order;
    std::sort(sorted.begin(), sorted.end());
    std::vector<long> all(sorted.size());
    std::iota(all.begin(), all.end(), 0);
    EXPECT_EQ(sorted, all) << "seed " << seed;
  }
}

}  // namespace
}  // namespace shadowsg
