// The dominant-plane fit: RANSAC + least squares on noisy points with an
// object and outliers, the scale-derived threshold and the orientation.
#include "calib/plane_fit.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <random>

namespace shadowsg {
namespace {

struct Cloud {
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector3d> cameras;
  Eigen::Vector3d normal;
  Eigen::Vector3d point;
};

// A tilted, offset plane with Gaussian noise, an object's points standing on
// it, uniform outliers, and cameras above it.
Cloud MakeCloud(int plane_points, double noise, int object_points, int outliers, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0, 1);
  std::uniform_real_distribution<double> uni(-1, 1);
  Cloud c;
  const Eigen::Matrix3d R = (Eigen::AngleAxisd(0.4, Eigen::Vector3d(1, 2, 0.5).normalized())).toRotationMatrix();
  c.normal = R * Eigen::Vector3d::UnitZ();
  c.point = Eigen::Vector3d(3, -1, 2);
  auto to_world = [&](const Eigen::Vector3d& local) { return Eigen::Vector3d(R * local + c.point); };
  for (int i = 0; i < plane_points; ++i)
    c.points.push_back(to_world({2 * uni(rng), 2 * uni(rng), noise * gauss(rng)}));
  for (int i = 0; i < object_points; ++i)  // a box 0.4 high
    c.points.push_back(to_world({0.2 * uni(rng), 0.2 * uni(rng), 0.2 + 0.2 * uni(rng)}));
  for (int i = 0; i < outliers; ++i) c.points.push_back(to_world({3 * uni(rng), 3 * uni(rng), 1.5 * uni(rng)}));
  for (int i = 0; i < 12; ++i) {
    const double a = 2 * M_PI * i / 12;
    c.cameras.push_back(to_world({2.5 * std::cos(a), 2.5 * std::sin(a), 1.5}));
  }
  return c;
}

double AngleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) * 180 / M_PI;
}

TEST(PlaneFit, RecoversTheGroundAmongObjectAndOutliers) {
  const Cloud c = MakeCloud(2000, 0.003, 600, 800, 1);
  PlaneRansacOptions o;
  o.inlier_threshold = PlaneInlierThreshold(c.points, c.cameras);
  EXPECT_GT(o.inlier_threshold, 0.01);  // 1 % of a ~2 viewing distance
  EXPECT_LT(o.inlier_threshold, 0.04);
  const auto fit = FitPlaneRansac(c.points, o);
  ASSERT_TRUE(fit.has_value());
  PlaneFitResult plane = *fit;
  EXPECT_EQ(OrientPlaneNormal(c.cameras, &plane), 0);
  EXPECT_LT(AngleDeg(plane.normal, c.normal), 0.1);  // oriented towards the cameras
  EXPECT_NEAR(c.normal.dot(plane.point - c.point), 0, 1e-3);
  // Every plane point is an inlier; the object's points (>= 0 above, mostly far) mostly not.
  int plane_in = 0, object_in = 0;
  for (int i = 0; i < 2000; ++i) plane_in += plane.inliers[i];
  for (int i = 2000; i < 2600; ++i) object_in += plane.inliers[i];
  EXPECT_EQ(plane_in, 2000);
  EXPECT_LT(object_in, 60);
  EXPECT_NEAR(plane.rms, 0.003, 0.002);
}

TEST(PlaneFit, DeterministicForASeedAndFlipsTowardsCameras) {
  const Cloud c = MakeCloud(500, 0.002, 100, 200, 2);
  PlaneRansacOptions o;
  o.inlier_threshold = 0.02;
  o.seed = 9;
  const auto a = FitPlaneRansac(c.points, o), b = FitPlaneRansac(c.points, o);
  ASSERT_TRUE(a && b);
  EXPECT_EQ(a->normal, b->normal);
  EXPECT_EQ(a->inliers, b->inliers);
  PlaneFitResult flipped = *a;
  flipped.normal = -flipped.normal;
  std::vector<Eigen::Vector3d> cams = c.cameras;
  cams.push_back(c.point - 3 * c.normal);  // one camera below
  EXPECT_EQ(OrientPlaneNormal(cams, &flipped), 1);
  EXPECT_GT(flipped.normal.dot(c.normal), 0.99);
}

TEST(PlaneFit, DegenerateInputsGiveNoPlane) {
  PlaneRansacOptions o;
  o.inlier_threshold = 0.1;
  EXPECT_FALSE(FitPlaneRansac({{0, 0, 0}, {1, 0, 0}}, o).has_value());
  std::vector<Eigen::Vector3d> line;
  for (int i = 0; i < 50; ++i) line.emplace_back(i, 2 * i, 0);
  EXPECT_FALSE(FitPlaneRansac(line, o).has_value());
  EXPECT_FALSE(LeastSquaresPlane(line).has_value());
  std::string why;
  o.inlier_threshold = 0;
  EXPECT_FALSE(o.IsValid(&why));
  EXPECT_NE(why.find("threshold"), std::string::npos);
}

TEST(PlaneFit, ScatteredPointsHoldNoDominantPlane) {
  // Uniform points in a cube: the best plane holds a small share only.
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> uni(-1, 1);
  std::vector<Eigen::Vector3d> pts;
  for (int i = 0; i < 2000; ++i) pts.emplace_back(uni(rng), uni(rng), uni(rng));
  PlaneRansacOptions o;
  o.inlier_threshold = 0.02;
  const auto fit = FitPlaneRansac(pts, o);
  ASSERT_TRUE(fit.has_value());
  EXPECT_LT(fit->num_inliers, 0.1 * pts.size());
}

}  // namespace
}  // namespace shadowsg
