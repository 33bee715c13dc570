// Non-negative least squares, min |A x - b|^2 subject to x >= 0, by the
// active-set algorithm of Lawson & Hanson ("Solving Least Squares Problems",
// 1974, ch. 23) in the cross-product form of Bro & de Jong ("A fast
// non-negativity-constrained least squares algorithm", J. Chemometrics 11,
// 1997): it needs only H = A^T A and f = A^T b, so one Gram matrix serves any
// number of right-hand sides and any number of rows.
//
// Eigen 3.4.0 (Debian 12) does not ship unsupported/Eigen/NNLS (it arrived
// after 3.4.0), hence this implementation. The passive-set system is solved by
// a Cholesky factor that is extended by one column when a variable enters and
// downdated by Givens rotations when one leaves: O(p^2) per step.
#pragma once

#include <Eigen/Dense>
#include <vector>

namespace shadowsg {

struct NnlsOptions {
  // Outer iterations (variables entering the passive set); 0 = 3 * n, as scipy.
  int max_iterations = 0;
  // KKT tolerance relative to max |f_j| / sqrt(H_jj): a variable at zero with
  // gradient -(f - H x)_j scaled the same way below -tolerance enters.
  double tolerance = 1e-10;
};

struct NnlsSummary {
  int iterations = 0;
  bool converged = false;   // false: max_iterations reached
  int passive = 0;          // variables > 0 at the solution
  int dependent = 0;        // variables left at 0 because their column is
                            // numerically dependent on the passive ones
};

// H symmetric positive semi-definite (n x n), f of size n.
Eigen::VectorXd SolveNnls(const Eigen::MatrixXd& gram, const Eigen::VectorXd& atb,
                          const NnlsOptions& options = {}, NnlsSummary* summary = nullptr);

// The same from a guess of the passive set (indices, e.g. a nearby
// problem's): the guess's least-squares solution, its non-positive members
// dropped (the last first) until it is positive, starts the iteration. Same
// optimum; far fewer steps when the guess is close.
Eigen::VectorXd SolveNnls(const Eigen::MatrixXd& gram, const Eigen::VectorXd& atb, const std::vector<int>& start,
                          const NnlsOptions& options = {}, NnlsSummary* summary = nullptr);

}  // namespace shadowsg
