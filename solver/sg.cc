#include "solver/sg.h"

#include <cmath>

#include "solver/envmap.h"

namespace shadowsg {

void SplitLobes(const std::vector<SgLobe>& lobes, std::vector<Eigen::Vector3d>* axes, std::vector<double>* sharpness) {
  for (const SgLobe& l : lobes) axes->push_back(l.axis), sharpness->push_back(l.sharpness);
}

Eigen::Vector3d EvalSg(const SgLobe& lobe, const Eigen::Vector3d& dir) {
  return lobe.amplitude * std::exp(lobe.sharpness * (dir.dot(lobe.axis) - 1.0));
}

Eigen::Vector3d EvalSg(const SgLighting& lighting, const Eigen::Vector3d& dir) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const auto& lobe : lighting.lobes) sum += EvalSg(lobe, dir);
  return sum;
}

int RemoveInvalidLobes(SgLighting* lighting) {
  const size_t before = lighting->lobes.size();
  std::erase_if(lighting->lobes, [](const SgLobe& l) {
    const double n = l.axis.norm();
    return !(std::isfinite(n) && n > 1e-12) || !(std::isfinite(l.sharpness) && l.sharpness > 0) ||
           !l.amplitude.allFinite() || (l.amplitude.array() < 0).any() || !(l.amplitude.maxCoeff() > 0);
  });
  for (SgLobe& l : lighting->lobes) l.axis.normalize();
  if (!lighting->up.allFinite() || !(lighting->up.norm() > 1e-12)) lighting->up = Eigen::Vector3d::UnitZ();
  return static_cast<int>(before - lighting->lobes.size());
}

Eigen::Vector3d SgIntegral(const SgLobe& lobe) {
  return 2 * M_PI * lobe.amplitude * (1 - std::exp(-2 * lobe.sharpness)) / lobe.sharpness;
}

Image SgToEnvMap(const SgLighting& lighting, int height) {
  return MakeEnvMap(height, [&](const Eigen::Vector3d& d) { return EvalSg(lighting, d); });
}

}  // namespace shadowsg
