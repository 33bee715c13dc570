// How every method is scored (spec/metrics.md). One implementation, shared by
// solve, eval, composite and bench.
#pragma once

#include <Eigen/Dense>
#include <cstddef>

#include "calib/image.h"

namespace shadowsg {

struct ImageMetrics {
  double psnr = 0;      // 10 log10(R^2 / MSE), R = max of gt over the mask
  double ssim = 0;      // Wang 2004, Gaussian 11x11 sigma 1.5, range R, zero outside the mask
  double rel_rmse = 0;  // ||render - gt|| / ||gt|| over the mask
  size_t pixels = 0;
};

// Scores `render` (clamped at 0) against `gt` (not clamped) over the pixels
// where mask (1 channel) is non-zero, on the first three channels.
ImageMetrics CompareImages(const Image& render, const Image& gt, const Image& mask);

// SSIM as above (exposed for tests).
double MaskedSsim(const Image& render, const Image& gt, const Image& mask, double data_range);

struct EnvMetrics {
  double angular_error_deg = 0;     // solid-angle-weighted mean RGB angle, upper hemisphere
  double irradiance_rel_rmse = 0;   // over kIrradianceNormals normals in the upper hemisphere
};

inline constexpr int kEnvMetricHeight = 64;
inline constexpr int kIrradianceNormals = 64;

// Both maps are brought to H = 64 by area averaging first.
EnvMetrics CompareEnvMaps(const Image& estimate, const Image& gt);

// Unit normals spread evenly over the upper hemisphere (Fibonacci lattice).
std::vector<Eigen::Vector3d> HemisphereNormals(int count);

}  // namespace shadowsg
