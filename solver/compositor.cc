#include "solver/compositor.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>
#include <vector>

#include "calib/camera.h"
#include "calib/conventions.h"
#include "calib/error.h"
#include "solver/cosine_integral.h"
#include "solver/envmap.h"
#include "solver/path_tracer.h"
#include "solver/ray_caster.h"
#include "solver/sg_shading.h"
#include "solver/shadow_plane.h"
#include "solver/sphere_tree.h"
#include "solver/ssdf.h"

namespace shadowsg {
namespace {

// The sun's mean angular radius (0.2666 degrees; its apparent diameter is
// 31.99 arc minutes at 1 au): a delta sun becomes a lobe this sharp.
constexpr double kSunAngularRadius = 4.653e-3;
// SgCosineIntegral is accurate for lambda up to 1e5 (cosine_integral.h).
constexpr double kMaxLobeSharpness = 1e5;

constexpr int kMaxSupersampling = 16;
constexpr int kMinEnvLobeHeight = 2, kMaxEnvLobeHeight = 64;

// ---- The differential-rendering formula, shared by both levels ---------------

// with_local / without_local: the local scene's radiance with and without the
// virtual objects; coverage (1 channel) and object_radiance: the objects'
// matte and radiance.
CompositeResult Assemble(const Image& photo, const Image& with_local, const Image& without_local,
                         const Image& coverage, const Image& object_radiance) {
  const int w = photo.width, h = photo.height;
  CompositeResult r;
  r.composite = Image(w, h, 3);
  r.shadow = Image(w, h, 3, 1.0f);
  r.objects = Image(w, h, 4);
  for (size_t p = 0; p < photo.pixels(); ++p) {
    const float a = coverage.data[p];
    for (int c = 0; c < 3; ++c) {
      const float object = object_radiance.data[p * 3 + c];
      r.objects.data[p * 4 + c] = a * object;
      if (a >= 1.0f) {  // nothing of the photo is left in this pixel
        r.composite.data[p * 3 + c] = object;
        continue;
      }
      const float photo_c = photo.data[p * photo.channels + c];
      const float with = with_local.data[p * 3 + c], without = without_local.data[p * 3 + c];
      float local;
      const float ratio = without > 0 ? with / without : 0.0f;
      if (without > 0 && std::isfinite(ratio)) {
        local = photo_c * ratio;
        r.shadow.data[p * 3 + c] = ratio;
      } else {
        // No light reaches the point without the objects: Debevec's additive
        // form (the objects can only add light here; removing it stops at 0).
        const float d = with - without;
        local = d < 0 ? std::max(0.0f, photo_c + d) : photo_c + d;
        ++r.additive_channels;
      }
      r.composite.data[p * 3 + c] = a > 0 ? a * object + (1 - a) * local : local;
    }
    r.objects.data[p * 4 + 3] = a;
  }
  return r;
}

// ---- Preview: closed-form SG shading with sphere-tree visibility ------------

enum class HitKind { kMiss, kPlane, kObject };

struct Hit {
  HitKind kind = HitKind::kMiss;
  int object = -1;  // index into scene.objects
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  // facing the ray
};

// A ray caster over some of the scene's objects, remembering which.
struct ObjectCaster {
  RayCaster caster;
  std::vector<int> object_of_geometry;

  explicit ObjectCaster(const Scene& scene, bool with_virtual) {
    for (size_t i = 0; i < scene.objects.size(); ++i) {
      const SceneObject& o = scene.objects[i];
      if (!o.is_train && !with_virtual) continue;
      caster.AddMesh(o.WorldMesh());
      object_of_geometry.push_back(static_cast<int>(i));
    }
    caster.Commit();
  }

