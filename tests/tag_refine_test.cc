// Tag corners refined on linear edges: on an sRGB-encoded photo of a small
// tag, libapriltag's square comes out ~1 % small; the refinement removes that.
#include "calib/tag_refine.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

#include "calib/pose_estimation.h"
#include "stages/io/image_io.h"
#include "synthetic_capture.h"

namespace shadowsg {
namespace {

TEST(TagRefine, RemovesTheDetectorsShrinkOnSrgbPhotos) {
  Camera cam;
  cam.width = 320;
  cam.height = 240;
  cam.fx = cam.fy = 300;
  cam.cx = 161.0;
  cam.cy = 118.5;
  double raw_ratio_sum = 0, refined_ratio_sum = 0;
  int n = 0;
  for (double tilt : {20.0, 45.0}) {
    Eigen::Matrix4d ground = Eigen::Matrix4d::Identity();
    ground.topLeftCorner<3, 3>() = (Eigen::AngleAxisd(tilt * M_PI / 180, Eigen::Vector3d::UnitX()) *
                                    Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()))
                                       .toRotationMatrix();
    ground.topRightCorner<3, 1>() = Eigen::Vector3d(0.02, -0.01, 1.2);
    testing::PlacedTag tag;
    tag.id = 7;
    tag.size = 0.16;
    Image linear = testing::PlaneRenderer(cam, 4).Render(ground, testing::TagsTexture({tag}), 0.8f);
    Image photo = linear;  // an 8-bit sRGB photo
    for (float& v : photo.data) v = std::round(SrgbEncode(v) * 255) / 255;
    const std::vector<TagDetection> det = DetectTags(photo, TagDetectorOptions());
    ASSERT_EQ(det.size(), 1u);
    Image decoded = photo;
    for (float& v : decoded.data) v = SrgbDecode(v);
    const auto refined = RefineTagCorners(decoded, det[0], MakeTagPattern("tag36h11", 7));
    ASSERT_TRUE(refined.has_value());
    const auto pts = TagCornerPoints(tag.size);
    std::array<Eigen::Vector2d, 4> truth;
    for (int k = 0; k < 4; ++k) truth[k] = *ProjectToPixel(cam, (ground * pts[k].homogeneous()).head<3>());
    auto edge = [](const std::array<Eigen::Vector2d, 4>& c) {
      double e = 0;
      for (int k = 0; k < 4; ++k) e += (c[k] - c[(k + 1) % 4]).norm() / 4;
      return e;
    };
    const double raw = edge(det[0].corners) / edge(truth), ref = edge(*refined) / edge(truth);
    double worst = 0;
    for (int k = 0; k < 4; ++k) worst = std::max(worst, ((*refined)[k] - truth[k]).norm());
    std::printf("tilt %.0f: edge %.1f px, detector %.4f, refined %.4f of the truth; refined corners within %.3f px\n",
                tilt, edge(truth), raw, ref, worst);
    EXPECT_LT(worst, 0.25);
    raw_ratio_sum += raw;
    refined_ratio_sum += ref;
    ++n;
  }
  EXPECT_LT(std::abs(refined_ratio_sum / n - 1), 0.003);
  EXPECT_LT(std::abs(refined_ratio_sum / n - 1), std::abs(raw_ratio_sum / n - 1));
}

TEST(TagRefine, HomographyMapsTheFourPoints) {
  const std::array<Eigen::Vector2d, 4> src = {Eigen::Vector2d(0, 0), Eigen::Vector2d(1, 0), Eigen::Vector2d(1, 1),
                                              Eigen::Vector2d(0, 1)};
  const std::array<Eigen::Vector2d, 4> dst = {Eigen::Vector2d(10, 20), Eigen::Vector2d(50, 22),
                                              Eigen::Vector2d(45, 70), Eigen::Vector2d(8, 60)};
  const Eigen::Matrix3d H = HomographyFrom4(src, dst);
  for (int k = 0; k < 4; ++k) EXPECT_NEAR(((H * src[k].homogeneous()).hnormalized() - dst[k]).norm(), 0, 1e-9);
}

}  // namespace
}  // namespace shadowsg
