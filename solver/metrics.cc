#include "solver/metrics.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "calib/conventions.h"
#include "calib/error.h"
#include "solver/envmap.h"

namespace shadowsg {

ImageMetrics CompareImages(const Image& render, const Image& gt, const Image& mask) {
  SHADOWSG_CHECK(render.width == gt.width && render.height == gt.height);
  SHADOWSG_CHECK(mask.width == gt.width && mask.height == gt.height);
  ImageMetrics m;
  double range = 0, se = 0, gt2 = 0;
  for (size_t p = 0; p < gt.pixels(); ++p) {
    if (mask.data[p * mask.channels] == 0) continue;
    ++m.pixels;
    for (int c = 0; c < 3; ++c) {
      const double g = gt.data[p * gt.channels + std::min(c, gt.channels - 1)];
      const double r = std::max(0.0f, render.data[p * render.channels + std::min(c, render.channels - 1)]);
      range = std::max(range, g);
      se += (r - g) * (r - g);
      gt2 += g * g;
    }
  }
  if (m.pixels == 0) return m;
  const double mse = se / (3.0 * m.pixels);
  m.psnr = mse > 0 && range > 0 ? 10 * std::log10(range * range / mse) : (mse == 0 ? 100.0 : 0.0);
  m.rel_rmse = gt2 > 0 ? std::sqrt(se / gt2) : 0;
  m.ssim = MaskedSsim(render, gt, mask, range > 0 ? range : 1.0);
  return m;
}

namespace {

// Separable Gaussian blur with an 11-tap kernel (sigma 1.5), zero padding.
std::vector<double> Blur(const std::vector<double>& in, int w, int h) {
  constexpr int kRadius = 5;
  constexpr double kSigma = 1.5;
  double k[2 * kRadius + 1], ksum = 0;
  for (int i = -kRadius; i <= kRadius; ++i) ksum += k[i + kRadius] = std::exp(-i * i / (2 * kSigma * kSigma));
  for (double& v : k) v /= ksum;
  std::vector<double> tmp(in.size(), 0.0), out(in.size(), 0.0);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      double s = 0;
      for (int i = -kRadius; i <= kRadius; ++i) {
        const int xx = x + i;
        if (xx >= 0 && xx < w) s += k[i + kRadius] * in[static_cast<size_t>(y) * w + xx];
      }
      tmp[static_cast<size_t>(y) * w + x] = s;
    }
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      double s = 0;
      for (int i = -kRadius; i <= kRadius; ++i) {
        const int yy = y + i;
        if (yy >= 0 && yy < h) s += k[i + kRadius] * tmp[static_cast<size_t>(yy) * w + x];
      }
      out[static_cast<size_t>(y) * w + x] = s;
    }
  return out;
}

}  // namespace

double MaskedSsim(const Image& render, const Image& gt, const Image& mask, double range) {
  const int w = gt.width, h = gt.height;
  const size_t n = gt.pixels();
  const double c1 = (0.01 * range) * (0.01 * range), c2 = (0.03 * range) * (0.03 * range);
  double total = 0;
  size_t count = 0;
  for (int c = 0; c < 3; ++c) {
    std::vector<double> x(n, 0.0), y(n, 0.0);
    for (size_t p = 0; p < n; ++p) {
      if (mask.data[p * mask.channels] == 0) continue;
      x[p] = std::max(0.0f, render.data[p * render.channels + std::min(c, render.channels - 1)]);
      y[p] = gt.data[p * gt.channels + std::min(c, gt.channels - 1)];
    }
    std::vector<double> xx(n), yy(n), xy(n);
    for (size_t p = 0; p < n; ++p) {
      xx[p] = x[p] * x[p];
      yy[p] = y[p] * y[p];
      xy[p] = x[p] * y[p];
    }
    const auto mx = Blur(x, w, h), my = Blur(y, w, h);
    const auto sxx = Blur(xx, w, h), syy = Blur(yy, w, h), sxy = Blur(xy, w, h);
    for (size_t p = 0; p < n; ++p) {
      if (mask.data[p * mask.channels] == 0) continue;
      const double vx = sxx[p] - mx[p] * mx[p], vy = syy[p] - my[p] * my[p], cxy = sxy[p] - mx[p] * my[p];
      total += ((2 * mx[p] * my[p] + c1) * (2 * cxy + c2)) /
               ((mx[p] * mx[p] + my[p] * my[p] + c1) * (vx + vy + c2));
      ++count;
    }
  }
  return count ? total / count : 0;
}

std::vector<Eigen::Vector3d> HemisphereNormals(int count) {
  std::vector<Eigen::Vector3d> normals;
  const double golden = M_PI * (3 - std::sqrt(5.0));
  for (int i = 0; i < count; ++i) {
    const double z = 1 - (i + 0.5) / count;  // cos(theta) in (0, 1)
    const double r = std::sqrt(1 - z * z);
    normals.emplace_back(r * std::cos(golden * i), r * std::sin(golden * i), z);
  }
  return normals;
}

EnvMetrics CompareEnvMaps(const Image& estimate, const Image& gt) {
  const Image est = ResampleEnvMap(estimate, kEnvMetricHeight);
  const Image ref = ResampleEnvMap(gt, kEnvMetricHeight);
  const int W = est.width, H = est.height;
  EnvMetrics m;
  double angle_sum = 0, weight_sum = 0;
  for (int v = 0; v < H / 2; ++v) {  // rows with theta < pi/2
    const double dw = EnvTexelSolidAngle(v, W, H);
    for (int u = 0; u < W; ++u) {
      const Eigen::Vector3d a = est.rgb(est.index(u, v)).cast<double>().cwiseMax(0.0);
      const Eigen::Vector3d b = ref.rgb(ref.index(u, v)).cast<double>().cwiseMax(0.0);
      double angle;
      if (a.norm() == 0 && b.norm() == 0) angle = 0;
      else if (a.norm() == 0 || b.norm() == 0) angle = 90;
      else angle = std::acos(std::clamp(a.dot(b) / (a.norm() * b.norm()), -1.0, 1.0)) * 180 / M_PI;
      angle_sum += dw * angle;
      weight_sum += dw;
    }
  }
  m.angular_error_deg = angle_sum / weight_sum;
  double se = 0, ref2 = 0;
  for (const auto& n : HemisphereNormals(kIrradianceNormals)) {
    const Eigen::Vector3d e = EnvIrradiance(est, n), g = EnvIrradiance(ref, n);
    se += (e - g).squaredNorm();
    ref2 += g.squaredNorm();
  }
  m.irradiance_rel_rmse = ref2 > 0 ? std::sqrt(se / ref2) : 0;
  return m;
}

}  // namespace shadowsg