  // The nearer of the meshes' hit and the plane rectangle's (seen from either side).
  Hit First(const Plane& plane, const Ray& ray) const {
    Hit hit;
    double t_best = 1e30;
    if (!caster.empty())
      if (const auto m = caster.Intersect(ray.origin, ray.dir)) {
        t_best = m->t;
        hit.kind = HitKind::kObject;
        hit.object = object_of_geometry[m->geometry];
        hit.point = ray.origin + m->t * ray.dir;
        hit.normal = m->normal;
      }
    if (const auto t = IntersectPlane(plane, ray.origin, ray.dir); t && *t < t_best) {
      const Eigen::Vector3d p = ray.origin + *t * ray.dir;
      if (PlaneRectContains(plane, p)) {
        hit.kind = HitKind::kPlane;
        hit.object = -1;
        hit.point = p;
        hit.normal = plane.normal.dot(ray.dir) < 0 ? plane.normal : Eigen::Vector3d(-plane.normal);
      }
    }
    return hit;
  }
};

// C(lambda, c) = SgCosineIntegral(lambda, c).value of one sharpness at
// kCosineTableSize + 1 evenly spaced c in [-1, 1], linearly interpolated:
// surface points have a normal each, and the quadrature is too slow to run
// per point and lobe. C is smooth in c (its kinks lie in the integrand only).
constexpr int kCosineTableSize = 1024;

class CosineTable {
 public:
  explicit CosineTable(double lambda) : value_(kCosineTableSize + 1) {
#pragma omp parallel for schedule(static)
    for (int i = 0; i <= kCosineTableSize; ++i)
      value_[i] = SgCosineIntegral(lambda, -1.0 + 2.0 * i / kCosineTableSize).value;
  }
  double operator()(double c) const {
    const double x = (std::clamp(c, -1.0, 1.0) + 1.0) * 0.5 * kCosineTableSize;
    const int i = std::min(static_cast<int>(x), kCosineTableSize - 1);
    const double f = x - i;
    return (1 - f) * value_[i] + f * value_[i + 1];
  }

