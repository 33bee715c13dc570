#include "solver/metrics.h"

#include <gtest/gtest.h>

#include <cmath>

#include "solver/envmap.h"

namespace shadowsg {
namespace {

TEST(Metrics, PsnrAndRelRmseByHand) {
  // 2x1 image, both pixels on the plane. gt = (1,1,1), (0.5,0.5,0.5);
  // render = (0.9,1,1), (0.5,0.5,0.7). Errors: 0.01 and 0.04 over 6 values.
  Image gt(2, 1, 3), r(2, 1, 3), mask(2, 1, 1, 1.0f);
  gt.set_rgb(0, {1, 1, 1});
  gt.set_rgb(1, {0.5, 0.5, 0.5});
  r.set_rgb(0, {0.9f, 1, 1});
  r.set_rgb(1, {0.5, 0.5, 0.7f});
  const ImageMetrics m = CompareImages(r, gt, mask);
  const double mse = (0.01 + 0.04) / 6;
  EXPECT_NEAR(m.psnr, 10 * std::log10(1.0 / mse), 1e-5);
  EXPECT_NEAR(m.rel_rmse, std::sqrt(0.05 / 3.75), 1e-6);
  EXPECT_EQ(m.pixels, 2u);
}

TEST(Metrics, MaskAndClampAndRange) {
  // Masked-out pixels do not count; negative render values are clamped at 0;
  // R is the max of gt over the MASK only.
  Image gt(3, 1, 3), r(3, 1, 3), mask(3, 1, 1, 0.0f);
  gt.set_rgb(0, {2, 2, 2});
  gt.set_rgb(1, {100, 100, 100});  // outside the mask
  gt.set_rgb(2, {0, 0, 0});
  r.set_rgb(0, {2, 2, 2});
  r.set_rgb(1, {0, 0, 0});
  r.set_rgb(2, {-1, -1, -1});
  mask.data[0] = mask.data[2] = 1;
  const ImageMetrics m = CompareImages(r, gt, mask);
  EXPECT_EQ(m.pixels, 2u);
  EXPECT_NEAR(m.psnr, 100.0, 1e-9);  // identical after clamping
}

TEST(Metrics, SsimIsOneForIdenticalAndLowerForNoise) {
  Image gt(32, 32, 3), mask(32, 32, 1, 1.0f);
  for (size_t i = 0; i < gt.data.size(); ++i) gt.data[i] = 0.5f + 0.4f * std::sin(0.37 * i);
  EXPECT_NEAR(CompareImages(gt, gt, mask).ssim, 1.0, 1e-9);
  Image noisy = gt;
  for (size_t i = 0; i < noisy.data.size(); ++i) noisy.data[i] += (i % 3 == 0 ? 0.1f : -0.1f);
  const double s = CompareImages(noisy, gt, mask).ssim;
  EXPECT_LT(s, 0.99);
  EXPECT_GT(s, 0.0);
}

TEST(Metrics, SsimConstantShiftByHand) {
  // Constant images x = a, y = b (whole image in the mask, away from borders
  // the window sums to 1): SSIM = (2ab + c1) / (a^2 + b^2 + c1).
  const int n = 40;
  Image x(n, n, 3, 0.6f), y(n, n, 3, 0.8f);
  Image full_mask(n, n, 1, 1.0f);
  const double c1 = 0.01 * 0.8 * 0.01 * 0.8;
  const double expected = (2 * 0.6 * 0.8 + c1) / (0.36 + 0.64 + c1);
  const double s = MaskedSsim(x, y, full_mask, 0.8);
  // Border pixels see zero padding; the interior dominates: check within 2 %.
  EXPECT_NEAR(s, expected, 0.02);
}

TEST(Metrics, EnvAngularAndIrradiance) {
  const Image a = MakeEnvMap(32, [](const Eigen::Vector3d&) { return Eigen::Vector3d(1, 0, 0); });
  const Image b = MakeEnvMap(64, [](const Eigen::Vector3d&) { return Eigen::Vector3d(0, 1, 0); });
  const EnvMetrics m = CompareEnvMaps(a, b);
  EXPECT_NEAR(m.angular_error_deg, 90.0, 1e-9);
  const EnvMetrics same = CompareEnvMaps(b, b);
  EXPECT_NEAR(same.angular_error_deg, 0.0, 1e-6);
  EXPECT_NEAR(same.irradiance_rel_rmse, 0.0, 1e-9);
  // Twice as bright: irradiance error exactly 1.
  const Image c = MakeEnvMap(64, [](const Eigen::Vector3d&) { return Eigen::Vector3d(0, 2, 0); });
  EXPECT_NEAR(CompareEnvMaps(c, b).irradiance_rel_rmse, 1.0, 1e-6);
  EXPECT_NEAR(CompareEnvMaps(c, b).angular_error_deg, 0.0, 1e-6);
  for (const auto& n : HemisphereNormals(64)) EXPECT_GT(n.z(), 0);
}

}  // namespace
}  // namespace shadowsg
