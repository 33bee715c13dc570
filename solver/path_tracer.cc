#include "solver/path_tracer.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <exception>
#include <mutex>
#include <optional>
#include <vector>

#include "calib/conventions.h"
#include "calib/error.h"
#include "solver/ray_caster.h"
#include "solver/sampling.h"
#include "solver/sg_shading.h"

namespace shadowsg {

namespace {

// Secondary rays start this far (times 1 + |p|_inf, in scene units) off the
// surface along its normal: well above Embree's single-precision hit error
// (~1e-7 relative) and well below any feature of a scene of unit size.
constexpr double kRayOffset = 1e-4;

double Mean(const Eigen::Vector3d& rgb) { return rgb.sum() / 3.0; }

Eigen::Vector3d OffsetOrigin(const Eigen::Vector3d& p, const Eigen::Vector3d& n) {
  return p + kRayOffset * (1.0 + p.cwiseAbs().maxCoeff()) * n;
}

// ---- Geometry: objects and the plane rectangle in one Embree scene ----------

struct SurfaceHit {
  double t = 0;
  Eigen::Vector3d point;
  Eigen::Vector3d normal;  // unit, facing the incoming ray
  Eigen::Vector3d albedo;
  bool plane_front = false;  // on the plane, seen from its normal's side
  bool virtual_object = false;  // on an object with is_train false
};

class RenderGeometry {
 public:
  RenderGeometry(const Scene& scene, const PathTraceOptions& options) : plane_(scene.plane) {
    for (const auto& o : scene.objects) {
      const bool take = options.objects == RenderObjects::kAll ||
                        (options.objects == RenderObjects::kCasters && o.is_train);
      if (!take) continue;
      const int id = caster_.AddMesh(o.WorldMesh());
      if (static_cast<int>(albedo_.size()) <= id) {
        albedo_.resize(id + 1);
        virtual_.resize(id + 1, 0);
      }
      albedo_[id] = o.diffuse;
      virtual_[id] = !o.is_train;
    }
    if (options.include_plane) {
      // The rectangle as two triangles: world = xyz + R^T local.
      const Eigen::Matrix3d rt = MinimalRotationToZ(plane_.normal).transpose();
      const double sx = plane_.scale.x(), sy = plane_.scale.y();
      TriangleMesh rect;
      for (const auto& c : {Eigen::Vector2d(-sx, -sy), Eigen::Vector2d(sx, -sy), Eigen::Vector2d(sx, sy),
                            Eigen::Vector2d(-sx, sy)})
        rect.vertices.push_back(plane_.xyz + rt * Eigen::Vector3d(c.x(), c.y(), 0));
      rect.faces = {{0, 1, 2}, {0, 2, 3}};
      plane_id_ = caster_.AddMesh(rect);
    }
    caster_.Commit();
  }

  std::optional<SurfaceHit> Intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir) const {
    const auto hit = caster_.Intersect(origin, dir);
    if (!hit) return std::nullopt;
    SurfaceHit s;
    s.t = hit->t;
    s.point = origin + hit->t * dir;
    if (hit->geometry == plane_id_) {
      // Embree's hit distance is single precision; the plane's is exact.
      if (const auto t = IntersectPlane(plane_, origin, dir)) {
        s.t = *t;
        s.point = origin + *t * dir;
      }
      s.plane_front = plane_.normal.dot(dir) < 0;
      s.normal = s.plane_front ? plane_.normal : Eigen::Vector3d(-plane_.normal);
      s.albedo = PlaneAlbedo(plane_, s.point);
    } else {
      s.normal = hit->normal;
      s.albedo = albedo_[hit->geometry];
      s.virtual_object = virtual_[hit->geometry];
    }
    return s;
  }

  bool Occluded(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double tmax = 1e30) const {
    return caster_.Occluded(origin, dir, 0, tmax);
  }