 private:
  std::vector<double> value_;
};

// A lighting's tables, one per sharpness (an env map's lobes share one),
// made once for every ShadeSurface call of a preview.
using CosineTables = std::map<double, CosineTable>;
CosineTables MakeCosineTables(const SgLighting& sg) {
  CosineTables tables;
  for (const auto& l : sg.lobes) tables.try_emplace(l.sharpness, l.sharpness);
  return tables;
}

// A point on an object's surface seen by one sub-pixel ray (or a pixel centre).
struct SurfaceSample {
  int pixel = 0;
  int object = 0;
  Eigen::Vector3d point, normal;
};

// The `sg` model of the plane at `points` with the given occluders (eval's).
ShadowPlaneModel PlaneModel(const Scene& scene, const std::vector<Eigen::Vector3d>& points,
                            const std::vector<SphereTree>& occluders) {
  return MakeShadowPlaneModel(scene.plane, points, occluders, ShadingModel::kSg);
}

// Closed-form SG radiance of surface samples: for each,
//   albedo/pi * sum_i a_i * C(lambda_i, mu_i . n) * sigma(k(lambda') theta),
// C the exact cosine integral about the sample's own normal, theta the
// smaller of the signed angle to the occluders' leaf spheres and to the
// plane's half-space (the side of the plane the point is not on). The
// sigmoid is uncapped: a half-space is the boundary it was fitted to.
// tables: MakeCosineTables(sg). known (optional, in): theta over other
// occluders for these samples and lobes, which `occluders` join; theta
// (optional, out): theta over all of them.
std::vector<Eigen::Vector3d> ShadeSurface(const std::vector<SurfaceSample>& samples,
                                          const std::vector<Eigen::Vector3d>& albedo,
                                          const std::vector<SphereTree>& occluders, const Plane& plane,
                                          const SgLighting& sg, const CosineTables& tables,
                                          const Eigen::MatrixXf* known = nullptr, Eigen::MatrixXf* theta_out = nullptr) {
  std::vector<Eigen::Vector3d> out(samples.size(), Eigen::Vector3d::Zero());
  if (samples.empty() || sg.lobes.empty()) return out;
  std::vector<Eigen::Vector3d> points, axes;
  points.reserve(samples.size());
  for (const auto& s : samples) points.push_back(s.point);
  for (const auto& l : sg.lobes) axes.push_back(l.axis);
  // theta is needed only up to where the sigmoid saturates: the cap of the
  // least steep product lobe any normal can make (k(lambda') grows with
  // lambda' >= |lambda - lambda_c|), as RenderShadowPlane's caps.
  std::vector<float> caps;
  for (const auto& l : sg.lobes) {
    ProductLobe flattest;
    flattest.lambda_prime = std::abs(l.sharpness - kCosineLobeSharpness);
    flattest.max_steepness = kSgMaxVisibilitySteepness;
    caps.push_back(VisibilityCap(flattest));
  }
  Eigen::MatrixXf theta;
  SignedAnglesWithWitness(occluders, points, axes, &theta, nullptr, SsdfSearch::kExact, &caps, CapSides::kAbove,
                          known);
  std::vector<const CosineTable*> table;
  for (const auto& l : sg.lobes) table.push_back(&tables.at(l.sharpness));
#pragma omp parallel for schedule(static)
  for (long k = 0; k < static_cast<long>(samples.size()); ++k) {
    const SurfaceSample& s = samples[k];
    const double side = plane.normal.dot(s.point - plane.xyz) >= 0 ? 1.0 : -1.0;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (size_t j = 0; j < sg.lobes.size(); ++j) {
      const SgLobe& lobe = sg.lobes[j];
      // lambda' (the shadow's softness) as EvalProductLobe gives it; the
      // unoccluded integral exactly (CosineModel::kExact), from the table.
      ProductLobe product = EvalProductLobe(lobe.axis, lobe.sharpness, s.normal, CosineModel::kSgProduct,
                                            /*derivatives=*/true, kSgMaxVisibilitySteepness);
      product.scale = (*table[j])(lobe.axis.dot(s.normal));
      const double theta_plane = std::asin(std::clamp(side * lobe.axis.dot(plane.normal), -1.0, 1.0));
      const double t = std::min(static_cast<double>(theta(k, static_cast<long>(j))), theta_plane);
      sum += ShadeLobe(product, t, Eigen::Vector3d::Zero()).value * lobe.amplitude;
    }
    out[k] = albedo[k].cwiseProduct(sum) / M_PI;
  }
  if (theta_out) *theta_out = std::move(theta);
  return out;
}

// The plane points of `without` (the casters' model) whose closed-form
// shading the virtual objects can change. Adding occluders changes a point's
// radiance only through theta = min over trees, and through the cap's cone
// (occluder_cos, the smallest cosine over trees); so a point is unchanged when
// the cone of each virtual object's bounding sphere is no wider than the
// casters' widest (cos_v >= cos_c) and lies, for every lobe, at least that
// lobe's VisibilityCap away from its axis (a lower bound of the objects'
// theta: beyond the cap the sigmoid is 1 to 1e-13, and RenderShadowPlane
// stops there too).
std::vector<char> VirtualObjectsMatter(const Scene& scene, const std::vector<SphereTree>& world_tree,
                                       const ShadowPlaneModel& without, const SgLighting& sg) {
  std::vector<Sphere> bounds;
  for (size_t i = 0; i < scene.objects.size(); ++i)
    if (!scene.objects[i].is_train && !world_tree[i].nodes.empty()) bounds.push_back(SubtreeBounds(world_tree[i])[0]);
  std::vector<float> caps;
  for (const auto& l : sg.lobes)
    caps.push_back(VisibilityCap(EvalProductLobe(l.axis, l.sharpness, without.normal, CosineModel::kSgProduct,
                                                 /*derivatives=*/false, without.max_steepness)));
  std::vector<char> matter(without.points.size(), 0);
  if (bounds.empty()) return matter;
#pragma omp parallel for schedule(static)
  for (long k = 0; k < static_cast<long>(without.points.size()); ++k) {
    const Eigen::Vector3d& x = without.points[k];
    bool m = false;
    for (const Sphere& b : bounds) {
      if (b.empty()) continue;
      const Eigen::Vector3d s = b.centre - x;
      const double d = s.norm();
      if (d <= b.radius) {
        m = true;
        break;
      }
      const double cos_v = std::sqrt(1 - (b.radius / d) * (b.radius / d));
      if (cos_v < without.occluder_cos[k]) {
        m = true;
        break;
      }
      const Eigen::Vector3d u = s / d;
      const double half = std::asin(b.radius / d);
      for (size_t j = 0; j < sg.lobes.size() && !m; ++j) {
        const double angle = std::atan2(u.cross(sg.lobes[j].axis).norm(), u.dot(sg.lobes[j].axis));
        m = angle - half < caps[j];
      }
      if (m) break;
    }
    matter[k] = m;
  }
  return matter;
}

CompositeResult CompositePreview(const Scene& scene, const LightSet& lights, const CompositeOptions& options,
                                 const ProgressFn& progress) {
  const Camera& cam = scene.camera;
  const int w = cam.width, h = cam.height;
  const size_t n_pixels = static_cast<size_t>(w) * h;
  const SgLighting sg = PreviewSgLighting(lights, options.env_lobe_height);
  Report(progress, 0.0, "preview: " + std::to_string(sg.lobes.size()) + " lobes");

  std::vector<SphereTree> world_tree(scene.objects.size());
  for (size_t i = 0; i < scene.objects.size(); ++i) {
    const SceneObject& o = scene.objects[i];
    SHADOWSG_CHECK(o.sphere_tree.has_value());
    world_tree[i] = TransformSphereTree(*o.sphere_tree, o.o2w);
  }
  // Trees of the objects selected by `take` (index -> bool).
  auto trees = [&](auto take) {
    std::vector<SphereTree> t;
    for (size_t i = 0; i < scene.objects.size(); ++i)
      if (take(static_cast<int>(i))) t.push_back(world_tree[i]);
    return t;
  };
  const bool any_virtual = !scene.VirtualObjects().empty();

  // Rays: the pixel centre against the local scene (what the photo shows
  // there), and n x n stratified rays against everything for the matte.
  const ObjectCaster local(scene, false), all(scene, true);
  std::vector<Hit> centre(n_pixels);
  std::vector<int> covered(n_pixels, 0);
  std::vector<std::vector<SurfaceSample>> row_samples(h);
  const int n = options.supersampling;
#pragma omp parallel for schedule(dynamic, 1)
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const size_t p = static_cast<size_t>(y) * w + x;
      centre[p] = local.First(scene.plane, PixelRay(cam, x, y));
      if (!any_virtual) continue;
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
          const Ray ray = PixelRay(cam, x + (i + 0.5) / n - 0.5, y + (j + 0.5) / n - 0.5);
          const Hit hit = all.First(scene.plane, ray);
          if (hit.kind != HitKind::kObject || scene.objects[hit.object].is_train) continue;
          ++covered[p];
          row_samples[y].push_back({static_cast<int>(p), hit.object, hit.point, hit.normal});
        }
    }
  }
  Report(progress, 0.2, "rays cast");

  // 1 / 1 where the ray escapes and where the objects change nothing.
  Image with_local(w, h, 3, 1.0f), without_local(w, h, 3, 1.0f);

  // Plane pixels.
  std::vector<int> plane_pixel;
  std::vector<Eigen::Vector3d> plane_point;
  for (size_t p = 0; p < n_pixels; ++p)
    if (centre[p].kind == HitKind::kPlane) {
      plane_pixel.push_back(static_cast<int>(p));
      plane_point.push_back(centre[p].point);
    }
  const auto is_caster = [&](int i) { return scene.objects[i].is_train; };
  const auto is_any = [&](int) { return true; };
  // Both renders only where the virtual objects can change the shading
  // (VirtualObjectsMatter); elsewhere the ratio is 1 (with = without = 1).
  {
    const std::vector<char> matter =
        VirtualObjectsMatter(scene, world_tree, PlaneModel(scene, plane_point, trees(is_caster)), sg);
    std::vector<int> pixels;
    std::vector<Eigen::Vector3d> points;
    for (size_t k = 0; k < plane_point.size(); ++k)
      if (matter[k]) {
        pixels.push_back(plane_pixel[k]);
        points.push_back(plane_point[k]);
      }
    std::vector<Eigen::Vector3f> without, with;
    RenderShadowPlaneAdding(PlaneModel(scene, points, trees(is_caster)), trees([&](int i) { return !is_caster(i); }),
                            sg, &without, &with);
    for (size_t m = 0; m < pixels.size(); ++m) {
      with_local.set_rgb(pixels[m], with[m]);
      without_local.set_rgb(pixels[m], without[m]);
    }
  }
  Report(progress, 0.6, "plane without and with objects");

  // Caster pixels: their shading changes by the virtual objects' shadows.
  const CosineTables tables = MakeCosineTables(sg);
  for (size_t c = 0; c < scene.objects.size(); ++c) {
    if (!scene.objects[c].is_train) continue;
    std::vector<SurfaceSample> samples;
    for (size_t p = 0; p < n_pixels; ++p)
      if (centre[p].kind == HitKind::kObject && centre[p].object == static_cast<int>(c))
        samples.push_back({static_cast<int>(p), static_cast<int>(c), centre[p].point, centre[p].normal});
    if (samples.empty()) continue;
    const std::vector<Eigen::Vector3d> albedo(samples.size(), scene.objects[c].diffuse);
    const int self = static_cast<int>(c);
    Eigen::MatrixXf theta_without;
    const auto without = ShadeSurface(samples, albedo, trees([&](int i) { return is_caster(i) && i != self; }),
                                      scene.plane, sg, tables, nullptr, &theta_without);
    const auto with =
        ShadeSurface(samples, albedo, trees([&](int i) { return !is_caster(i); }), scene.plane, sg, tables, &theta_without);
    for (size_t k = 0; k < samples.size(); ++k) {
      with_local.set_rgb(samples[k].pixel, with[k].cast<float>());
      without_local.set_rgb(samples[k].pixel, without[k].cast<float>());
    }
  }
  Report(progress, 0.7, "casters");

  // Virtual-object samples: direct light, then one bounce off the plane.
  Image coverage(w, h, 1), object_radiance(w, h, 3);
  std::vector<SurfaceSample> samples;
  for (auto& row : row_samples) samples.insert(samples.end(), row.begin(), row.end());
  std::vector<Eigen::Vector3d> radiance(samples.size(), Eigen::Vector3d::Zero());
  for (size_t o = 0; o < scene.objects.size(); ++o) {
    if (scene.objects[o].is_train) continue;
    std::vector<size_t> index;
    std::vector<SurfaceSample> mine;
    for (size_t k = 0; k < samples.size(); ++k)
      if (samples[k].object == static_cast<int>(o)) {
        index.push_back(k);
        mine.push_back(samples[k]);
      }
    if (mine.empty()) continue;
    const std::vector<Eigen::Vector3d> albedo(mine.size(), scene.objects[o].diffuse);
    const int self = static_cast<int>(o);
    const auto direct = ShadeSurface(mine, albedo, trees([&](int i) { return i != self; }), scene.plane, sg, tables);
    for (size_t k = 0; k < mine.size(); ++k) radiance[index[k]] = direct[k];
  }
  // The plane below as a uniform Lambertian emitter of the radiance it has
  // where n - up meets it: E = L_plane * pi * (1 - n.up) / 2 (the view factor
  // of a half-space), so the sample gains albedo * L_plane * (1 - n.up) / 2.
  {
    const Eigen::Vector3d& up = scene.plane.normal;
    std::vector<size_t> index;
    std::vector<Eigen::Vector3d> feet;
    std::vector<double> view;
    for (size_t k = 0; k < samples.size(); ++k) {
      const SurfaceSample& s = samples[k];
      const double side = up.dot(s.point - scene.plane.xyz) >= 0 ? 1.0 : -1.0;
      const Eigen::Vector3d down_normal = s.normal - side * up;
      const double f = (1 - side * s.normal.dot(up)) / 2;
      if (f <= 0 || down_normal.norm() == 0) continue;
      const Eigen::Vector3d d = down_normal.normalized();
      const auto t = IntersectPlane(scene.plane, s.point, d);
      if (!t) continue;
      const Eigen::Vector3d foot = s.point + *t * d;
      if (!PlaneRectContains(scene.plane, foot)) continue;
      index.push_back(k);
      feet.push_back(foot);
      view.push_back(f);
    }
    const std::vector<Eigen::Vector3f> plane_at_feet = RenderShadowPlane(PlaneModel(scene, feet, trees(is_any)), sg);
    for (size_t m = 0; m < index.size(); ++m) {
      const SurfaceSample& s = samples[index[m]];
      radiance[index[m]] += scene.objects[s.object].diffuse.cwiseProduct(plane_at_feet[m].cast<double>()) * view[m];
    }
  }
  for (size_t k = 0; k < samples.size(); ++k) {
    const int p = samples[k].pixel;
    object_radiance.set_rgb(p, object_radiance.rgb(p) + (radiance[k] / covered[p]).cast<float>());
  }
  for (size_t p = 0; p < n_pixels; ++p) coverage.data[p] = static_cast<float>(covered[p]) / (n * n);
  Report(progress, 1.0, "preview done");
  return Assemble(scene.image, with_local, without_local, coverage, object_radiance);
}

