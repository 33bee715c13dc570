#include "calib/conventions.h"

#include <ImfEnvmap.h>
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


// OpenEXR's own lat-long functions (ImfEnvmap.h) are the reference: the
// direction of each of our OpenEXR-layout texels must have the latitude and
// longitude that OpenEXR assigns to that texel's centre.
TEST(Conventions, UsdTexelsAgreeWithOpenExrLatLongMap) {
  const int W = 64, H = 32;
  for (int v = 0; v < H; v += 3)
    for (int u = 0; u < W; u += 5) {
      const Eigen::Vector3d d = UsdTexelDirection(u, v, W, H);
      const Imath::V2f ll = Imf::LatLongMap::latLong(Imath::V3f(d.x(), d.y(), d.z()));
      const double lat = M_PI / 2 - M_PI * (v + 0.5) / H;
      const double lon = M_PI - 2 * M_PI * (u + 0.5) / W;
      EXPECT_NEAR(ll.x, lat, 1e-5) << u << " " << v;
      EXPECT_NEAR(std::remainder(ll.y - lon, 2 * M_PI), 0, 1e-5) << u << " " << v;
    }
  // Their pixel positions differ from our texel centres by at most half a
  // texel (LatLongMap spreads the centres over [+pi, -pi] end to end).
  const Imath::Box2i window(Imath::V2i(0, 0), Imath::V2i(W - 1, H - 1));
  const Imath::V2f pos = Imf::LatLongMap::pixelPosition(window, Imath::V3f(0, 0, 1));  // longitude 0
  EXPECT_NEAR(pos.x, (W - 1) / 2.0, 1e-4);
  EXPECT_NEAR(LatLongDirectionToTexel(LatLongConvention::kOpenExr, UsdToWorldDirection({0, 0, 1}), W, H).x(),
              W / 2.0 - 0.5, 1e-9);
}

TEST(Conventions, WorldToUsdIsTheMinus90DegreeTurnAboutX) {
  Eigen::Matrix3d R;
  for (int i = 0; i < 3; ++i) R.col(i) = WorldToUsdDirection(Eigen::Vector3d::Unit(i));
  EXPECT_NEAR((R - Eigen::AngleAxisd(-M_PI / 2, Eigen::Vector3d::UnitX()).toRotationMatrix()).norm(), 0, 1e-12);
  // World up is the dome's pole, world -y its longitude 0, world +x longitude pi/2.
  EXPECT_NEAR((WorldToUsdDirection({0, 0, 1}) - Eigen::Vector3d(0, 1, 0)).norm(), 0, 1e-12);
  EXPECT_NEAR((WorldToUsdDirection({0, -1, 0}) - Eigen::Vector3d(0, 0, 1)).norm(), 0, 1e-12);
  EXPECT_NEAR((WorldToUsdDirection({1, 0, 0}) - Eigen::Vector3d(1, 0, 0)).norm(), 0, 1e-12);
}

// Cycles' direction_to_equirectangular (kernel/camera/projection.h):
// u = 0.5 - atan2(y, x) / (2 pi), v = 1 - acos(z) / pi, v from the bottom row.
TEST(Conventions, BlenderTexelsAgreeWithCyclesEquirectangular) {
  const int W = 64, H = 32;
  for (int v = 0; v < H; v += 3)
    for (int u = 0; u < W; u += 5) {
      const Eigen::Vector3d d = BlenderTexelDirection(u, v, W, H);
      const double cu = 0.5 - std::atan2(d.y(), d.x()) / (2 * M_PI);
      const double cv = 1 - std::acos(std::clamp(d.z(), -1.0, 1.0)) / M_PI;
      EXPECT_NEAR(std::remainder(cu * W - 0.5 - u, W), 0, 1e-9);
      EXPECT_NEAR((1 - cv) * H - 0.5, v, 1e-9);  // file rows count from the top
    }
  // Blender's image centre looks along +x and longitude grows to the left:
  // the map is ours mirrored in azimuth.
  EXPECT_NEAR(BlenderTexelDirection(W / 2.0 - 0.5, H / 2.0 - 0.5, W, H).x(), 1.0, 1e-12);
  EXPECT_GT(BlenderTexelDirection(W / 4.0 - 0.5, H / 2.0 - 0.5, W, H).y(), 0.99);
  EXPECT_LT(EnvTexelDirection(W / 4.0 - 0.5, H / 2.0 - 0.5, W, H).y(), -0.99);
}

TEST(Conventions, LatLongTexelDirectionsInvert) {
  for (const LatLongConvention c :
       {LatLongConvention::kShadowSg, LatLongConvention::kOpenExr, LatLongConvention::kBlender})
    for (const int H : {8, 9, 32}) {
      const int W = 2 * H;
      for (int v = 0; v < H; ++v)
        for (int u = 0; u < W; u += 3) {
          const Eigen::Vector2d t = LatLongDirectionToTexel(c, LatLongTexelDirection(c, u, v, W, H), W, H);
          EXPECT_NEAR(t.x(), u, 1e-9);
          EXPECT_NEAR(t.y(), v, 1e-9);
        }
    }
}

}  // namespace
}  // namespace shadowsg