 private:
  const Plane& plane_;
  RayCaster caster_;
  std::vector<Eigen::Vector3d> albedo_;  // by geometry id
  std::vector<char> virtual_;            // by geometry id: is_train false
  int plane_id_ = -1;
};

// ---- Lights: evaluation and sampling ----------------------------------------

// A direction sampled towards a distant light (env map or SG).
struct LightSample {
  Eigen::Vector3d dir;       // towards the light
  Eigen::Vector3d radiance;  // arriving along -dir
  double pdf = 0;            // per unit solid angle
};

// Nearest texel of an env map (texel boundaries sit half-way between centres).
void EnvTexelOf(const Image& env, const Eigen::Vector3d& dir, int* u, int* v) {
  const Eigen::Vector2d t = EnvDirectionToTexel(dir, env.width, env.height);
  *u = ((static_cast<int>(std::floor(t.x() + 0.5)) % env.width) + env.width) % env.width;
  *v = std::clamp(static_cast<int>(std::floor(t.y() + 0.5)), 0, env.height - 1);
}

Eigen::Vector3d NearestEnvRadiance(const Image& env, const Eigen::Vector3d& dir) {
  int u, v;
  EnvTexelOf(env, dir, &u, &v);
  return env.rgb(env.index(u, v)).cast<double>();
}

// The env map as a piecewise-constant radiance over its texels. Two sampling
// densities, each constant over a texel (a texel is chosen from a 2-D CDF,
// then a direction uniformly in its phi and cos theta):
//   generic  texel weight = mean RGB x texel solid angle, for any vertex;
//   plane    the same times the texel's largest max(0, n_plane . w), for
//            vertices on the plane's front: NEE then follows L cos, and an
//            unoccluded plane point is estimated almost without variance.
//            It is positive wherever L cos is, so it is used there alone,
//            without MIS (see Integrator).
class EnvLight {
 public:
  EnvLight(const Image& env, const std::optional<Eigen::Vector3d>& plane_normal)
      : env_(env), w_(env.width), h_(env.height) {
    std::vector<double> weights(static_cast<size_t>(w_) * h_), plane_weights(weights.size(), 0.0);
    const double texel_radius = 0.5 * std::hypot(M_PI / h_, 2 * M_PI / w_);
    for (int v = 0; v < h_; ++v) {
      const double dw = EnvTexelSolidAngle(v, w_, h_);
      for (int u = 0; u < w_; ++u) {
        const size_t i = static_cast<size_t>(v) * w_ + u;
        weights[i] = std::max(0.0, Mean(Texel(u, v))) * dw;
        if (plane_normal) {
          // The largest cosine over the texel (bounded through its angular
          // radius), so that every texel reaching above the plane keeps a
          // positive density.
          const double angle = std::acos(std::clamp(plane_normal->dot(EnvTexelDirection(u, v, w_, h_)), -1.0, 1.0));
          const double closest = std::max(0.0, angle - texel_radius);
          if (closest < M_PI / 2) plane_weights[i] = weights[i] * std::cos(closest);
        }
      }
    }
    generic_ = Distribution2D(weights, w_, h_);
    if (plane_normal) plane_ = Distribution2D(plane_weights, w_, h_);
  }

  Eigen::Vector3d Texel(int u, int v) const { return env_.rgb(env_.index(u, v)).cast<double>(); }
  Eigen::Vector3d Radiance(const Eigen::Vector3d& dir) const { return NearestEnvRadiance(env_, dir); }
  bool CanSample(bool on_plane) const { return Dist(on_plane).total() > 0; }

  double Pdf(const Eigen::Vector3d& dir, bool on_plane) const {
    const Distribution2D& dist = Dist(on_plane);
    if (dist.total() <= 0) return 0;
    int u, v;
    EnvTexelOf(env_, dir, &u, &v);
    const double p_texel = dist.Density({(u + 0.5) / w_, (v + 0.5) / h_}) / (static_cast<double>(w_) * h_);
    return p_texel / EnvTexelSolidAngle(v, w_, h_);
  }

