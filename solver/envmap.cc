#include "solver/envmap.h"

#include <algorithm>
#include <cmath>

#include "calib/conventions.h"
#include "calib/error.h"

namespace shadowsg {

Image MakeEnvMap(int height, const std::function<Eigen::Vector3d(const Eigen::Vector3d&)>& radiance) {
  const int width = 2 * height;
  Image env(width, height, 3);
  for (int v = 0; v < height; ++v)
    for (int u = 0; u < width; ++u)
      env.set_rgb(env.index(u, v), radiance(EnvTexelDirection(u, v, width, height)).cast<float>());
  return env;
}

Eigen::Vector3d SampleEnvMap(const Image& env, const Eigen::Vector3d& dir) {
  const Eigen::Vector2d t = EnvDirectionToTexel(dir, env.width, env.height);
  const double fu = t.x(), fv = std::clamp(t.y(), 0.0, env.height - 1.0);
  const int u0 = static_cast<int>(std::floor(fu)), v0 = static_cast<int>(std::floor(fv));
  const double au = fu - u0, av = fv - v0;
  auto texel = [&](int u, int v) -> Eigen::Vector3d {
    u = ((u % env.width) + env.width) % env.width;
    v = std::clamp(v, 0, env.height - 1);
    return env.rgb(env.index(u, v)).cast<double>();
  };
  return (1 - av) * ((1 - au) * texel(u0, v0) + au * texel(u0 + 1, v0)) +
         av * ((1 - au) * texel(u0, v0 + 1) + au * texel(u0 + 1, v0 + 1));
}

Image ResampleEnvMap(const Image& env, int height) {
  SHADOWSG_CHECK(env.height > 0 && env.width == 2 * env.height && height > 0);
  if (height == env.height) return env;
  const int width = 2 * height;
  Image out(width, height, 3);
  // Overlap of source rows/columns with target ones, in units of the source
  // grid; rows are weighted by their solid angle so that the average is an
  // area average on the sphere.
  const double ry = static_cast<double>(env.height) / height;
  const double rx = static_cast<double>(env.width) / width;
  for (int v = 0; v < height; ++v) {
    const double y0 = v * ry, y1 = (v + 1) * ry;
    for (int u = 0; u < width; ++u) {
      const double x0 = u * rx, x1 = (u + 1) * rx;
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      double wsum = 0;
      for (int sy = static_cast<int>(std::floor(y0)); sy < std::ceil(y1) && sy < env.height; ++sy) {
        const double oy = std::min(y1, sy + 1.0) - std::max(y0, static_cast<double>(sy));
        if (oy <= 0) continue;
        const double row_w = EnvTexelSolidAngle(sy, env.width, env.height) * oy;
        for (int sx = static_cast<int>(std::floor(x0)); sx < std::ceil(x1) && sx < env.width; ++sx) {
          const double ox = std::min(x1, sx + 1.0) - std::max(x0, static_cast<double>(sx));
          if (ox <= 0) continue;
          sum += row_w * ox * env.rgb(env.index(sx, sy)).cast<double>();
          wsum += row_w * ox;
        }
      }
      out.set_rgb(out.index(u, v), (wsum > 0 ? sum / wsum : sum).cast<float>());
    }
  }
  return out;
}

Eigen::Vector3d EnvIrradiance(const Image& env, const Eigen::Vector3d& normal) {
  Eigen::Vector3d e = Eigen::Vector3d::Zero();
  for (int v = 0; v < env.height; ++v) {
    const double dw = EnvTexelSolidAngle(v, env.width, env.height);
    for (int u = 0; u < env.width; ++u) {
      const double c = normal.dot(EnvTexelDirection(u, v, env.width, env.height));
      if (c > 0) e += c * dw * env.rgb(env.index(u, v)).cast<double>();
    }
  }
  return e;
}

namespace {

// Texel centres closer than this (in texels) to a grid point coincide with it.
constexpr double kTexelCentreTolerance = 1e-6;

// `src` (layout `from`) re-laid out as `to`, same size.
Image Relayout(const Image& src, LatLongConvention from, LatLongConvention to) {
  SHADOWSG_CHECK(src.height > 0 && src.width == 2 * src.height && src.channels >= 3);
  const int w = src.width, h = src.height;
  Image out(w, h, 3);
  auto texel = [&](int u, int v) -> Eigen::Vector3d {
    u = ((u % w) + w) % w;
    v = std::clamp(v, 0, h - 1);
    return src.rgb(src.index(u, v)).cast<double>();
  };
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) {
      const Eigen::Vector2d t = LatLongDirectionToTexel(from, LatLongTexelDirection(to, u, v, w, h), w, h);
      const double ru = std::round(t.x()), rv = std::round(t.y());
      Eigen::Vector3d value;
      if (std::abs(t.x() - ru) < kTexelCentreTolerance && std::abs(t.y() - rv) < kTexelCentreTolerance) {
        value = texel(static_cast<int>(ru), static_cast<int>(rv));
      } else {
        const double fv = std::clamp(t.y(), 0.0, h - 1.0);
        const int u0 = static_cast<int>(std::floor(t.x())), v0 = static_cast<int>(std::floor(fv));
        const double au = t.x() - u0, av = fv - v0;
        value = (1 - av) * ((1 - au) * texel(u0, v0) + au * texel(u0 + 1, v0)) +
                av * ((1 - au) * texel(u0, v0 + 1) + au * texel(u0 + 1, v0 + 1));
      }
      out.set_rgb(out.index(u, v), value.cast<float>());
    }
  return out;
}

}  // namespace

Image EnvMapToLatLong(const Image& ours, LatLongConvention to) {
  return Relayout(ours, LatLongConvention::kShadowSg, to);
}

Image EnvMapFromLatLong(const Image& theirs, LatLongConvention from) {
  return Relayout(theirs, from, LatLongConvention::kShadowSg);
}

}  // namespace shadowsg
