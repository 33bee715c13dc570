#include "solver/observability.h"
#include "solver/primitives.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace shadowsg {
namespace {

struct Plane {
  std::vector<Eigen::Vector3d> points;
  std::vector<double> irradiance;
};

// A 4 x 4 plane at z = 0 on a 64 x 64 grid, with a shadow disc of radius 0.8
// behind an object at the origin (irradiance x 0.2 inside) and 2 % noise.
template <typename Light>
Plane MakePlane(Light light) {
  Plane p;
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(1.0, 0.02);
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x) {
      const Eigen::Vector3d q(-2 + 4 * (x + 0.5) / 64, -2 + 4 * (y + 0.5) / 64, 0);
      const double shadow = (q - Eigen::Vector3d(0.6, 0, 0)).norm() < 0.8 ? 0.2 : 1.0;
      p.points.push_back(q);
      p.irradiance.push_back(light(q) * shadow * noise(rng));
    }
  return p;
}

TEST(LitPlaneTrend, DistantLightIsUniformWhatTheShadowsLookLike) {
  const Plane p = MakePlane([](const Eigen::Vector3d&) { return 3.0; });
  const LitPlaneTrend t = MeasureLitPlaneTrend(p.points, Eigen::Vector3d::UnitZ(), p.irradiance);
  EXPECT_GT(t.lit_pixels, 1000);
  EXPECT_LT(t.ratio, 1.05);
  EXPECT_GE(t.ratio, 1.0);
}

TEST(LitPlaneTrend, NearPointLightFallsOffAcrossTheView) {
  // A point light 2.5 units up and 2 to the side: cos / r^2 across the plane.
  const Eigen::Vector3d lamp(-2, 0, 2.5);
  const Plane p = MakePlane([&](const Eigen::Vector3d& q) {
    const Eigen::Vector3d d = lamp - q;
    return 10 * d.normalized().z() / d.squaredNorm();
  });
  const LitPlaneTrend t = MeasureLitPlaneTrend(p.points, Eigen::Vector3d::UnitZ(), p.irradiance);
  EXPECT_GT(t.ratio, 2.0);
  EXPECT_GT(t.ratio, kNearLightTrend);
  // The same light far away (scaled to the same irradiance) is uniform again.
  const Eigen::Vector3d far = lamp.normalized() * 1000;
  const Plane q = MakePlane([&](const Eigen::Vector3d& x) {
    const Eigen::Vector3d d = far - x;
    return 1e7 * d.normalized().z() / d.squaredNorm();
  });
  EXPECT_LT(MeasureLitPlaneTrend(q.points, Eigen::Vector3d::UnitZ(), q.irradiance).ratio, 1.05);
}

TEST(LitPlaneTrend, TooFewOrNonFinitePixelsGiveNoAnswer) {
  std::vector<Eigen::Vector3d> pts(10, Eigen::Vector3d::Zero());
  std::vector<double> e(10, 1.0);
  EXPECT_EQ(MeasureLitPlaneTrend(pts, Eigen::Vector3d::UnitZ(), e).ratio, 0);
  pts.assign(100, Eigen::Vector3d::Zero());
  e.assign(100, std::nan(""));
  EXPECT_EQ(MeasureLitPlaneTrend(pts, Eigen::Vector3d::UnitZ(), e).ratio, 0);
}

// A ball on the plane: plane points near it are shadowed from some directions
// and not others; points far away see (almost) the whole sky; no points, no
// answer.
TEST(InformativeSkyShare, OnlyDirectionsThatSplitThePointsCount) {
  RayCaster ball;
  TriangleMesh m = MakeIcosphere(0.5, 3);
  for (Eigen::Vector3d& v : m.vertices) v.z() += 0.5;
  ball.AddMesh(m);
  ball.Commit();
  const Eigen::Vector3d n = Eigen::Vector3d::UnitZ();
  std::vector<Eigen::Vector3d> near, far;
  for (int i = 0; i < 64; ++i) {
    const double a = 2 * M_PI * i / 64;
    near.emplace_back(0.8 * std::cos(a), 0.8 * std::sin(a), 0);
    far.emplace_back(50 + std::cos(a), std::sin(a), 0);
  }
  const double share = InformativeSkyShare(n, near, ball);
  EXPECT_GT(share, 0.05);
  EXPECT_LT(share, 0.9);
  // Far away the ball hides only grazing directions (cosine weight ~0).
  EXPECT_LT(InformativeSkyShare(n, far, ball), 1e-4);
  EXPECT_EQ(InformativeSkyShare(n, {}, ball), 0.0);
  // One point cannot be split: every direction shadows all or none of it.
  EXPECT_EQ(InformativeSkyShare(n, {near[0]}, ball), 0.0);
}

}  // namespace
}  // namespace shadowsg