  LightSample Sample(const Eigen::Vector2d& r, bool on_plane) const {
    double pdf_xy = 0;
    const Eigen::Vector2d xy = Dist(on_plane).Sample(r, &pdf_xy);
    const double fu = xy.x() * w_, fv = xy.y() * h_;
    const int u = std::min(static_cast<int>(fu), w_ - 1), v = std::min(static_cast<int>(fv), h_ - 1);
    const double phi = 2 * M_PI * fu / w_ - M_PI;
    const double c0 = std::cos(M_PI * v / h_), c1 = std::cos(M_PI * (v + 1) / h_);
    const double cos_theta = c0 - (fv - v) * (c0 - c1);
    const double sin_theta = std::sqrt(std::max(0.0, 1 - cos_theta * cos_theta));
    LightSample s;
    s.dir = Eigen::Vector3d(std::cos(phi) * sin_theta, std::sin(phi) * sin_theta, cos_theta);
    s.radiance = Texel(u, v);
    s.pdf = pdf_xy / (static_cast<double>(w_) * h_) / EnvTexelSolidAngle(v, w_, h_);
    return s;
  }

 private:
  const Distribution2D& Dist(bool on_plane) const { return on_plane && !plane_.empty() ? plane_ : generic_; }

  const Image& env_;
  int w_, h_;
  Distribution2D generic_, plane_;
};

// SG lighting sampled per vertex: each lobe times the clamped cosine around
// the vertex normal is again (nearly) an SG, the product lobe of
// method-notes.md (cosine as the SG kCosineLobeSharpness/Amplitude). A lobe is
// chosen in proportion to its product's power (mean RGB), then a von
// Mises-Fisher direction of the product's axis and sharpness. The density is
// exact for that mixture, so the estimate stays unbiased where the cosine fit
// is coarse.
class SgLight {
 public:
  explicit SgLight(const SgLighting& sg) : sg_(sg) {}

  // The per-vertex mixture (reused buffers, one per thread).
  struct Mixture {
    std::vector<Eigen::Vector3d> axis;
    std::vector<double> kappa, cdf;  // cdf: size lobes + 1, normalised
    bool empty() const { return cdf.empty() || cdf.back() <= 0; }
  };

  void Prepare(const Eigen::Vector3d& n, Mixture* m) const {
    const size_t k = sg_.lobes.size();
    m->axis.resize(k);
    m->kappa.resize(k);
    m->cdf.assign(k + 1, 0.0);
    for (size_t i = 0; i < k; ++i) {
      const SgLobe& l = sg_.lobes[i];
      const Eigen::Vector3d sum = l.sharpness * l.axis + kCosineLobeSharpness * n;
      const double lp = std::max(sum.norm(), kMinSharpness);
      m->axis[i] = sum.norm() > 0 ? Eigen::Vector3d(sum / sum.norm()) : n;
      m->kappa[i] = lp;
      // Integral of the product lobe over the sphere: 2 pi a' (1 - e^{-2 lambda'}) / lambda'.
      const double amp = kCosineLobeAmplitude * Mean(l.amplitude) * std::exp(lp - l.sharpness - kCosineLobeSharpness);
      const double power = std::max(0.0, 2 * M_PI * amp * -std::expm1(-2 * lp) / lp);
      m->cdf[i + 1] = m->cdf[i] + (std::isfinite(power) ? power : 0.0);
    }
    const double total = m->cdf[k];
    if (total > 0)
      for (double& c : m->cdf) c /= total;
  }

  Eigen::Vector3d Radiance(const Eigen::Vector3d& dir) const { return EvalSg(sg_, dir); }

