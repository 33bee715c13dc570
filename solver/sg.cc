#include "solver/sg.h"

#include <cmath>

#include "solver/envmap.h"

namespace shadowsg {

Eigen::Vector3d EvalSg(const SgLobe& lobe, const Eigen::Vector3d& dir) {
  return lobe.amplitude * std::exp(lobe.sharpness * (dir.dot(lobe.axis) - 1.0));
}

Eigen::Vector3d EvalSg(const SgLighting& lighting, const Eigen::Vector3d& dir) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const auto& lobe : lighting.lobes) sum += EvalSg(lobe, dir);
  return sum;
}

Eigen::Vector3d SgIntegral(const SgLobe& lobe) {
  return 2 * M_PI * lobe.amplitude * (1 - std::exp(-2 * lobe.sharpness)) / lobe.sharpness;
}

Image SgToEnvMap(const SgLighting& lighting, int height) {
  return MakeEnvMap(height, [&](const Eigen::Vector3d& d) { return EvalSg(lighting, d); });
}

}  // namespace shadowsg
