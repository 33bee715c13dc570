// Does distant lighting explain the lit plane at all? Under distant light the
// irradiance of the plane where nothing is in the way is one value; a light
// close to the scene (a lamp, a window a metre away) makes it fall off across
// the view, which no SG mixture or env map can reproduce (method-notes.md:
// every distant model ends near 14 dB on such a scene). The solve stage warns
// from this number instead of leaving users with an unexplained bad fit.
#pragma once

#include <vector>

#include <Eigen/Core>

namespace shadowsg {

struct LitPlaneTrend {
  // max / min over the lit pixels of exp(a + b u + c v), the log-linear fit
  // of their irradiance across the plane (u, v: plane coordinates); 1 when
  // the lit plane is uniform. 0 when there are too few lit pixels to tell.
  double ratio = 0;
  int lit_pixels = 0;
};

// irradiance: per pixel (radiance / albedo, any common scale); points: the
// pixels' positions on the plane of unit normal `normal`. Lit pixels are the
// brighter half (shadows, cast by the object, lower the rest); a pixel must
// be above 1e-6 of the brightest one.
LitPlaneTrend MeasureLitPlaneTrend(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& normal,
                                   const std::vector<double>& irradiance);

// Above this ratio across the view the scene is reported as near-lit.
constexpr double kNearLightTrend = 1.3;

}  // namespace shadowsg
