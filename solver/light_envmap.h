// Any LightSet as an equirectangular radiance map (conventions.h), e.g. the
// env_gt.exr of a synthetic scene:
//   SG lobes     evaluated at texel centres (SgToEnvMap);
//   env map      area-averaged to the target height (ResampleEnvMap);
//   suns         rasterised discs: the disc is split into many equal-power
//                directions, each adding irradiance / texel solid angle to the
//                texel it falls in, so sum(L dOmega) = the sun's irradiance;
//   area lights  the rectangle as seen from `viewpoint` (texel average of
//                supersampled rays), exact for a plane point at the viewpoint
//                only, because the light is near.
#pragma once

#include <Eigen/Dense>

#include "calib/image.h"
#include "solver/lights.h"

namespace shadowsg {

struct LightEnvMapOptions {
  int height = 256;  // map is height x 2 height
  Eigen::Vector3d viewpoint = Eigen::Vector3d::Zero();  // where area lights are seen from
  int sun_directions = 1024;    // per sun with angular radius > 0
  int area_supersampling = 8;   // n x n rays per texel for area lights

  bool IsValid(std::string* error) const;
};

Image LightSetToEnvMap(const LightSet& lights, const LightEnvMapOptions& options = {});

}  // namespace shadowsg