  double Pdf(const Mixture& m, const Eigen::Vector3d& dir) const {
    if (m.empty()) return 0;
    double pdf = 0;
    for (size_t i = 0; i < m.axis.size(); ++i) {
      const double p = m.cdf[i + 1] - m.cdf[i];
      if (p > 0) pdf += p * VmfPdf(m.axis[i], m.kappa[i], dir);
    }
    return pdf;
  }

  LightSample Sample(const Mixture& m, double pick, const Eigen::Vector2d& r) const {
    const auto it = std::upper_bound(m.cdf.begin(), m.cdf.end(), pick);
    size_t i = std::min<size_t>(std::max<ptrdiff_t>(it - m.cdf.begin() - 1, 0), m.axis.size() - 1);
    while (i > 0 && m.cdf[i + 1] - m.cdf[i] <= 0) --i;
    LightSample s;
    s.dir = SampleVmf(m.axis[i], m.kappa[i], r);
    s.radiance = Radiance(s.dir);
    s.pdf = Pdf(m, s.dir);
    return s;
  }

 private:
  // Keeps the vMF of a product lobe whose axes cancel numerically sound.
  static constexpr double kMinSharpness = 1e-6;
  const SgLighting& sg_;
};

// Solid-angle density of uniform area sampling of `a`, seen from o along d at distance t.
double AreaLightPdf(const AreaLight& a, const Eigen::Vector3d& d, double t) {
  const double cos_l = -a.Normal().dot(d);
  return cos_l > 0 ? t * t / (a.Area() * cos_l) : 0.0;
}

class Integrator {
 public:
  Integrator(const Scene& scene, const LightSet& lights, const PathTraceOptions& options)
      : geometry_(scene, options), lights_(lights), options_(options) {
    std::optional<Eigen::Vector3d> plane_normal;
    if (options.include_plane) plane_normal = scene.plane.normal;
    if (lights.env) env_.emplace(*lights.env, plane_normal);
    if (lights.sg) sg_.emplace(*lights.sg);
  }

  Eigen::Vector3d Distant(const Eigen::Vector3d& dir) const {
    Eigen::Vector3d l = Eigen::Vector3d::Zero();
    if (env_) l += env_->Radiance(dir);
    if (sg_) l += sg_->Radiance(dir);
    return l;
  }

  // Radiance along a camera ray; *first_virtual (optional) tells whether the
  // ray's first hit is a virtual object.
  Eigen::Vector3d Li(const Ray& camera_ray, RandomStream& rng, bool* first_virtual = nullptr) const {
    auto hit = geometry_.Intersect(camera_ray.origin, camera_ray.dir);
    if (first_virtual) *first_virtual = hit && hit->virtual_object;
    if (!hit) return Distant(camera_ray.dir);
    thread_local SgLight::Mixture sg_mixture;
    Eigen::Vector3d radiance = Eigen::Vector3d::Zero();
    Eigen::Vector3d beta = Eigen::Vector3d::Ones();
    for (int depth = 0;; ++depth) {
      const Eigen::Vector3d& n = hit->normal;
      const Eigen::Vector3d origin = OffsetOrigin(hit->point, n);
      if (sg_) sg_->Prepare(n, &sg_mixture);
      const Eigen::Vector3d f = hit->albedo / M_PI;  // Lambertian BRDF
      radiance += beta.cwiseProduct(f).cwiseProduct(DirectLight(*hit, origin, sg_mixture, rng));

      // BSDF sample: cosine-weighted, so beta * f * cos / pdf = beta * albedo.
      const Eigen::Vector3d wi = SampleCosineHemisphere(n, rng.Uniform2());
      const double cos_i = n.dot(wi);
      if (cos_i <= 0) break;
      const double pdf_bsdf = cos_i / M_PI;
      beta = beta.cwiseProduct(hit->albedo);
      if (beta.maxCoeff() <= 0) break;
      const auto next = geometry_.Intersect(origin, wi);
      const double t_surface = next ? next->t : 1e30;
      for (const auto& a : lights_.areas) {
        const auto t = IntersectAreaLight(a, origin, wi);
        if (t && *t < t_surface)
          radiance += beta.cwiseProduct(a.radiance) * PowerHeuristic(pdf_bsdf, AreaLightPdf(a, wi, *t));
      }
      if (!next) {
        // On the plane's front, env and SG come from their cosine-product
        // NEE alone (DirectLight); elsewhere the BSDF ray takes its MIS share.
        if (!hit->plane_front) {
          if (env_) radiance += beta.cwiseProduct(env_->Radiance(wi)) * PowerHeuristic(pdf_bsdf, env_->Pdf(wi, false));
          if (sg_)
            radiance += beta.cwiseProduct(sg_->Radiance(wi)) * PowerHeuristic(pdf_bsdf, sg_->Pdf(sg_mixture, wi));
        }
        break;
      }
      if (depth >= options_.max_bounces) break;
      hit = next;
    }
    return radiance;
  }

