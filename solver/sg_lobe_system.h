// SG lobe amplitudes by least squares for fixed axes and sharpness (the
// shading is linear in them): the system, NNLS on it, and the order of
// backward elimination that the `sg` solver's size path and pool follow
// (solver/sg_solver.h).
#pragma once

#include <array>
#include <vector>

#include <Eigen/Dense>

#include "solver/sg.h"
#include "solver/shadow_plane.h"

namespace shadowsg {

// The per-channel least-squares system of lobe amplitudes for fixed axes and
// sharpness over the points of `model`: gram = A^T A, atb = A^T b, btb = b^T b,
// A(k, i) = sqrt(w_k) rho_kc/pi (direct + bounce shading of lobe i at k),
// b(k) = sqrt(w_k) target_kc. NNLS on it gives the amplitudes of any subset.
// Systems of the same lobes over disjoint or repeated points add up.
struct LobeNormalEquations {
  std::array<Eigen::MatrixXd, 3> gram;
  std::array<Eigen::VectorXd, 3> atb;
  std::array<double, 3> btb{};
  double weight_sum = 0;  // sum of w_k: the weighted MSE is the squared error / (3 weight_sum)

  void Add(const LobeNormalEquations& other) {
    for (int c = 0; c < 3; ++c) {
      gram[c] = gram[c].size() ? Eigen::MatrixXd(gram[c] + other.gram[c]) : other.gram[c];
      atb[c] = atb[c].size() ? Eigen::VectorXd(atb[c] + other.atb[c]) : other.atb[c];
      btb[c] += other.btb[c];
    }
    weight_sum += other.weight_sum;
  }
};

// |A x - b|^2 of one channel from its system: b^T b - 2 x^T A^T b + x^T A^T A x.
double SquaredError(const Eigen::MatrixXd& gram, const Eigen::VectorXd& atb, double btb, const Eigen::VectorXd& x);

// The system of `lobes` over the points of `model` (hints: as LobeColumns;
// bounce_irradiance: the lobes' BounceIrradiance where the caller has it).
LobeNormalEquations BuildLobeNormalEquations(const ShadowPlaneModel& model, const std::vector<double>& weight,
                                             const std::vector<Eigen::Vector3f>& targets,
                                             const std::vector<SgLobe>& lobes,
                                             std::vector<OccluderCones::AngleHints>* hints = nullptr,
                                             const std::array<Eigen::MatrixXf, 3>* bounce_irradiance = nullptr);

// Amplitudes of every lobe of *lighting re-solved by NNLS per channel for
// its axes and sharpness: the start of LM is then no worse than the model
// without the newest lobe.
void ResolveAmplitudes(const ShadowPlaneModel& model, const std::vector<double>& weight,
                       const std::vector<Eigen::Vector3f>& targets, SgLighting* lighting,
                       std::vector<OccluderCones::AngleHints>* hints);

// The reverse order of backward elimination (OrderByElimination) on the
// system of all the lobes: indices, the lobe kept last first.
std::vector<long> EliminationOrder(const LobeNormalEquations& eq);

// The order in which the size path adds the merged lobes: the reverse of
// backward elimination on the model's points. Starting from all of them, the
// lobe whose removal raises the weighted fit error least (every other
// amplitude re-solved by NNLS per channel; weight: one per point) goes, and
// so on; the lobe left last comes first. So the path's first k lobes are the
// k that elimination keeps, and a lobe needed for a shadow comes early even
// when it lights the plane little: the low sun of pub_torus_sunrise lights it
// at 4 degrees and was twelfth by its share of the image. Fast, 10 seeds,
// 2 threads, against the share order (solver/EXPERIMENTS.md): sunrise 37.80 (36.91-38.34) ->
// 39.12 (37.39-39.63) dB median (range), interior 34.25 (33.74-34.58) ->
// 34.22 (33.88-34.33), sunsky and the cone scene level.
std::vector<SgLobe> OrderByElimination(const ShadowPlaneModel& model, const std::vector<double>& weight,
                                       const std::vector<Eigen::Vector3f>& targets, const std::vector<SgLobe>& lobes);

}  // namespace shadowsg
