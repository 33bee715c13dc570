// The least-squares problem of the `sg` solver's Levenberg-Marquardt
// refinement (solver/sg_solver.h), as one Ceres cost: one residual block over
// every point of a shadow-plane model and channel,
//
//   r(k, c) = sqrt(w_k) (rho_kc/pi sum_i a_ic (S_i(x_k) + B_ic(x_k)) - target_kc),
//
// with parameter blocks per lobe: axis (3, a free vector, normalised here;
// callers put it on ceres::SphereManifold), log-sharpness (1), amplitude (3).
// S is the direct shading under the model's visibility (sphere-tree sigmoid
// or exact), B the casters' bounce when the model has it.
//
// Jacobians are analytic for the direct part. The bounce carries its
// amplitude part and, with bounce_sharpness, its sharpness part by a forward
// difference: at a fixed amplitude a lobe's bounce falls with sharpness (its
// power goes as 1/lambda), and without that column LM mispredicts every step
// that sharpens a sun whose bounce is large (pub_torus_sunsky, exact
// visibility: the sun stalled at lambda 131 and 36.0 dB; with it 1894 and
// 41.9). The solver asks for it with exact visibility only: with the
// sphere-tree sigmoid it changed no median by more than 0.2 dB (fast, 10
// seeds, three scenes with the bounce) for more time (median solve 5.0 ->
// 5.8 s on pub_torus_sunrise, 5.1 -> 6.7 on interior). The
// bounce's axis part is left out: a forward difference of it lowered the
// median by 0.2-0.9 dB (fast, 3 seeds, pub_torus_sunrise and interior).
//
// What a lobe costs to shade (its visibility angles or exact lobe, its
// cosine integral, its bounce) is kept per lobe while its axis and sharpness
// stay the same: the Jacobian after an accepted step reuses the step's
// evaluation (a lobe whose block a caller holds constant would be shaded once).
#pragma once

#include <ceres/ceres.h>

#include <Eigen/Dense>
#include <array>
#include <vector>

#include "solver/exact_visibility.h"
#include "solver/shadow_plane.h"
#include "solver/sg_shading.h"

namespace shadowsg {

class RefineCost final : public ceres::CostFunction {
 public:
  // Residuals over every point of `model`; targets in the same order.
  RefineCost(const ShadowPlaneModel& model, const std::vector<double>& weight,
             const std::vector<Eigen::Vector3f>& targets, int lobes, bool bounce_sharpness);

  bool Evaluate(double const* const* params, double* residuals, double** jacobians) const override;

  // A lobe's visibility search hints (OccluderCones::AngleHints, one axis),
  // before the first evaluation (from an earlier fit of the same lobe over
  // the same points) and after the last (for the next).
  void SetHints(int lobe, OccluderCones::AngleHints hints);
  const OccluderCones::AngleHints& Hints(int lobe) const;

 private:
  struct LobeCache {
    Eigen::Vector3d axis = Eigen::Vector3d::Zero();
    double lambda = -1;  // never a valid sharpness: nothing cached yet
    ProductLobe product;
    bool product_derivatives = false;  // residual-only evaluations skip the exact integral's
    ExactVisibility::Lobe exact;
    Eigen::VectorXf theta;                  // sphere-tree visibility, per point
    std::vector<Eigen::Vector3f> witness;   // and its witness direction
    OccluderCones::AngleHints hints;        // what the last search learnt, for the next (one axis)
    std::array<Eigen::VectorXf, 3> bounce;  // per channel, per point
    std::array<Eigen::VectorXf, 3> dbounce; // d bounce / d log sharpness (empty until asked for)
  };
  // Brings cache_ up to date for these parameters (Evaluate runs on one
  // thread: RefineLobes sets num_threads = 1 and parallelises inside).
  void Update(const std::vector<Eigen::Vector3d>& axes, const std::vector<double>& lambda, bool derivatives,
              bool need_dbounce) const;

  const ShadowPlaneModel& model_;
  const std::vector<Eigen::Vector3f>& targets_;
  std::vector<double> sqrt_w_;
  int lobes_;
  bool bounce_sharpness_;
  mutable std::vector<LobeCache> cache_;
};

}  // namespace shadowsg