 private:
  // Next-event estimate of  integral L V cos  at the hit, one sample per
  // light kind, MIS-weighted against the BSDF for env, SG and area lights;
  // on the plane's front, env and SG samples follow L cos and stand alone.
  Eigen::Vector3d DirectLight(const SurfaceHit& hit, const Eigen::Vector3d& origin, const SgLight::Mixture& sg_mixture,
                              RandomStream& rng) const {
    const Eigen::Vector3d& n = hit.normal;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    auto distant = [&](const LightSample& s) {
      const double c = n.dot(s.dir);
      if (c <= 0 || s.pdf <= 0 || s.radiance.maxCoeff() <= 0) return;
      if (geometry_.Occluded(origin, s.dir)) return;
      sum += s.radiance * (c / s.pdf * (hit.plane_front ? 1.0 : PowerHeuristic(s.pdf, c / M_PI)));
    };
    if (env_ && env_->CanSample(hit.plane_front)) distant(env_->Sample(rng.Uniform2(), hit.plane_front));
    if (sg_ && !sg_mixture.empty()) {
      const double pick = rng.Uniform();
      distant(sg_->Sample(sg_mixture, pick, rng.Uniform2()));
    }
    for (const auto& sun : lights_.suns) {
      Eigen::Vector3d dir = sun.direction;
      double weight = 1;  // E cos for a delta sun
      if (sun.angular_radius > 0) {
        // Uniform radiance E / (pi sin^2 a) over the cone, sampled uniformly.
        dir = SampleUniformCone(sun.direction, sun.angular_radius, rng.Uniform2());
        const double s = std::sin(sun.angular_radius);
        weight = 1.0 / (M_PI * s * s * UniformConePdf(sun.angular_radius));
      }
      const double c = n.dot(dir);
      if (c <= 0 || geometry_.Occluded(origin, dir)) continue;
      sum += sun.irradiance * (c * weight);
    }
    for (const auto& a : lights_.areas) {
      const Eigen::Vector2d r = rng.Uniform2();
      const Eigen::Vector3d q = a.centre + (2 * r.x() - 1) * a.half_u + (2 * r.y() - 1) * a.half_v;
      const Eigen::Vector3d d = q - hit.point;
      const double dist = d.norm();
      if (dist <= 0) continue;
      const Eigen::Vector3d dir = d / dist;
      const double c = n.dot(dir);
      const double pdf = AreaLightPdf(a, dir, dist);
      if (c <= 0 || pdf <= 0) continue;
      if (geometry_.Occluded(origin, dir, (q - origin).norm() * (1 - 1e-6))) continue;
      sum += a.radiance * (c / pdf * PowerHeuristic(pdf, c / M_PI));
    }
    return sum;
  }

  RenderGeometry geometry_;
  const LightSet& lights_;
  const PathTraceOptions& options_;
  std::optional<EnvLight> env_;
  std::optional<SgLight> sg_;
};

}  // namespace