// ---- Final: the path tracer ---------------------------------------------------

CompositeResult CompositeFinal(const Scene& scene, const LightSet& lights, const CompositeOptions& options,
                               const ProgressFn& progress) {
  PathTraceOptions trace;
  trace.samples_per_pixel = options.samples_per_pixel;
  trace.max_bounces = options.max_bounces;
  trace.seed = options.seed;
  auto part = [&](double begin, const std::string& label) -> ProgressFn {
    if (!progress) return {};
    return [=](double f, const std::string&) { progress(begin + 0.5 * f, label); };
  };
  trace.objects = RenderObjects::kCasters;
  const Image without = RenderPathTraced(scene, lights, trace, part(0.0, "without objects"));
  trace.objects = RenderObjects::kAll;
  VirtualObjectSplit split;
  RenderPathTraced(scene, lights, trace, part(0.5, "with objects"), &split);
  Report(progress, 1.0, "final done");
  return Assemble(scene.image, split.rest_radiance, without, split.coverage, split.object_radiance);
}

}  // namespace

bool CompositeOptions::IsValid(std::string* error) const {
  auto fail = [&](const std::string& m) {
    if (error) *error = m;
    return false;
  };
  if (samples_per_pixel < 1) return fail("samples per pixel must be at least 1");
  if (max_bounces < 0) return fail("bounces must be non-negative");
  if (supersampling < 1 || supersampling > kMaxSupersampling)
    return fail("supersampling must be 1 to " + std::to_string(kMaxSupersampling) + " rays per pixel side");
  if (env_lobe_height < kMinEnvLobeHeight || env_lobe_height > kMaxEnvLobeHeight)
    return fail("env lobe height must be " + std::to_string(kMinEnvLobeHeight) + " to " +
                std::to_string(kMaxEnvLobeHeight) + " rows");
  return true;
}

