#include "solver/sg_lobe_system.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include <omp.h>

#include "calib/error.h"
#include "solver/nnls.h"
#include "solver/row_parallel_product.h"

namespace shadowsg {

double SquaredError(const Eigen::MatrixXd& gram, const Eigen::VectorXd& atb, double btb, const Eigen::VectorXd& x) {
  return btb - 2 * x.dot(atb) + x.dot(gram * x);
}

LobeNormalEquations BuildLobeNormalEquations(const ShadowPlaneModel& model, const std::vector<double>& weight,
                                             const std::vector<Eigen::Vector3f>& targets,
                                             const std::vector<SgLobe>& lobes,
                                             std::vector<OccluderCones::AngleHints>* hints,
                                             const std::array<Eigen::MatrixXf, 3>* bounce_irradiance) {
  const long np = static_cast<long>(model.points.size());
  std::vector<Eigen::Vector3d> axes;
  std::vector<double> sharpness;
  SplitLobes(lobes, &axes, &sharpness);
  // One batch of shading columns (as the dictionary's), not a render a lobe.
  const LobeShadingColumns shading = LobeColumns(model, axes, sharpness, hints, bounce_irradiance);
  LobeNormalEquations eq;
  for (int c = 0; c < 3; ++c) {
    Eigen::VectorXd b(np);
    for (long k = 0; k < np; ++k) b[k] = std::sqrt(weight[k]) * targets[k][c];
    const Eigen::MatrixXd a = shading.Weighted(model, weight, c);
    eq.gram[c] = ColumnParallelTransposeProduct<double>(a, a);
    eq.atb[c] = a.transpose() * b;
    eq.btb[c] = b.squaredNorm();
  }
  for (double w : weight) eq.weight_sum += w;
  return eq;
}

void ResolveAmplitudes(const ShadowPlaneModel& model, const std::vector<double>& weight,
                       const std::vector<Eigen::Vector3f>& targets, SgLighting* lighting,
                       std::vector<OccluderCones::AngleHints>* hints) {
  if (lighting->lobes.empty()) return;
  const LobeNormalEquations eq = BuildLobeNormalEquations(model, weight, targets, lighting->lobes, hints);
  for (int c = 0; c < 3; ++c) {
    const Eigen::VectorXd a = SolveNnls(eq.gram[c], eq.atb[c]);
    for (size_t i = 0; i < lighting->lobes.size(); ++i) lighting->lobes[i].amplitude[c] = a[static_cast<long>(i)];
  }
}

std::vector<long> EliminationOrder(const LobeNormalEquations& eq) {
  const long n = eq.atb[0].size();
  // Fit error of a subset, amplitudes by NNLS per channel; `active` (if not
  // null) gets whether each member is lit (> 0) in some channel.
  auto subset_error = [&](const std::vector<long>& set, std::vector<char>* active) {
    const long m = static_cast<long>(set.size());
    if (active) active->assign(m, 0);
    double e = 0;
    for (int c = 0; c < 3; ++c) {
      Eigen::MatrixXd h(m, m);
      Eigen::VectorXd f(m);
      for (long i = 0; i < m; ++i) {
        f[i] = eq.atb[c][set[i]];
        for (long j = 0; j < m; ++j) h(i, j) = eq.gram[c](set[i], set[j]);
      }
      const Eigen::VectorXd x = SolveNnls(h, f);
      e += SquaredError(h, f, eq.btb[c], x);
      if (active)
        for (long i = 0; i < m; ++i) (*active)[i] |= x[i] > 0;
    }
    return e;
  };
  // Each round drops the member whose removal raises the error least. Those
  // at zero amplitude in every channel raise it by nothing, and the others'
  // solution stays optimal without them: they all go at once (in input
  // order), without the other members' solves. The candidates of a round are
  // independent solves, shared by the threads (the pool's sharpness copies
  // make a few hundred members).
  std::vector<long> set(n);
  std::iota(set.begin(), set.end(), 0);
  std::vector<long> dropped;
  while (!set.empty()) {
    std::vector<char> active;
    subset_error(set, &active);
    if (std::find(active.begin(), active.end(), 0) != active.end()) {
      std::vector<long> kept;
      for (size_t t = 0; t < set.size(); ++t) (active[t] ? kept : dropped).push_back(set[t]);
      set = std::move(kept);
      continue;
    }
    const long m = static_cast<long>(set.size());
    std::vector<double> error(static_cast<size_t>(m));
#pragma omp parallel for schedule(dynamic, 1) if (m > 8 && !omp_in_parallel())
    for (long t = 0; t < m; ++t) {
      std::vector<long> rest = set;
      rest.erase(rest.begin() + t);
      error[static_cast<size_t>(t)] = subset_error(rest, nullptr);
    }
    const long drop = std::min_element(error.begin(), error.end()) - error.begin();
    dropped.push_back(set[drop]);
    set.erase(set.begin() + drop);
  }
  return std::vector<long>(dropped.rbegin(), dropped.rend());
}

std::vector<SgLobe> OrderByElimination(const ShadowPlaneModel& model, const std::vector<double>& weight,
                                       const std::vector<Eigen::Vector3f>& targets, const std::vector<SgLobe>& lobes) {
  SHADOWSG_CHECK(weight.size() == model.points.size() && targets.size() == model.points.size());
  if (lobes.size() < 2) return lobes;
  std::vector<SgLobe> ordered;
  for (long i : EliminationOrder(BuildLobeNormalEquations(model, weight, targets, lobes))) ordered.push_back(lobes[i]);
  return ordered;
}

}  // namespace shadowsg
