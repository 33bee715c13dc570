// The least-squares problem of the `sg` solver's Levenberg-Marquardt
// refinement (solver/sg_solver.h, solver/sg_refine_lm.h): residuals over every
// point k of a shadow-plane model and channel c,
//
//   r(k, c) = sqrt(w_k) (rho_kc/pi sum_i a_ic (S_i(x_k) + B_ic(x_k)) - target_kc),
//
// and their Jacobian in its structure: a lobe's axis (two tangent
// directions) and log-sharpness move every channel's residual, its amplitude
// in channel c only channel c's. S is the direct shading under the model's
// visibility (sphere-tree sigmoid or exact), B the casters' bounce when the
// model has it.
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
// evaluation (a lobe held still would be shaded once). Where the model's
// form factors are prepared, a residual-only evaluation carries the lobes'
// bounce to the points as one amplitude-weighted sum, and each lobe's own
// bounce there waits for a Jacobian.
#pragma once

#include <Eigen/Dense>
#include <array>
#include <vector>

#include "solver/exact_visibility.h"
#include "solver/sg.h"
#include "solver/shadow_plane.h"
#include "solver/sg_shading.h"

namespace shadowsg {

// An orthonormal basis of the plane orthogonal to the unit vector a: the
// two directions in which the refinement moves an axis. Basis and scale are
// Ceres' SphereManifold's: a tangent step d turns the axis by |d|/2 towards
// d_1 t_1 + d_2 t_2. Levenberg-Marquardt's damping is not rotation invariant,
// and its first, nearly Gauss-Newton steps go far along directions the error
// hardly constrains: with a cross-product basis and whole-angle steps the
// size paths of pub_torus_sunrise ended systematically worse (fast, 20 seeds:
// 15 lower, median -0.3 dB) than with Ceres, whose steps these reproduce.
std::array<Eigen::Vector3d, 2> TangentBasis(const Eigen::Vector3d& a);

// The unit axis a after the tangent step (d1, d2): along the great circle
// towards d1 t1 + d2 t2, by half the step's length.
Eigen::Vector3d TurnAxis(const Eigen::Vector3d& a, double d1, double d2);

// The Jacobian of RefineCost's residuals, one block per channel c: rows are
// points, columns 3j, 3j+1 lobe j's axis tangent steps (TangentBasis), 3j+2 its
// log-sharpness, and 3L + j its amplitude in channel c.
struct RefineJacobian {
  std::array<Eigen::MatrixXd, 3> channel;
};

class RefineCost {
 public:
  // Residuals over every point of `model`; targets in the same order.
  RefineCost(const ShadowPlaneModel& model, const std::vector<double>& weight,
             const std::vector<Eigen::Vector3f>& targets, int lobes, bool bounce_sharpness);

  int lobes() const { return lobes_; }
  long points() const { return static_cast<long>(model_.points.size()); }

  // Residuals at `lobes` (unit axes), r(k, c) in row k, column c; with
  // `jacobian`, its Jacobian too.
  void Evaluate(const std::vector<SgLobe>& lobes, Eigen::MatrixX3d* residuals, RefineJacobian* jacobian) const;

  // Whether the cost (1/2 the sum of squared residuals) at `lobes` is surely
  // above `limit`: the sum over the first points (a lower bound on it), a
  // chunk at a time, up to a quarter of them. Levenberg-Marquardt's first
  // steps of a solve go far, and most are refused at many times the cost
  // (pub_torus_sunrise: 3-38x); here they are refused after a few hundred
  // points' visibility. The lobes' bounce is computed and kept, as an
  // evaluation would; their visibility is not kept, nor its hints.
  bool CostExceeds(const std::vector<SgLobe>& lobes, double limit) const;

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
    OccluderCones::AngleHints ground_hints; // the same for the bounce's ground points
    // What the bounce below was computed for (CostExceeds computes it ahead
    // of the rest).
    Eigen::Vector3d bounce_axis = Eigen::Vector3d::Zero();
    double bounce_lambda = -1;
    // The bounce per channel: the patches' radiance in the form factors'
    // basis (FactoredFormFactors::Reduce), and at the points (per point;
    // empty until a Jacobian asks for it: a residual needs only the
    // amplitude-weighted sum over the lobes, expanded once, and most
    // evaluations are of candidate steps, half of them refused).
    std::array<Eigen::VectorXf, 3> reduced;
    std::array<Eigen::VectorXf, 3> bounce;
    std::array<Eigen::VectorXf, 3> dbounce; // d bounce / d log sharpness (empty until asked for)
  };
  // Brings cache_ up to date for these parameters (called from one thread;
  // it parallelises inside).
  void Update(const std::vector<Eigen::Vector3d>& axes, const std::vector<double>& lambda, bool derivatives,
              bool need_dbounce) const;
  // The bounce's part of Update, on its own: CostExceeds needs the bounce
  // of a step before any point's visibility.
  void UpdateBounce(const std::vector<Eigen::Vector3d>& axes, const std::vector<double>& lambda, bool derivatives,
                    bool need_dbounce) const;

  const ShadowPlaneModel& model_;
  const std::vector<Eigen::Vector3f>& targets_;
  std::vector<double> sqrt_w_;
  int lobes_;
  bool bounce_sharpness_;
  mutable std::vector<LobeCache> cache_;
};

// Search hints for `lobes` from those learnt for the lobes `from` over the
// same points (from_hints, one per lobe of `from`): each lobe takes the
// hints of the lobe of `from` nearest its axis; none where `from` has none.
// A hint bounds theta for any axis by the angle between that axis and its
// own, so another lobe's hints are sound, and the nearer it is, the more
// searches it skips (a fit's final refinement starts from its size path's).
std::vector<OccluderCones::AngleHints> NearestAxisHints(const std::vector<SgLobe>& lobes,
                                                        const std::vector<SgLobe>& from,
                                                        const std::vector<OccluderCones::AngleHints>& from_hints);

}  // namespace shadowsg