SgLighting EnvMapToSgLobes(const Image& env, int height) {
  SHADOWSG_CHECK(height > 0);
  const Image map = ResampleEnvMap(env, height);
  const int w = map.width;
  const double lambda = std::min(kMaxLobeSharpness, 2.0 * height * height / M_PI);
  const double lobe_integral = 2 * M_PI * -std::expm1(-2 * lambda) / lambda;  // per unit amplitude
  SgLighting sg;
  for (int v = 0; v < height; ++v) {
    const double solid_angle = EnvTexelSolidAngle(v, w, height);
    for (int u = 0; u < w; ++u) {
      const Eigen::Vector3d radiance = map.rgb(map.index(u, v)).cast<double>();
      if (radiance.isZero()) continue;
      SgLobe lobe;
      lobe.axis = EnvTexelDirection(u, v, w, height);
      lobe.sharpness = lambda;
      lobe.amplitude = radiance * (solid_angle / lobe_integral);
      sg.lobes.push_back(lobe);
    }
  }
  return sg;
}

SgLobe SunToSgLobe(const SunLight& sun) {
  const double alpha = std::max(sun.angular_radius, kSunAngularRadius);
  SgLobe lobe;
  lobe.axis = sun.direction.normalized();
  lobe.sharpness = std::min(kMaxLobeSharpness, 2.0 / (alpha * alpha));
  lobe.amplitude = sun.irradiance * (lobe.sharpness / (2 * M_PI * -std::expm1(-2 * lobe.sharpness)));
  return lobe;
}

SgLighting PreviewSgLighting(const LightSet& lights, int env_lobe_height) {
  SHADOWSG_CHECK(lights.areas.empty());
  SgLighting sg;
  if (lights.sg) sg = *lights.sg;
  if (lights.env) {
    const SgLighting env = EnvMapToSgLobes(*lights.env, env_lobe_height);
    sg.lobes.insert(sg.lobes.end(), env.lobes.begin(), env.lobes.end());
  }
  for (const SunLight& sun : lights.suns) sg.lobes.push_back(SunToSgLobe(sun));
  return sg;
}

CompositeResult CompositeVirtualObjects(const Scene& scene, const LightSet& lights, const CompositeOptions& options,
                                        const ProgressFn& progress) {
  std::string error;
  SHADOWSG_CHECK(options.IsValid(&error));
  SHADOWSG_CHECK(scene.image.width == scene.camera.width && scene.image.height == scene.camera.height &&
                 scene.image.channels >= 3);
  return options.quality == CompositeQuality::kPreview ? CompositePreview(scene, lights, options, progress)
                                                       : CompositeFinal(scene, lights, options, progress);
}

}  // namespace shadowsg
