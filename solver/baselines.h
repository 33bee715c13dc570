// The discrete-map baselines of the paper (method-notes.md "Baselines"): the
// radiance of every texel of a (map_rows x 4 map_rows) upper-hemisphere map,
// fitted to the shadow-plane pixels through the light transport of
// solver/light_transport.h (albedo/pi * V * cos * dOmega, visibility by ray
// casting against the real meshes).
//
//   kSS03     Sato, Sato & Ikeuchi, TPAMI 2003: min |A l - b| per channel by a
//             rank-revealing solver (minimum-norm solution when rank deficient).
//   kSS03Plus the same with l >= 0 (Lawson-Hanson NNLS, solver/nnls.h).
//   kSH21     Swedish, Henley & Raskar, ICCV 2021, with the weights of the
//             ShadowSG reference code: (A^T A + wL D^T D + wI I) l = A^T b,
//             D the 5-point graph Laplacian of the texel grid (wrapping in
//             azimuth, no wrap at the pole and horizon rows).
//
// The objective is the sum over ALL plane pixels. Pixels whose visibility rows
// are identical are merged exactly (weight = their count); when more than
// max_fit_pixels distinct rows remain, a deterministic, spatially stratified
// sample of them is fitted instead, each weighted by the inverse of its
// inclusion probability (systematic sampling in image order, probability
// proportional to the row's pixel count, so the merged big groups - e.g. the
// unshadowed plane - are always in). A^T A therefore always estimates the Gram
// matrix of all plane pixels, which keeps SH21's absolute weights meaningful.
//
// estimate_albedo (the original SH21 solves for the plane albedo jointly):
// the product albedo x radiance is all the image determines, so a global
// albedo scale (or colour) is NOT identifiable - any value fits equally well.
// What the image does determine is how the albedo VARIES over the plane (a
// distant light gives an unshadowed plane of constant radiance). We estimate a
// smooth gain field g(x) (bilinear on 5 x 5 nodes spanning the image) with
// albedo(x) = g(x) * scene albedo, by 4 alternations of map fit and gain fit
// (each a linear least-squares problem; the map fit comes last), under the
// gauge mean(g) = 1 over the plane pixels: the scene's albedo keeps fixing
// the absolute scale, and albedo_scale stays 1 by construction. The gain also
// absorbs a smooth near-field falloff of the unshadowed plane.
#pragma once

#include <Eigen/Dense>
#include <Eigen/Sparse>
#include <cstdint>
#include <string>
#include <vector>

#include "calib/image.h"
#include "solver/plane_pixels.h"
#include "solver/progress.h"
#include "solver/ray_caster.h"
#include "solver/scene.h"

namespace shadowsg {

enum class BaselineMethod { kSS03, kSS03Plus, kSH21 };

// "ss03", "ss03+", "sh21".
const char* BaselineMethodName(BaselineMethod method);
// Parses a name as above; false when unknown.
bool ParseBaselineMethod(const std::string& name, BaselineMethod* method);

struct BaselineOptions {
  BaselineMethod method = BaselineMethod::kSS03;
  int map_rows = 16;               // texel rows over the hemisphere; the map is map_rows x 4 map_rows
  bool estimate_albedo = false;    // joint plane-albedo gain field (see above)
  // SH21 weights in the reference code's units (its map absorbs albedo/pi,
  // so on our radiance map they act as w * (albedo/pi)^2 per channel).
  double laplacian_weight = 0.1;   // SH21 wL (reference code's reg_lstsq_1)
  double identity_weight = 0.1;    // SH21 wI (reference code's reg_lstsq_2)
  int max_fit_pixels = 40000;      // distinct transport rows fitted at most
  uint64_t seed = 0;               // offset of the systematic sample

  // map_rows in [kMinMapRows, kMaxMapRows], weights finite and >= 0 (SH21:
  // not both 0), max_fit_pixels >= 1.
  bool IsValid(std::string* error) const;
};

// 32 rows = 4096 texels: a dense 4096^2 Gram matrix and 4096-wide fit rows
// are the most the dense solvers and the 2 GB memory target allow (the fit
// matrix is also capped at 512 MiB, which lowers max_fit_pixels above 16 rows).
inline constexpr int kMinMapRows = 1;
inline constexpr int kMaxMapRows = 32;

struct BaselineResult {
  Image envmap;                          // full equirect map, height 2*map_rows, width 4*map_rows, lower half zero
  std::vector<Eigen::Vector3f> render;   // re-render of every plane pixel, same order as PlanePixels
  double albedo_scale = 1;               // plane albedo / scene albedo (global; 1 by gauge, see above)
  std::vector<float> albedo_gain;        // per plane pixel, mean 1; empty unless estimate_albedo
  int n_params = 0;                      // 3 * texels
  double solve_seconds = 0;              // whole SolveBaseline call
  double transport_seconds = 0;          // of which: casting the visibility rays
  double ray_fraction = 0;               // (point, texel) pairs that needed a ray
  size_t distinct_rows = 0;              // plane pixels with distinct visibility
  int fit_rows = 0;                      // rows of the fitted system
  int rank = 0;                          // SS03: numerical rank of A
  int nnls_dependent = 0;                // SS03+: variables held at 0 as dependent (all channels)
  bool converged = true;                 // SS03+: every channel's NNLS converged
  int invalid_texels = 0;                // non-finite texel values set to 0 by the last guard
};

// Throws InputError for invalid options, no plane pixels, or a plane albedo
// that is not positive. `casters` = BuildRayCaster(scene.Casters()).
BaselineResult SolveBaseline(const Scene& scene, const PlanePixels& pixels, const RayCaster& casters,
                             const BaselineOptions& options, const ProgressFn& progress = {});

// The SH21 smoothness operator: 5-point graph Laplacian of a rows x (4 rows)
// texel grid, (D l)_i = sum over grid neighbours k of (l_i - l_k), neighbours
// wrapping in azimuth but not across the first and last rows.
Eigen::SparseMatrix<double> HemisphereLaplacian(int map_rows);

}  // namespace shadowsg
