// Spherical Gaussian lighting: G(w) = a exp(lambda (w.mu - 1)), RGB amplitude,
// radiance units (scene-format.md, "SG lighting file"). SG algebra after
// Wang et al. 2009 (ACM TOG 28(5):133).
#pragma once

#include <Eigen/Dense>
#include <vector>

#include "calib/image.h"

namespace shadowsg {

struct SgLobe {
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();  // unit
  double sharpness = 1;                             // lambda > 0
  Eigen::Vector3d amplitude = Eigen::Vector3d::Zero();  // >= 0, radiance
};

struct SgLighting {
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  std::vector<SgLobe> lobes;
};

// The lobes' axes and sharpness values appended to *axes and *sharpness, as
// the batched shading functions take them.
void SplitLobes(const std::vector<SgLobe>& lobes, std::vector<Eigen::Vector3d>* axes, std::vector<double>* sharpness);

Eigen::Vector3d EvalSg(const SgLobe& lobe, const Eigen::Vector3d& dir);
Eigen::Vector3d EvalSg(const SgLighting& lighting, const Eigen::Vector3d& dir);
// Full-sphere integral of a lobe: 2 pi a (1 - exp(-2 lambda)) / lambda.
Eigen::Vector3d SgIntegral(const SgLobe& lobe);
// The solvers' last guard (issue #10): drops lobes that are not lighting
// (non-finite or zero axis, sharpness not finite and positive, amplitude not
// finite and non-negative, or all zero) and normalises the axes. Returns how
// many were dropped; what is left renders finite values.
int RemoveInvalidLobes(SgLighting* lighting);
// The lighting as an H x 2H equirectangular map (texel-centre values).
Image SgToEnvMap(const SgLighting& lighting, int height);

}  // namespace shadowsg