bool PathTraceOptions::IsValid(std::string* error) const {
  auto fail = [&](const std::string& m) {
    if (error) *error = m;
    return false;
  };
  if (samples_per_pixel < 1) return fail("samples per pixel must be at least 1");
  if (max_bounces < 0) return fail("bounces must be non-negative");
  return true;
}

Eigen::Vector3d RenderedDistantRadiance(const LightSet& lights, const Eigen::Vector3d& dir) {
  Eigen::Vector3d l = Eigen::Vector3d::Zero();
  if (lights.sg) l += EvalSg(*lights.sg, dir);
  if (lights.env) l += NearestEnvRadiance(*lights.env, dir);
  return l;
}

Image RenderPathTraced(const Scene& scene, const LightSet& lights, const PathTraceOptions& options,
                       const ProgressFn& progress, VirtualObjectSplit* split) {
  std::string error;
  SHADOWSG_CHECK(options.IsValid(&error));
  if (lights.env) SHADOWSG_CHECK(lights.env->width == 2 * lights.env->height && lights.env->channels >= 3);
  const Camera& cam = scene.camera;
  const int w = cam.width, h = cam.height;
  Image image(w, h, 3);
  if (split) {
    split->coverage = Image(w, h, 1);
    split->object_radiance = Image(w, h, 3);
    split->rest_radiance = Image(w, h, 3);
  }
  const Integrator integrator(scene, lights, options);

  std::atomic<int> rows_done{0};
  std::atomic<bool> stop{false};
  std::exception_ptr failure;  // written under progress_mutex
  std::mutex progress_mutex;
  Report(progress, 0.0);
#pragma omp parallel for schedule(dynamic, 1)
  for (int y = 0; y < h; ++y) {
    if (stop.load(std::memory_order_relaxed)) continue;
    for (int x = 0; x < w; ++x) {
      const uint64_t pixel = static_cast<uint64_t>(y) * w + x;
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      // The split: sums and counts of the samples whose first hit is a
      // virtual object and of the others (non-finite samples count as 0, as
      // in the image).
      Eigen::Vector3d sum_object = Eigen::Vector3d::Zero(), sum_rest = Eigen::Vector3d::Zero();
      int n_object = 0;
      for (int s = 0; s < options.samples_per_pixel; ++s) {
        RandomStream rng(options.seed, pixel, static_cast<uint64_t>(s));
        const Eigen::Vector2d jitter = rng.Uniform2() - Eigen::Vector2d::Constant(0.5);
        const Ray ray = PixelRay(cam, x + jitter.x(), y + jitter.y());
        bool first_virtual = false;
        const Eigen::Vector3d l = integrator.Li(ray, rng, split ? &first_virtual : nullptr);
        if (l.allFinite()) sum += l;
        if (split) {
          n_object += first_virtual;
          if (l.allFinite()) (first_virtual ? sum_object : sum_rest) += l;
        }
      }
      image.set_rgb(pixel, (sum / options.samples_per_pixel).cast<float>());
      if (split) {
        const int n_rest = options.samples_per_pixel - n_object;
        split->coverage.data[pixel] = static_cast<float>(static_cast<double>(n_object) / options.samples_per_pixel);
        if (n_object > 0) split->object_radiance.set_rgb(pixel, (sum_object / n_object).cast<float>());
        if (n_rest > 0) split->rest_radiance.set_rgb(pixel, (sum_rest / n_rest).cast<float>());
      }
    }
    const int done = ++rows_done;
    // Whichever worker finishes a row reports, one at a time; a report that
    // cannot get the lock is skipped (the next row reports).
    if (progress && progress_mutex.try_lock()) {
      try {
        if (!failure && done < h) Report(progress, static_cast<double>(done) / h);
      } catch (...) {
        failure = std::current_exception();
        stop = true;
      }
      progress_mutex.unlock();
    }
  }
  if (failure) std::rethrow_exception(failure);
  Report(progress, 1.0);
  return image;
}

}  // namespace shadowsg
