#include "solver/sampling.h"

#include <gtest/gtest.h>

#include <cmath>

#include "calib/conventions.h"

namespace shadowsg {
namespace {

TEST(RandomStream, DeterministicAndInRange) {
  RandomStream a(7, 123, 4), b(7, 123, 4), c(7, 123, 5), d(8, 123, 4);
  double sum = 0;
  for (int i = 0; i < 1000; ++i) {
    const double x = a.Uniform();
    EXPECT_EQ(x, b.Uniform());
    EXPECT_GE(x, 0.0);
    EXPECT_LT(x, 1.0);
    sum += x;
  }
  EXPECT_NEAR(sum / 1000, 0.5, 0.03);
  EXPECT_NE(RandomStream(7, 123, 4).Uniform(), c.Uniform());
  EXPECT_NE(RandomStream(7, 123, 4).Uniform(), d.Uniform());
}

TEST(Distribution1D, FrequenciesFollowWeightsAndSkipEmptyCells) {
  const Distribution1D dist({1, 0, 3, 0});
  int counts[4] = {0, 0, 0, 0};
  RandomStream rng(1, 0, 0);
  const int n = 40000;
  for (int i = 0; i < n; ++i) {
    double pdf = 0;
    int cell = -1;
    const double x = dist.Sample(rng.Uniform(), &pdf, &cell);
    ASSERT_EQ(cell, static_cast<int>(x * 4));
    ++counts[cell];
    EXPECT_NEAR(pdf, dist.Density(cell), 1e-12);
  }
  EXPECT_EQ(counts[1], 0);
  EXPECT_EQ(counts[3], 0);
  EXPECT_NEAR(counts[0] / double(n), 0.25, 0.01);
  EXPECT_NEAR(dist.Density(2), 3.0, 1e-12);  // 0.75 probability over a cell of width 1/4
}

TEST(Distribution2D, SampledDensityMatchesDensity) {
  std::vector<double> w(6 * 4);
  for (size_t i = 0; i < w.size(); ++i) w[i] = (i % 5) * 0.5;
  const Distribution2D dist(w, 6, 4);
  RandomStream rng(2, 0, 0);
  double integral = 0;
  const int n = 20000;
  for (int i = 0; i < n; ++i) {
    double pdf = 0;
    const Eigen::Vector2d xy = dist.Sample(rng.Uniform2(), &pdf);
    EXPECT_NEAR(pdf, dist.Density(xy), 1e-9);
    EXPECT_GT(pdf, 0);
    integral += 1.0 / pdf;  // E[1/pdf] = measure of the support
  }
  double support = 0;
  for (double x : w) support += x > 0 ? 1.0 / w.size() : 0;
  EXPECT_NEAR(integral / n, support, 0.02 * support);
}

// E[1 / pdf] over a sampler's support is the support's solid angle.
template <typename Sample, typename Pdf>
double SupportSolidAngle(Sample sample, Pdf pdf, int n) {
  RandomStream rng(3, 0, 0);
  double sum = 0;
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d d = sample(rng.Uniform2());
    EXPECT_NEAR(d.norm(), 1.0, 1e-9);
    sum += 1.0 / pdf(d);
  }
  return sum / n;
}

TEST(DirectionSampling, DensitiesIntegrateToOne) {
  const Eigen::Vector3d axis = Eigen::Vector3d(0.3, -0.4, 0.8).normalized();
  EXPECT_NEAR(SupportSolidAngle([&](const Eigen::Vector2d& u) { return SampleCosineHemisphere(axis, u); },
                                [&](const Eigen::Vector3d& d) { return axis.dot(d) / M_PI; }, 20000),
              2 * M_PI, 0.05 * 2 * M_PI);
  const double angle = 0.2;
  EXPECT_NEAR(SupportSolidAngle([&](const Eigen::Vector2d& u) { return SampleUniformCone(axis, angle, u); },
                                [&](const Eigen::Vector3d& d) {
                                  EXPECT_GE(d.dot(axis), std::cos(angle) - 1e-9);
                                  return UniformConePdf(angle);
                                },
                                100),
              2 * M_PI * (1 - std::cos(angle)), 1e-12);
  for (double kappa : {0.5, 5.0, 200.0}) {
    // The density integrates to one over the sphere (quadrature on an env grid).
    double total = 0;
    const int h = 512, w = 2 * h;
    for (int v = 0; v < h; ++v)
      for (int u = 0; u < w; ++u)
        total += VmfPdf(axis, kappa, EnvTexelDirection(u, v, w, h)) * EnvTexelSolidAngle(v, w, h);
    EXPECT_NEAR(total, 1.0, 2e-3) << "kappa " << kappa;
    // Sampled directions concentrate as the density says: mean cosine = coth(k) - 1/k.
    RandomStream rng(4, 0, 0);
    double mean_cos = 0;
    const int n = 20000;
    for (int i = 0; i < n; ++i) mean_cos += SampleVmf(axis, kappa, rng.Uniform2()).dot(axis);
    EXPECT_NEAR(mean_cos / n, 1 / std::tanh(kappa) - 1 / kappa, 0.01) << "kappa " << kappa;
  }
}

TEST(PowerHeuristic, WeightsSumToOne) {
  EXPECT_NEAR(PowerHeuristic(2, 3) + PowerHeuristic(3, 2), 1.0, 1e-15);
  EXPECT_EQ(PowerHeuristic(0, 0), 0.0);
  EXPECT_EQ(PowerHeuristic(1, 0), 1.0);
}

}  // namespace
}  // namespace shadowsg
