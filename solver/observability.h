// What an observation can tell about the lighting, measured before solving so
// that solve can warn instead of leaving users with an unexplained bad fit.
//
// Informative sky share: a direction of the sky says where light comes from
// only if it shadows some visible plane pixels and not others.
//
// Lit-plane trend: does distant lighting explain the lit plane at all? Under distant light the
// irradiance of the plane where nothing is in the way is one value; a light
// close to the scene (a lamp, a window a metre away) makes it fall off across
// the view, which no SG mixture or env map can reproduce (method-notes.md:
// every distant model ends near 14 dB on such a scene). The solve stage warns
// from this number instead of leaving users with an unexplained bad fit.
#pragma once

#include <vector>

#include <Eigen/Core>

#include "solver/ray_caster.h"

namespace shadowsg {

// Which share of the sky (cosine-weighted, over the plane's hemisphere) the
// observation says anything about the direction of: a direction tells only
// when it shadows some of the plane points and not others. Light from
// elsewhere is known in total only (any mix of such directions renders the
// same image). 1024 directions x at most 512 of the points.
double InformativeSkyShare(const Eigen::Vector3d& plane_normal, const std::vector<Eigen::Vector3d>& points,
                           const RayCaster& casters);

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
