#include "calib/camera.h"

#include <gtest/gtest.h>

namespace shadowsg {
namespace {

Camera TestCamera() {
  Camera c;
  c.width = 640;
  c.height = 480;
  c.fx = 500;
  c.fy = 510;
  c.cx = 319.5;
  c.cy = 239.5;
  Eigen::Matrix3d R = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  c.c2w.block<3, 3>(0, 0) = R;
  c.c2w.block<3, 1>(0, 3) = Eigen::Vector3d(0.5, -1, 2);
  return c;
}

TEST(Camera, PrincipalPointRayIsOpticalAxis) {
  const Camera c = TestCamera();
  const Ray r = PixelRay(c, c.cx, c.cy);
  EXPECT_NEAR((r.dir - c.Rotation().col(2)).norm(), 0, 1e-12);
  EXPECT_NEAR((r.origin - c.Centre()).norm(), 0, 1e-12);
}

TEST(Camera, KnownPointProjectsToKnownPixel) {
  Camera c = TestCamera();
  // A point at camera coordinates (1, -0.5, 4) lands at (fx*0.25+cx, fy*-0.125+cy).
  const Eigen::Vector3d pc(1, -0.5, 4);
  const Eigen::Vector3d pw = c.Rotation() * pc + c.Centre();
  const auto uv = ProjectToPixel(c, pw);
  ASSERT_TRUE(uv);
  EXPECT_NEAR(uv->x(), 500 * 0.25 + 319.5, 1e-9);
  EXPECT_NEAR(uv->y(), 510 * -0.125 + 239.5, 1e-9);
}

TEST(Camera, RayAndProjectionRoundTripWithDistortion) {
  Camera c = TestCamera();
  c.k1 = -0.28;
  c.k2 = 0.09;
  c.p1 = 0.001;
  c.p2 = -0.0005;
  c.k3 = -0.01;
  for (double u : {0.0, 100.0, 319.5, 639.0})
    for (double v : {0.0, 239.5, 479.0}) {
      const Ray r = PixelRay(c, u, v);
      const auto uv = ProjectToPixel(c, r.origin + 3.0 * r.dir);
      ASSERT_TRUE(uv);
      EXPECT_NEAR(uv->x(), u, 1e-6);
      EXPECT_NEAR(uv->y(), v, 1e-6);
    }
}

TEST(Camera, BehindCameraDoesNotProject) {
  const Camera c = TestCamera();
  EXPECT_FALSE(ProjectToPixel(c, c.Centre() - c.Rotation().col(2)));
}

TEST(Camera, OrthographicRoundTrip) {
  Camera c;
  c.projection = Projection::kOrthographic;
  c.width = 64;
  c.height = 48;
  c.znear = -100;
  c.zfar = 100;
  c.min_x = -2;
  c.max_x = 2;
  c.min_y = -1.5;
  c.max_y = 1.5;
  c.scale = 1;
  const Ray r = PixelRay(c, 10, 20);
  const auto uv = ProjectToPixel(c, r.origin + 5 * r.dir);
  ASSERT_TRUE(uv);
  EXPECT_NEAR(uv->x(), 10, 1e-9);
  EXPECT_NEAR(uv->y(), 20, 1e-9);
}

}  // namespace
}  // namespace shadowsg
