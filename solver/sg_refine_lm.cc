#include "solver/sg_refine_lm.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "calib/error.h"
#include "solver/side_by_side.h"

namespace shadowsg {
namespace {

// Ceres' bounds on the scaled Levenberg-Marquardt diagonal.
constexpr double kMinDiagonal = 1e-6, kMaxDiagonal = 1e32;
constexpr double kMaxRadius = 1e16, kMinRadius = 1e-32;
constexpr double kMinRelativeDecrease = 1e-3;
constexpr double kProbeMargin = 1e-3;

struct NormalEquations {
  Eigen::MatrixXd H;  // J'J, unknowns ordered: geometry (3 a lobe), then amplitudes channel by channel
  Eigen::VectorXd g;  // J'r
};

// J'J and J'r from the per-channel blocks. The points are cut into
// kFormShares fixed shares whatever the thread count, and the shares' sums
// are added in order, so the normal equations round the same on any number
// of threads (with shares per thread, one seed's lobes differed between one,
// two and three threads).
constexpr long kFormShares = 16;

NormalEquations Form(const RefineJacobian& J, const Eigen::MatrixX3d& r, int L) {
  const long np = r.rows(), m = 4L * L, n = 6L * L, geo = 3L * L;
  std::vector<Eigen::MatrixXd> share_h(kFormShares);
  std::vector<Eigen::VectorXd> share_g(kFormShares);
#pragma omp parallel
  {
    Eigen::MatrixXd Hc(m, m);
#pragma omp for schedule(static)
    for (long t = 0; t < kFormShares; ++t) {
      const long begin = np * t / kFormShares, end = np * (t + 1) / kFormShares;
      Eigen::MatrixXd& H = share_h[t];
      Eigen::VectorXd& g = share_g[t];
      H.setZero(n, n);
      g.setZero(n);
      for (int c = 0; c < 3 && end > begin; ++c) {
        const auto rows = J.channel[c].middleRows(begin, end - begin);
        Hc.setZero();
        Hc.selfadjointView<Eigen::Lower>().rankUpdate(rows.transpose());
        const Eigen::VectorXd gc = rows.transpose() * r.col(c).segment(begin, end - begin);
        // Lower triangles only: geometry x geometry is shared by the channels,
        // each channel's amplitudes meet the geometry and themselves.
        const long amp = geo + c * L;
        H.topLeftCorner(geo, geo) += Hc.topLeftCorner(geo, geo);
        H.block(amp, 0, L, geo) += Hc.block(geo, 0, L, geo);
        H.block(amp, amp, L, L) += Hc.bottomRightCorner(L, L);
        g.head(geo) += gc.head(geo);
        g.segment(amp, L) += gc.tail(L);
      }
    }
  }
  NormalEquations ne{std::move(share_h[0]), std::move(share_g[0])};
  for (long t = 1; t < kFormShares; ++t) {
    ne.H += share_h[t];
    ne.g += share_g[t];
  }
  ne.H = Eigen::MatrixXd(ne.H.selfadjointView<Eigen::Lower>());
  return ne;
}

double Cost(const Eigen::MatrixX3d& r) { return 0.5 * r.squaredNorm(); }

// Norm of the parameters as Ceres sees them (axis, log-sharpness, amplitude).
double ParameterNorm(const std::vector<SgLobe>& lobes) {
  double s = 0;
  for (const SgLobe& l : lobes) s += 1 + std::pow(std::log(l.sharpness), 2) + l.amplitude.squaredNorm();
  return std::sqrt(s);
}

// lobes + step, projected onto the bounds (Ceres' ParameterBlock::Plus);
// *taken gets the step actually made, for the parameter tolerance.
std::vector<SgLobe> Move(const std::vector<SgLobe>& lobes, const Eigen::VectorXd& step, const RefineLmOptions& o,
                         Eigen::VectorXd* taken) {
  const long L = static_cast<long>(lobes.size()), geo = 3 * L;
  std::vector<SgLobe> out = lobes;
  taken->resize(step.size());
  const double lo = std::log(o.min_sharpness), hi = std::log(o.max_sharpness);
  for (long j = 0; j < L; ++j) {
    const SgLobe& l = lobes[j];
    out[j].axis = TurnAxis(l.axis, step[3 * j], step[3 * j + 1]);
    (*taken)[3 * j] = step[3 * j];
    (*taken)[3 * j + 1] = step[3 * j + 1];
    const double log_lambda = std::log(l.sharpness);
    const double moved = std::clamp(log_lambda + step[3 * j + 2], lo, hi);
    out[j].sharpness = std::exp(moved);
    (*taken)[3 * j + 2] = moved - log_lambda;
    for (int c = 0; c < 3; ++c) {
      const long i = geo + c * L + j;
      out[j].amplitude[c] = std::max(0.0, l.amplitude[c] + step[i]);
      (*taken)[i] = out[j].amplitude[c] - l.amplitude[c];
    }
  }
  return out;
}

}  // namespace

RefineLmSummary RefineByLm(const RefineCost& cost, std::vector<SgLobe>* lobes, const RefineLmOptions& o,
                           const std::function<void(int, double)>& on_iteration) {
  SHADOWSG_CHECK(static_cast<int>(lobes->size()) == cost.lobes());
  const int L = cost.lobes();
  RefineLmSummary sum;
  sum.radius = o.initial_radius;
  if (L == 0 || o.max_iterations <= 0) return sum;
  Eigen::MatrixX3d r, r_new;
  RefineJacobian J;
  cost.Evaluate(*lobes, &r, &J);
  double f = Cost(r);
  sum.initial_cost = sum.final_cost = f;
  if (!std::isfinite(f)) return sum;
  NormalEquations ne = Form(J, r, L);
  // Ceres' Jacobi scaling, 1 / (1 + column norm), is set at the start and kept.
  const Eigen::VectorXd scale2 = (1 + ne.H.diagonal().cwiseMax(0).array().sqrt()).square().inverse();
  double radius = o.initial_radius, decrease_factor = 2;
  const long n = 6L * L;
  Eigen::VectorXd taken;
  while (sum.iterations < o.max_iterations) {
    ++sum.iterations;
    TakeLentThreads();  // a restart beside others takes the threads of those done
    // Ceres' Jacobi-scaled damping, in the unscaled unknowns.
    Eigen::MatrixXd A = ne.H;
    for (long i = 0; i < n; ++i)
      A(i, i) += std::clamp(ne.H(i, i) * scale2[i], kMinDiagonal, kMaxDiagonal) / scale2[i] / radius;
    const Eigen::VectorXd step = A.ldlt().solve(-ne.g);
    bool ok = step.allFinite();
    double predicted = 0, f_new = f;
    std::vector<SgLobe> candidate;
    if (ok) {
      candidate = Move(*lobes, step, o, &taken);
      // The unprojected step's, as Ceres predicts it (see the header).
      predicted = -(ne.g.dot(step) + 0.5 * step.dot(ne.H * step));
      ok = predicted > 0 && std::isfinite(predicted);
    }
    if (ok) {
      // Converged (Ceres' parameter and function tolerances): the candidate is not taken.
      bool converged = taken.norm() <= o.parameter_tolerance * (ParameterNorm(*lobes) + o.parameter_tolerance);
      if (!converged) {
        // A far step shown on a sample of the points to cost more than
        // (1 + kProbeMargin) f is refused as its full evaluation would
        // refuse it (not converged either: the margin is far above the
        // function tolerance and the sample's rounding).
        if (radius >= o.probe_radius && cost.CostExceeds(candidate, (1 + kProbeMargin) * f)) {
          f_new = std::numeric_limits<double>::infinity();
          ok = false;
          ++sum.probe_refusals;
        } else {
          cost.Evaluate(candidate, &r_new, nullptr);
          f_new = Cost(r_new);
          ok = std::isfinite(f_new);
          converged = ok && std::abs(f - f_new) <= o.function_tolerance * f;
        }
      }
      if (converged) {
        if (on_iteration) on_iteration(sum.iterations, f);
        break;
      }
    }
    const double rho = ok ? (f - f_new) / predicted : -1;
    if (rho > kMinRelativeDecrease) {
      *lobes = std::move(candidate);
      f = f_new;
      ++sum.accepted;
      radius = std::min(kMaxRadius, radius / std::max(1.0 / 3.0, 1 - std::pow(2 * rho - 1, 3)));
      decrease_factor = 2;
      if (sum.iterations < o.max_iterations) {
        cost.Evaluate(*lobes, &r, &J);
        ne = Form(J, r, L);
      }
    } else {
      radius /= decrease_factor;
      decrease_factor *= 2;
    }
    if (on_iteration) on_iteration(sum.iterations, f);
    if (radius < kMinRadius) break;
  }
  sum.final_cost = f;
  sum.radius = radius;
  return sum;
}

}  // namespace shadowsg
