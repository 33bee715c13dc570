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

namespace {

// One channel's NNLS system restricted to a subset of the lobes.
struct SubsetSystem {
  Eigen::MatrixXd h;
  Eigen::VectorXd f;
  double btb = 0;
};

SubsetSystem Restrict(const LobeNormalEquations& eq, int c, const std::vector<long>& set) {
  return {eq.gram[c](set, set), eq.atb[c](set), eq.btb[c]};
}

// The squared error of one channel's NNLS solution on the subset without
// member t, from the solution x on the whole subset and, where x_t > 0, the
// inverse of the Gram matrix of x's passive (positive) members: x_t at zero
// changes nothing; else the passive members' least-squares solution without
// t is x_P - inv(:, t) x_t / inv(t, t) and the error rises by x_t^2 / inv(t, t).
// That is the NNLS solution wherever it stays positive and no member at zero
// then pulls the wrong way (the KKT conditions, to SolveNnls's tolerance);
// elsewhere NNLS solves the subset without t again, started from the
// passive members.
class DropOneErrors {
 public:
  explicit DropOneErrors(const SubsetSystem& s) : s_(s), x_(SolveNnls(s.h, s.f)) {
    error_ = SquaredError(s.h, s.f, s.btb, x_);
    for (long i = 0; i < x_.size(); ++i)
      if (x_[i] > 0) slot_.push_back(i);
    const long p = static_cast<long>(slot_.size());
    const Eigen::LLT<Eigen::MatrixXd> llt(s.h(slot_, slot_));
    if (llt.info() == Eigen::Success) inverse_ = llt.solve(Eigen::MatrixXd::Identity(p, p));
    inverse_ok_ = llt.info() == Eigen::Success && inverse_.allFinite();
  }

  const Eigen::VectorXd& x() const { return x_; }

  double Without(long t) const {
    if (!(x_[t] > 0)) return error_;
    if (inverse_ok_) {
      const long k = std::find(slot_.begin(), slot_.end(), t) - slot_.begin();
      const double d = inverse_(k, k);
      if (d > 0) {
        const Eigen::VectorXd z = x_(slot_) - inverse_.col(k) * (x_[t] / d);
        bool ok = true;
        for (long i = 0; i < z.size() && ok; ++i) ok = i == k || z[i] > 0;
        if (ok && KktHolds(t, k, z)) return error_ + x_[t] * x_[t] / d;
      }
    }
    // Solved again, from the passive members without t.
    const long m = x_.size();
    std::vector<long> rest;
    for (long i = 0; i < m; ++i)
      if (i != t) rest.push_back(i);
    std::vector<int> start;
    for (long i : slot_)
      if (i != t) start.push_back(static_cast<int>(i < t ? i : i - 1));
    const Eigen::MatrixXd h = s_.h(rest, rest);
    const Eigen::VectorXd f = s_.f(rest);
    return SquaredError(h, f, s_.btb, SolveNnls(h, f, start));
  }

 private:
  // No member at zero (other than t) whose gradient, scaled as SolveNnls
  // scales it, exceeds SolveNnls's tolerance at z (z(k) is t's, zero).
  bool KktHolds(long t, long k, const Eigen::VectorXd& z) const {
    const long m = x_.size();
    double fmax = 0;
    for (long j = 0; j < m; ++j)
      if (j != t && s_.h(j, j) > 0) fmax = std::max(fmax, std::abs(s_.f[j]) / std::sqrt(s_.h(j, j)));
    const double tol = NnlsOptions{}.tolerance * fmax;
    for (long j = 0; j < m; ++j) {
      if (j == t || x_[j] > 0 || !(s_.h(j, j) > 0)) continue;
      double w = s_.f[j];
      for (size_t i = 0; i < slot_.size(); ++i)
        if (static_cast<long>(i) != k) w -= s_.h(j, slot_[i]) * z[static_cast<long>(i)];
      if (w / std::sqrt(s_.h(j, j)) > tol) return false;
    }
    return true;
  }

  const SubsetSystem& s_;
  Eigen::VectorXd x_;
  double error_ = 0;
  std::vector<long> slot_;  // the passive members' positions in the subset
  Eigen::MatrixXd inverse_;
  bool inverse_ok_ = false;
};

}  // namespace

std::vector<long> EliminationOrder(const LobeNormalEquations& eq) {
  const long n = eq.atb[0].size();
  // Each round drops the member whose removal raises the error least. Those
  // at zero amplitude in every channel raise it by nothing, and the others'
  // solution stays optimal without them: they all go at once (in input
  // order). The others' errors without each member come from one NNLS
  // solve and one inverse a channel (DropOneErrors), shared by the threads
  // where a member's removal needs a solve; a solve from scratch for every
  // member took 5.5x as long on 240 candidates (BM_EliminationOrder:
  // 509 -> 93 ms), with the same order.
  std::vector<long> set(n);
  std::iota(set.begin(), set.end(), 0);
  std::vector<long> dropped;
  while (!set.empty()) {
    const long m = static_cast<long>(set.size());
    std::array<SubsetSystem, 3> sys;
    for (int c = 0; c < 3; ++c) sys[c] = Restrict(eq, c, set);
    const DropOneErrors channel[3] = {DropOneErrors(sys[0]), DropOneErrors(sys[1]), DropOneErrors(sys[2])};
    std::vector<char> active(static_cast<size_t>(m), 0);
    for (int c = 0; c < 3; ++c)
      for (long i = 0; i < m; ++i) active[static_cast<size_t>(i)] |= channel[c].x()[i] > 0;
    if (std::find(active.begin(), active.end(), 0) != active.end()) {
      std::vector<long> kept;
      for (size_t t = 0; t < set.size(); ++t) (active[t] ? kept : dropped).push_back(set[t]);
      set = std::move(kept);
      continue;
    }
    std::vector<double> error(static_cast<size_t>(m));
#pragma omp parallel for schedule(dynamic, 1) if (m > 8 && !omp_in_parallel())
    for (long t = 0; t < m; ++t)
      error[static_cast<size_t>(t)] = channel[0].Without(t) + channel[1].Without(t) + channel[2].Without(t);
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
