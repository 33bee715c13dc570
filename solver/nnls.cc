#include "solver/nnls.h"

#include <cmath>
#include <limits>
#include <vector>

#include "calib/error.h"

namespace shadowsg {

namespace {

// A column whose squared distance from the span of the passive columns (all
// scaled to unit norm) is below this is treated as dependent: its Cholesky
// pivot would carry no significant digits (double precision, Gram form).
constexpr double kDependentPivot = 1e-11;

enum State : char { kAtZero = 0, kPassive = 1, kExcluded = 2 };

// Cholesky factor L (lower) of H restricted to an ordered passive set.
class PassiveFactor {
 public:
  PassiveFactor(const Eigen::MatrixXd& h) : h_(h), l_(h.rows(), h.rows()) {}

  const std::vector<int>& set() const { return set_; }
  int size() const { return static_cast<int>(set_.size()); }

  // Appends variable t; false (and no change) when its column is dependent.
  bool Append(int t) {
    const int p = size();
    Eigen::VectorXd r(p);
    for (int k = 0; k < p; ++k) r[k] = h_(set_[k], t);
    l_.topLeftCorner(p, p).triangularView<Eigen::Lower>().solveInPlace(r);
    const double d2 = h_(t, t) - r.squaredNorm();
    if (!(d2 > kDependentPivot)) return false;
    l_.row(p).head(p) = r.transpose();
    l_(p, p) = std::sqrt(d2);
    set_.push_back(t);
    return true;
  }

  // Removes the variable at position k: delete row k of L, then restore the
  // triangle with Givens rotations on column pairs (L L^T is unchanged by them).
  void Remove(int k) {
    const int p = size();
    for (int i = k; i < p - 1; ++i) l_.row(i).head(p) = l_.row(i + 1).head(p);
    for (int i = k; i < p - 1; ++i) {
      const double a = l_(i, i), b = l_(i, i + 1);
      const double r = std::hypot(a, b);
      if (r == 0) continue;
      const double c = a / r, s = b / r;
      for (int row = i; row < p - 1; ++row) {
        const double li = l_(row, i), lj = l_(row, i + 1);
        l_(row, i) = c * li + s * lj;
        l_(row, i + 1) = -s * li + c * lj;
      }
    }
    set_.erase(set_.begin() + k);
  }

  // z = H_PP^-1 f_P.
  Eigen::VectorXd Solve(const Eigen::VectorXd& f) const {
    const int p = size();
    Eigen::VectorXd z(p);
    for (int k = 0; k < p; ++k) z[k] = f[set_[k]];
    const auto lpp = l_.topLeftCorner(p, p);
    lpp.triangularView<Eigen::Lower>().solveInPlace(z);
    lpp.transpose().triangularView<Eigen::Upper>().solveInPlace(z);
    return z;
  }

 private:
  const Eigen::MatrixXd& h_;
  Eigen::MatrixXd l_;
  std::vector<int> set_;
};

}  // namespace

Eigen::VectorXd SolveNnls(const Eigen::MatrixXd& gram, const Eigen::VectorXd& atb, const NnlsOptions& options,
                          NnlsSummary* summary) {
  return SolveNnls(gram, atb, {}, options, summary);
}

Eigen::VectorXd SolveNnls(const Eigen::MatrixXd& gram, const Eigen::VectorXd& atb, const std::vector<int>& start,
                          const NnlsOptions& options, NnlsSummary* summary) {
  const int n = static_cast<int>(gram.rows());
  SHADOWSG_CHECK(gram.cols() == n && atb.size() == n);
  NnlsSummary local;
  NnlsSummary& s = summary ? *summary : local;
  s = NnlsSummary{};

  // Scale the columns of A to unit norm: x >= 0 is invariant under a positive
  // diagonal scaling, and the tolerances become relative.
  Eigen::VectorXd scale(n);
  std::vector<char> state(n, kAtZero);
  for (int j = 0; j < n; ++j) {
    scale[j] = gram(j, j) > 0 ? 1 / std::sqrt(gram(j, j)) : 0.0;
    if (scale[j] == 0) state[j] = kExcluded;
  }
  const Eigen::MatrixXd h = scale.asDiagonal() * gram * scale.asDiagonal();
  const Eigen::VectorXd f = scale.cwiseProduct(atb);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(n);
  const double fmax = n > 0 ? f.cwiseAbs().maxCoeff() : 0.0;
  if (!(fmax > 0)) {
    s.converged = true;
    return x;
  }
  const double tol = options.tolerance * fmax;
  const int max_iterations = options.max_iterations > 0 ? options.max_iterations : 3 * n;

  PassiveFactor factor(h);
  // The guess's passive set (none for a cold start), cut down until its
  // least-squares solution is positive: a feasible start.
  for (int j : start) {
    SHADOWSG_CHECK(j >= 0 && j < n);
    if (state[j] != kAtZero) continue;
    if (factor.Append(j)) {
      state[j] = kPassive;
    } else {
      state[j] = kExcluded;
      ++s.dependent;
    }
  }
  while (factor.size() > 0) {
    const Eigen::VectorXd z = factor.Solve(f);
    int k = factor.size() - 1;
    while (k >= 0 && z[k] > 0) --k;
    if (k < 0) {
      for (int i = 0; i < factor.size(); ++i) x[factor.set()[i]] = z[i];
      break;
    }
    state[factor.set()[k]] = kAtZero;
    factor.Remove(k);
  }
  Eigen::VectorXd w(n);
  while (true) {
    w = f;
    for (int j : factor.set()) w.noalias() -= h.col(j) * x[j];
    int t = -1;
    double best = tol;
    for (int j = 0; j < n; ++j)
      if (state[j] == kAtZero && w[j] > best) best = w[t = j];
    if (t < 0) {
      s.converged = true;
      break;
    }
    if (s.iterations >= max_iterations) break;
    ++s.iterations;
    if (!factor.Append(t)) {
      state[t] = kExcluded;
      ++s.dependent;
      continue;
    }
    state[t] = kPassive;
    Eigen::VectorXd z = factor.Solve(f);
    if (!(z[factor.size() - 1] > 0)) {
      // In exact arithmetic the entering variable rises; if round-off says
      // otherwise it would re-enter forever.
      factor.Remove(factor.size() - 1);
      state[t] = kExcluded;
      ++s.dependent;
      continue;
    }
    while (true) {
      const std::vector<int>& set = factor.set();
      const int p = factor.size();
      if (z.minCoeff() > 0) {
        for (int k = 0; k < p; ++k) x[set[k]] = z[k];
        break;
      }
      // Step from x towards z until the first passive variable hits zero.
      double alpha = std::numeric_limits<double>::infinity();
      int hit = -1;
      for (int k = 0; k < p; ++k)
        if (z[k] <= 0) {
          const double xk = x[set[k]];
          const double a = xk / (xk - z[k]);
          if (a < alpha) alpha = a, hit = k;
        }
      for (int k = 0; k < p; ++k) x[set[k]] += alpha * (z[k] - x[set[k]]);
      x[set[hit]] = 0;
      for (int k = p - 1; k >= 0; --k) {
        const int j = factor.set()[k];
        if (x[j] <= 0) {
          x[j] = 0;
          state[j] = kAtZero;
          factor.Remove(k);
        }
      }
      if (factor.size() == 0) break;
      z = factor.Solve(f);
    }
  }
  for (int j = 0; j < n; ++j) s.passive += x[j] > 0;
  return scale.cwiseProduct(x);
}

}  // namespace shadowsg
