#include "solver/light_envmap.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "calib/conventions.h"
#include "calib/error.h"
#include "solver/envmap.h"
#include "solver/sampling.h"
#include "solver/sg.h"

namespace shadowsg {

namespace {

void AddToTexelOf(Image* env, const Eigen::Vector3d& dir, const Eigen::Vector3d& irradiance) {
  const Eigen::Vector2d t = EnvDirectionToTexel(dir, env->width, env->height);
  const int u = ((static_cast<int>(std::floor(t.x() + 0.5)) % env->width) + env->width) % env->width;
  const int v = std::clamp(static_cast<int>(std::floor(t.y() + 0.5)), 0, env->height - 1);
  const Eigen::Vector3d l = irradiance / EnvTexelSolidAngle(v, env->width, env->height);
  for (int c = 0; c < 3; ++c) env->at(u, v, c) += static_cast<float>(l[c]);
}

}  // namespace

bool LightEnvMapOptions::IsValid(std::string* error) const {
  if (height < 1 || sun_directions < 1 || area_supersampling < 1) {
    if (error) *error = "env map height, sun directions and area supersampling must be positive";
    return false;
  }
  return true;
}

Image LightSetToEnvMap(const LightSet& lights, const LightEnvMapOptions& options) {
  std::string error;
  SHADOWSG_CHECK(options.IsValid(&error));
  const int h = options.height, w = 2 * h;
  Image env(w, h, 3, 0.0f);
  auto add = [&env](const Image& other) {
    for (size_t i = 0; i < env.pixels(); ++i) env.set_rgb(i, env.rgb(i) + other.rgb(i));
  };
  if (lights.sg) add(SgToEnvMap(*lights.sg, h));
  if (lights.env) add(ResampleEnvMap(*lights.env, h));

  for (const auto& sun : lights.suns) {
    if (sun.angular_radius <= 0) {
      AddToTexelOf(&env, sun.direction, sun.irradiance);
      continue;
    }
    // Equal-power directions over the disc (uniform radiance, so uniform in
    // solid angle): a stratified grid over the cone's (cos theta, phi).
    const int n = std::max(1, static_cast<int>(std::sqrt(static_cast<double>(options.sun_directions))));
    const Eigen::Vector3d share = sun.irradiance / (static_cast<double>(n) * n);
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j)
        AddToTexelOf(&env, SampleUniformCone(sun.direction, sun.angular_radius, {(i + 0.5) / n, (j + 0.5) / n}),
                     share);
  }

  if (!lights.areas.empty()) {
    const int n = options.area_supersampling;
#pragma omp parallel for schedule(dynamic, 4)
    for (int v = 0; v < h; ++v) {
      const double c0 = std::cos(M_PI * v / h), c1 = std::cos(M_PI * (v + 1) / h);
      for (int u = 0; u < w; ++u) {
        Eigen::Vector3d sum = Eigen::Vector3d::Zero();
        for (int i = 0; i < n; ++i)
          for (int j = 0; j < n; ++j) {
            // Uniform in solid angle within the texel: phi and cos theta.
            const double phi = 2 * M_PI * (u + (i + 0.5) / n) / w - M_PI;
            const double ct = c0 - (j + 0.5) / n * (c0 - c1);
            const double st = std::sqrt(std::max(0.0, 1 - ct * ct));
            const Eigen::Vector3d d(std::cos(phi) * st, std::sin(phi) * st, ct);
            // The nearest front-facing light along d is the one seen.
            double best = 1e300;
            const AreaLight* seen = nullptr;
            for (const auto& a : lights.areas) {
              const auto t = IntersectAreaLight(a, options.viewpoint, d);
              if (t && *t < best) {
                best = *t;
                seen = &a;
              }
            }
            if (seen) sum += seen->radiance;
          }
        const Eigen::Vector3f add_l = (sum / (static_cast<double>(n) * n)).cast<float>();
        env.set_rgb(env.index(u, v), env.rgb(env.index(u, v)) + add_l);
      }
    }
  }
  return env;
}

}  // namespace shadowsg
