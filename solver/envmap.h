// Equirectangular environment maps (convention in calib/conventions.h): an
// Image of height H and width 2H holding radiance.
#pragma once

#include <Eigen/Dense>
#include <functional>

#include "calib/conventions.h"
#include "calib/image.h"

namespace shadowsg {

// Fills an H x 2H map by evaluating radiance(direction) at texel centres.
Image MakeEnvMap(int height, const std::function<Eigen::Vector3d(const Eigen::Vector3d&)>& radiance);
// Bilinear lookup (wrapping in azimuth, clamped at the poles).
Eigen::Vector3d SampleEnvMap(const Image& env, const Eigen::Vector3d& dir);
// Area-weighted resampling to height H (box filter over the solid angle of each
// target texel); exact when H divides the source height.
Image ResampleEnvMap(const Image& env, int height);
// Cosine-weighted irradiance integral over the hemisphere around `normal`
// (no visibility): E = sum L(w) max(n.w, 0) dOmega.
Eigen::Vector3d EnvIrradiance(const Image& env, const Eigen::Vector3d& normal);

// Our map laid out in another tool's lat-long convention (calib/conventions.h,
// LatLongConvention), same size, and back. Each texel takes the value our map
// has in its direction: an exact texel permutation wherever the two layouts'
// texel centres coincide (Blender: always; OpenEXR/USD: when the width is a
// multiple of 4), else bilinear between the four nearest texels.
Image EnvMapToLatLong(const Image& ours, LatLongConvention to);
Image EnvMapFromLatLong(const Image& theirs, LatLongConvention from);

}  // namespace shadowsg
