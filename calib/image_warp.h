// Resampling images between camera models: undistortion to the pinhole
// camera with the same K, and intrinsics for a resized image. The geometry is
// the project's camera model (camera.h); OpenCV only interpolates.
#pragma once

#include "calib/camera.h"
#include "calib/image.h"

namespace shadowsg {

// The camera without lens distortion (same size, K and pose).
Camera PinholeOf(const Camera& camera);

// Intrinsics of the same camera for an image resized to width x height
// (pixel centres at integers: u' = (u + 0.5) s - 0.5). Distortion, being on
// normalised coordinates, is unchanged.
Camera ResizeCamera(const Camera& camera, int width, int height);

enum class WarpSampling {
  kBilinear,    // colour images
  kAnyNonZero,  // masks: an output pixel is non-zero when any of its source neighbours is
};

// Resamples `image`, taken by `camera`, as PinholeOf(camera) would see it.
// Output pixels whose source lies outside the frame are 0 and, when `outside`
// is given, set to 1 there (1-channel image of the output size).
Image UndistortImage(const Image& image, const Camera& camera, WarpSampling sampling = WarpSampling::kBilinear,
                     Image* outside = nullptr);

}  // namespace shadowsg
