#include "calib/conventions.h"

#include <gtest/gtest.h>

#include <cmath>

namespace shadowsg {
namespace {

TEST(Conventions, EnvTexelDirectionMatchesSpec) {
  // Spec: phi = 2 pi (u + 0.5) / W - pi, theta = pi (v + 0.5) / H.
  const int W = 64, H = 32;
  const Eigen::Vector3d d = EnvTexelDirection(0, 0, W, H);
  const double phi = 2 * M_PI * 0.5 / W - M_PI, theta = M_PI * 0.5 / H;
  EXPECT_NEAR(d.x(), std::cos(phi) * std::sin(theta), 1e-12);
  EXPECT_NEAR(d.y(), std::sin(phi) * std::sin(theta), 1e-12);
  EXPECT_NEAR(d.z(), std::cos(theta), 1e-12);
  // Centre column of the map looks along +x at the horizon row boundary.
  const Eigen::Vector3d e = EnvTexelDirection(W / 2 - 0.5, H / 2 - 0.5, W, H);
  EXPECT_NEAR(e.x(), 1.0, 1e-12);
}

TEST(Conventions, EnvTexelRoundTrip) {
  const int W = 128, H = 64;
  for (int v = 0; v < H; v += 7)
    for (int u = 0; u < W; u += 5) {
      const Eigen::Vector2d t = EnvDirectionToTexel(EnvTexelDirection(u, v, W, H), W, H);
      EXPECT_NEAR(t.x(), u, 1e-9);
      EXPECT_NEAR(t.y(), v, 1e-9);
    }
}

TEST(Conventions, TexelSolidAnglesSumToSphere) {
  const int W = 64, H = 32;
  double total = 0;
  for (int v = 0; v < H; ++v) total += W * EnvTexelSolidAngle(v, W, H);
  EXPECT_NEAR(total, 4 * M_PI, 1e-12);
}

TEST(Conventions, MinimalRotationMapsNormalToZ) {
  const Eigen::Vector3d n = Eigen::Vector3d(0.3, -0.4, 0.8).normalized();
  EXPECT_NEAR((MinimalRotationToZ(n) * n - Eigen::Vector3d::UnitZ()).norm(), 0, 1e-12);
  EXPECT_NEAR((MinimalRotationToZ(Eigen::Vector3d::UnitZ()) - Eigen::Matrix3d::Identity()).norm(), 0, 1e-12);
}

TEST(Conventions, ColmapPixelShift) {
  const Eigen::Vector2d p(10.5, 20.5);
  EXPECT_EQ(ColmapToOpenCvPixel(p), Eigen::Vector2d(10, 20));
  EXPECT_EQ(OpenCvToColmapPixel(ColmapToOpenCvPixel(p)), p);
}

TEST(Conventions, ColmapPoseIsWorldToCameraHamilton) {
  // A quarter turn about z, w first: Hamilton gives R = [[0,-1,0],[1,0,0],[0,0,1]]
  // (JPL would give its transpose).
  ColmapPose pose;
  pose.qvec = Eigen::Vector4d(std::sqrt(0.5), 0, 0, std::sqrt(0.5));
  pose.tvec = Eigen::Vector3d(1, 2, 3);
  const Eigen::Matrix4d c2w = ColmapPoseToC2w(pose);
  const Eigen::Matrix3d R_wc = c2w.block<3, 3>(0, 0).transpose();
  EXPECT_NEAR(R_wc(0, 1), -1, 1e-12);
  EXPECT_NEAR(R_wc(1, 0), 1, 1e-12);
  // x_cam = R x_world + t: the camera centre maps to the camera origin.
  const Eigen::Vector3d centre = c2w.block<3, 1>(0, 3);
  EXPECT_NEAR((R_wc * centre + pose.tvec).norm(), 0, 1e-12);
  EXPECT_NEAR((centre - (-R_wc.transpose() * pose.tvec)).norm(), 0, 1e-12);
  // A world point in front of the camera: c2w maps its camera coordinates back.
  const Eigen::Vector3d xw(0.3, -0.2, 5.0);
  const Eigen::Vector3d xc = R_wc * xw + pose.tvec;
  EXPECT_NEAR((c2w.block<3, 3>(0, 0) * xc + centre - xw).norm(), 0, 1e-12);
}

TEST(Conventions, ColmapPoseRoundTripAndNormalisation) {
  ColmapPose pose;
  pose.qvec = Eigen::Vector4d(0.7, -0.1, 0.5, 0.3).normalized();
  pose.tvec = Eigen::Vector3d(-0.4, 1.5, 2.0);
  const ColmapPose back = C2wToColmapPose(ColmapPoseToC2w(pose));
  EXPECT_NEAR((back.qvec - pose.qvec).norm(), 0, 1e-12);
  EXPECT_NEAR((back.tvec - pose.tvec).norm(), 0, 1e-12);
  // A slightly non-unit quaternion (as rounded in a text model) still gives a rotation.
  ColmapPose rounded = pose;
  rounded.qvec *= 1.001;
  const Eigen::Matrix3d R = ColmapPoseToC2w(rounded).block<3, 3>(0, 0);
  EXPECT_NEAR((R.transpose() * R - Eigen::Matrix3d::Identity()).norm(), 0, 1e-12);
  // qw >= 0 on the way out (q and -q are the same rotation).
  ColmapPose negated = pose;
  negated.qvec = -pose.qvec;
  EXPECT_GE(C2wToColmapPose(ColmapPoseToC2w(negated)).qvec[0], 0);
}

TEST(Conventions, UsdRoundTripAndAxes) {
  const Eigen::Vector3d d = Eigen::Vector3d(0.2, -0.5, 0.7).normalized();
  EXPECT_NEAR((UsdToWorldDirection(WorldToUsdDirection(d)) - d).norm(), 0, 1e-12);
  EXPECT_NEAR((WorldToUsdDirection(Eigen::Vector3d::UnitZ()) - Eigen::Vector3d::UnitY()).norm(), 0, 1e-12);
  // USD: top row is +Y (up); longitude 0 (centre column) looks along +Z.
  EXPECT_GT(UsdTexelDirection(10, 0, 64, 32).y(), 0.99);
  EXPECT_NEAR(UsdTexelDirection(31.5, 15.5, 64, 32).z(), 1.0, 1e-9);
}

}  // namespace
}  // namespace shadowsg
