#include "solver/lights.h"

#include "solver/envmap.h"

namespace shadowsg {

Eigen::Vector3d LightSet::DistantRadiance(const Eigen::Vector3d& dir) const {
  Eigen::Vector3d l = Eigen::Vector3d::Zero();
  if (sg) l += EvalSg(*sg, dir);
  if (env) l += SampleEnvMap(*env, dir);
  return l;
}

}  // namespace shadowsg
