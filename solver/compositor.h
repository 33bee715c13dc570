// Inserting virtual objects into the photograph by differential rendering
// (Debevec, "Rendering synthetic objects into real scenes", SIGGRAPH 98;
// field-notes 3.8). The local scene (plane and real casters) is rendered
// under the estimated lighting with the virtual objects (L_with) and without
// (L_without); per pixel and channel
//
//   local  = photo * L_with / L_without          where L_without > 0,
//            photo + L_with - L_without (>= 0)   where L_without = 0
//   result = a * L_object + (1 - a) * local
//
// The ratio carries the objects' shadows (and the light they bounce) onto
// the real texture, noise and whatever the lighting estimate gets wrong about
// the photo's own shading, because the estimate's error divides out; only
// where no light at all reaches the point without the objects (L_without = 0,
// where the photo is dark too) is the ratio undefined, and the additive form
// (Debevec's own) takes over. a is the share of the pixel the virtual objects
// cover (supersampled: anti-aliased edges) and L_object their rendered
// radiance (Lambertian with their `diffuse`, shadowed by all geometry). No
// blending weights beyond these; the photo is never thresholded.
//
// Two quality levels:
//   kPreview  closed-form SG shading (solver/shadow_plane.h, the `sg` model:
//             exact cosine, capped occlusion) with sphere-tree visibility. Plane
//             pixels: RenderShadowPlaneAdding, the casters' trees (without)
//             and the virtual objects' trees beside them (with), where the
//             objects' bounding cones can change the shading (elsewhere the
//             ratio is exactly 1). Surface points
//             (virtual objects at n x n sub-pixel rays, casters at the pixel
//             centre): the SG closed form with the point's own normal (Embree
//             hit), visibility from the other objects' trees and the plane's
//             half-space (theta = the smaller signed angle), plus one bounce
//             off the plane (below). Env maps and suns take part as SG lobes
//             (EnvMapToSgLobes, SunToSgLobe); area lights are not supported.
//   kFinal    the path tracer (solver/path_tracer.h) with objects = kAll and
//             kCasters, same seed (correlated noise, so the ratio is exact
//             where the objects change nothing), next-event estimation of SG,
//             env maps, suns and area lights; the object matte and radiance
//             come from its per-sample split (VirtualObjectSplit).
//
// What the preview leaves out: an object's shadow on itself (its own tree is
// not an occluder of its own surface: the clamped cosine alone shades it, exact
// for convex objects), light bounced between objects, and the plane's bounce
// light is taken from one plane point (where the direction n - up meets it) as
// if the plane below were uniform. It is meant for interactive placement and
// for scoring solve's estimates; `final` for images.
#pragma once

#include <cstdint>
#include <string>

#include "calib/image.h"
#include "solver/lights.h"
#include "solver/progress.h"
#include "solver/scene.h"
#include "solver/sg.h"

namespace shadowsg {

enum class CompositeQuality { kPreview, kFinal };

struct CompositeOptions {
  CompositeQuality quality = CompositeQuality::kFinal;
  // kFinal: path-tracer samples per pixel and diffuse bounces of both renders.
  int samples_per_pixel = 256;  // >= 1
  int max_bounces = 4;          // >= 0 (Cycles' default, as PathTraceOptions)
  uint64_t seed = 0;
  // kPreview: n x n stratified rays per pixel for the object matte and shading.
  int supersampling = 4;  // 1 to 16
  // kPreview: an env map becomes one SG lobe per texel of the map area-averaged
  // to this height (H x 2H texels).
  int env_lobe_height = 16;  // 2 to 64

  bool IsValid(std::string* error) const;
};

struct CompositeResult {
  Image composite;  // RGB, linear
  // RGB: L_with / L_without of the local scene at each pixel (1 = unchanged,
  // and where the additive form was used); the artist's shadow layer. Where the
  // objects cover the whole pixel, kFinal has no local sample and writes 1.
  Image shadow;
  // RGBA, premultiplied: (a * L_object, a). composite = objects.rgb +
  // (1 - a) * photo * shadow wherever the ratio was used.
  Image objects;
  // Pixel channels where L_without = 0 took the additive form.
  size_t additive_channels = 0;
};

// Inserts scene.VirtualObjects() into scene.image under `lights`. kPreview
// needs a sphere tree on every object (SceneObject::sphere_tree) and distant
// lights only (no area lights). With no virtual object the result is the
// photograph, bit for bit (L_with and L_without are then the same render).
CompositeResult CompositeVirtualObjects(const Scene& scene, const LightSet& lights, const CompositeOptions& options,
                                        const ProgressFn& progress = {});

// The preview's SG stand-ins for other distant lights, each preserving power:
// one lobe per texel of the map area-averaged to `height`, on the texel
// centre, with sharpness 2 H^2 / pi (its solid angle 2 pi / lambda is an
// equatorial texel's, (pi / H)^2) and amplitude so that the lobe's integral is
// the texel's radiance times its solid angle (zero texels are skipped).
SgLighting EnvMapToSgLobes(const Image& env, int height);
// A sun of irradiance E and angular radius alpha: a lobe of solid angle
// 2 pi / lambda = pi alpha^2 (alpha no smaller than the real sun's) and
// integral E.
SgLobe SunToSgLobe(const SunLight& sun);
// All distant lighting of `lights` as one SG mixture (SG lobes as they are);
// area lights must be absent.
SgLighting PreviewSgLighting(const LightSet& lights, int env_lobe_height);

}  // namespace shadowsg
