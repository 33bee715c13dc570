// The pool of the `sg` solver's finished fits (solver/sg_solver.h, step 7):
// their lobes together with copies at other sharpness values and a sky
// basis, in the order of backward elimination, amplitudes by NNLS, the
// leading set chosen on held-out points.
#pragma once

#include <array>
#include <vector>

#include <Eigen/Dense>

#include "solver/sg.h"
#include "solver/sg_lobe_system.h"
#include "solver/sg_solver.h"
#include "solver/shadow_plane.h"

namespace shadowsg {

// The sky basis the pool offers (pool_sky_basis): lobes of that sharpness
// about the plane's normal and about six axes 60 degrees from it, every 60
// degrees of azimuth. Blended by NNLS they make a sky brighter to one side.
std::vector<SgLobe> SkyBasisLobes(const Eigen::Vector3d& plane_normal, double sharpness);

// Every lobe of the fits, then each again at o.pool_sharpness's multiples
// of its sharpness (within the refinement's bounds; a copy the bounds make
// equal to its lobe is left out), with o.pool_sky_lobe the flattest lobe
// the refinement allows, about the plane's normal, and with
// o.pool_sky_basis the sky basis (SkyBasisLobes).
std::vector<SgLobe> PooledLobes(const std::vector<SgLighting>& fits, const SgSolverOptions& o,
                                const Eigen::Vector3d& plane_normal);

// BounceIrradiance of the lobes (the model's bounce), or nothing without it.
std::array<Eigen::MatrixXf, 3> LobesBounceIrradiance(const ShadowPlaneModel& model, const std::vector<SgLobe>& lobes);

// PoolLobes on the fit points' system of all the lobes (one system serves
// the elimination and every leading set). *fit_mse (optional): the weighted
// fit MSE of the result, from the same system.
SgLighting PoolLobeSystem(LobeNormalEquations eq, std::vector<SgLobe> lobes, const Eigen::Vector3d& up,
                          const ShadowPlaneModel& hold_model, const std::vector<Eigen::Vector3f>& hold_targets,
                          const SgSolverOptions& o, std::vector<double>* heldout_path,
                          double* fit_mse = nullptr, const std::array<Eigen::MatrixXf, 3>* bounce_irradiance = nullptr);

// The pool of restarts (step 7): every lobe of `fits` together (and each
// again at options.pool_sharpness's multiples of its sharpness), in the
// reverse order of backward elimination on the model's points
// (OrderByElimination), amplitudes by NNLS per channel there; of the leading
// sets (up to options.pool_max_lobes), the smallest whose error on the hold
// model's points is within size_tolerance of the best plus 1e-7 of their
// mean squared signal (options.lobes > 0: the first that many). Lobes
// left at zero amplitude are dropped. The restarts' local minima differ in
// where they put lobes that the shadows barely pin down; the pool lets them
// share the work: balanced, 10 seeds, pub_torus_sunrise 39.80 -> 40.37 dB
// median, seed spread 0.93 -> 0.57 (solver/EXPERIMENTS.md). heldout_path (optional): the
// error of each leading set on the hold model's points.
SgLighting PoolLobes(const ShadowPlaneModel& model, const std::vector<double>& weight,
                     const std::vector<Eigen::Vector3f>& targets, const std::vector<SgLighting>& fits,
                     const ShadowPlaneModel& hold_model, const std::vector<Eigen::Vector3f>& hold_targets,
                     const SgSolverOptions& options, std::vector<double>* heldout_path = nullptr);

}  // namespace shadowsg
