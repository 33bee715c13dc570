// The reference renderer: a Monte Carlo path tracer over the scene's
// Lambertian plane and objects (Embree, via RayCaster), lit by any LightSet.
//
// Radiometry (method-notes.md, "physical scale"): every light is radiance
// (suns: irradiance), a Lambertian surface of albedo rho reflects
// rho / pi * integral L V cos, so a plane under an SG lighting and under that
// lighting's env map renders the same image.
//
// Estimator: next-event estimation at every diffuse vertex, one sample per
// light kind (env map by a luminance x solid-angle CDF over its texels; SG by
// choosing a lobe by power, then a von Mises-Fisher direction; area lights by
// uniform area sampling; suns by uniform cone sampling, or exactly when
// delta), combined with one cosine-sampled BSDF ray by the power heuristic
// for env, SG and area lights (suns are NEE only). Two refinements follow the
// cosine as well as the light: the SG lobe and its vMF are those of the lobe
// times the vertex's cosine lobe (the product lobe of method-notes.md), and on
// the plane's front the env CDF also carries the plane's cosine; there the env
// and SG samples follow L cos closely and are used alone (no MIS), which makes
// unoccluded plane pixels almost noise-free. Random numbers come from a
// counter-based hash of (seed, pixel, sample): the image is bit-identical for
// any thread count.
//
// What the camera sees: camera rays that miss everything return the distant
// radiance (SG + env, as Blender's world background); area lights do not
// occlude and are invisible to camera rays (Cycles' default), suns are never
// seen directly. The env map is piecewise constant over its texels (nearest
// texel), which is what EnvIrradiance integrates. Pixels are box-filtered over
// their footprint: jitter within +-0.5 px of the integer pixel centre.
#pragma once

#include <cstdint>
#include <string>

#include "calib/image.h"
#include "solver/lights.h"
#include "solver/progress.h"
#include "solver/scene.h"

namespace shadowsg {

// Which of the scene's objects take part (cast shadows, are seen, reflect).
enum class RenderObjects {
  kNone,     // the plane alone (object-free reference)
  kCasters,  // is_train objects: what image.exr shows
  kAll,      // casters and virtual objects: what image_virtual_objs.exr shows
};

struct PathTraceOptions {
  int samples_per_pixel = 64;  // >= 1
  // Diffuse bounces after the first surface hit: 0 = direct lighting only.
  // 4 is Cycles' default (max diffuse bounces); on the Blender-rendered
  // development scenes it matches 8 bounces within 0.1 % next to the object,
  // where 3 bounces are 0.5 % dark.
  int max_bounces = 4;
  RenderObjects objects = RenderObjects::kCasters;
  uint64_t seed = 0;
  // false drops the plane (object-only renders and tests).
  bool include_plane = true;

  bool IsValid(std::string* error) const;
};

// The samples of each pixel split by what their camera ray hits first: a
// virtual object (is_train false) or anything else (plane, casters, the
// distant lighting). The compositor's anti-aliased object matte and the two
// radiances it blends (solver/compositor.h).
struct VirtualObjectSplit {
  Image coverage;         // 1 channel: share of the pixel's samples that hit a virtual object first
  Image object_radiance;  // RGB: mean radiance of those samples (0 where coverage is 0)
  Image rest_radiance;    // RGB: mean radiance of the other samples (0 where coverage is 1)
};

// Linear RGB image of scene.camera's view (3 channels). The callback may throw
// (e.g. Interrupted); the exception propagates once the workers have stopped.
// `split`, when given, receives the per-pixel split above; the image does not
// depend on whether it is asked for.
Image RenderPathTraced(const Scene& scene, const LightSet& lights, const PathTraceOptions& options,
                       const ProgressFn& progress = {}, VirtualObjectSplit* split = nullptr);

// The radiance the renderer assigns to a distant direction (SG exactly, env map
// by nearest texel): what a camera ray that escapes returns.
Eigen::Vector3d RenderedDistantRadiance(const LightSet& lights, const Eigen::Vector3d& dir);

}  // namespace shadowsg
