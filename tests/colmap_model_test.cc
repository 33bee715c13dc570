// COLMAP sparse models: binary and text readers/writers round-trip in memory,
// hand-made files in COLMAP's documented layouts, and the conversion of
// cameras and poses to the project's conventions.
#include "calib/colmap_model.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cstring>
#include <fstream>
#include <sstream>

#include "calib/error.h"
#include "test_util.h"

namespace shadowsg {
namespace {

namespace fs = std::filesystem;
using testing::TempDir;

ColmapModel SampleModel() {
  ColmapModel m;
  ColmapCamera c;
  c.id = 1;
  c.model = "OPENCV";
  c.width = 640;
  c.height = 480;
  c.params = {500.25, 501.5, 320.5, 240.5, -0.1, 0.01, 0.001, -0.002};
  m.cameras[c.id] = c;
  ColmapCamera c2;
  c2.id = 7;
  c2.model = "SIMPLE_RADIAL";
  c2.width = 320;
  c2.height = 240;
  c2.params = {300, 160, 120, 0.02};
  m.cameras[c2.id] = c2;
  ColmapImage a;
  a.id = 3;
  a.pose.qvec = Eigen::Vector4d(0.9, 0.1, -0.2, 0.3).normalized();
  a.pose.tvec = Eigen::Vector3d(0.5, -1.25, 3.0);
  a.camera_id = 1;
  a.name = "sub/photo 1.jpg";  // a folder and a space
  a.points2D = {{10.5, 20.25}, {100.0, 7.5}, {3, 4}};
  a.point3D_ids = {42, kColmapInvalidPoint3D, 43};
  m.images[a.id] = a;
  ColmapImage b;
  b.id = 4;
  b.camera_id = 7;
  b.name = "b.png";  // no 2D points: an empty line in images.txt
  m.images[b.id] = b;
  ColmapPoint3D p;
  p.id = 42;
  p.xyz = Eigen::Vector3d(1.0 / 3, -2.5, 7.125);
  p.rgb = {255, 0, 17};
  p.error = 0.375;
  p.track = {{3, 0}, {4, 12}};
  m.points.push_back(p);
  ColmapPoint3D q;
  q.id = 43;
  q.xyz = Eigen::Vector3d(0, 1, 2);
  q.track = {{3, 2}};
  m.points.push_back(q);
  return m;
}

void ExpectSameModel(const ColmapModel& a, const ColmapModel& b) {
  ASSERT_EQ(a.cameras.size(), b.cameras.size());
  for (const auto& [id, c] : a.cameras) {
    const ColmapCamera& d = b.cameras.at(id);
    EXPECT_EQ(c.model, d.model);
    EXPECT_EQ(c.width, d.width);
    EXPECT_EQ(c.height, d.height);
    EXPECT_EQ(c.params, d.params);
  }
  ASSERT_EQ(a.images.size(), b.images.size());
  for (const auto& [id, im] : a.images) {
    const ColmapImage& jm = b.images.at(id);
    EXPECT_EQ(im.name, jm.name);
    EXPECT_EQ(im.camera_id, jm.camera_id);
    EXPECT_EQ(im.pose.qvec, jm.pose.qvec);
    EXPECT_EQ(im.pose.tvec, jm.pose.tvec);
    EXPECT_EQ(im.points2D, jm.points2D);
    EXPECT_EQ(im.point3D_ids, jm.point3D_ids);
  }
  ASSERT_EQ(a.points.size(), b.points.size());
  for (size_t i = 0; i < a.points.size(); ++i) {
    EXPECT_EQ(a.points[i].id, b.points[i].id);
    EXPECT_EQ(a.points[i].xyz, b.points[i].xyz);
    EXPECT_EQ(a.points[i].rgb, b.points[i].rgb);
    EXPECT_EQ(a.points[i].error, b.points[i].error);
    ASSERT_EQ(a.points[i].track.size(), b.points[i].track.size());
    for (size_t k = 0; k < a.points[i].track.size(); ++k) {
      EXPECT_EQ(a.points[i].track[k].image_id, b.points[i].track[k].image_id);
      EXPECT_EQ(a.points[i].track[k].point2D_idx, b.points[i].track[k].point2D_idx);
    }
  }
}

TEST(ColmapModel, BinaryRoundTripInMemory) {
  const ColmapModel m = SampleModel();
  std::stringstream cams, ims, pts;
  WriteColmapCamerasBinary(cams, m);
  WriteColmapImagesBinary(ims, m);
  WriteColmapPointsBinary(pts, m);
  ColmapModel back;
  ReadColmapCamerasBinary(cams, "cameras.bin", &back);
  ReadColmapImagesBinary(ims, "images.bin", &back);
  ReadColmapPointsBinary(pts, "points3D.bin", &back);
  ExpectSameModel(m, back);
}

TEST(ColmapModel, TextRoundTripInMemoryIsExact) {
  const ColmapModel m = SampleModel();
  std::stringstream cams, ims, pts;
  WriteColmapCamerasText(cams, m);
  WriteColmapImagesText(ims, m);
  WriteColmapPointsText(pts, m);
  ColmapModel back;
  ReadColmapCamerasText(cams, "cameras.txt", &back);
  ReadColmapImagesText(ims, "images.txt", &back);
  ReadColmapPointsText(pts, "points3D.txt", &back);
  ExpectSameModel(m, back);  // 17 significant digits: doubles come back bit for bit
}

TEST(ColmapModel, ReadsCameraBinaryLayoutByteForByte) {
  // cameras.bin @3.8: u64 count; u32 id, i32 model id, u64 width, u64 height, f64 params.
  std::string bytes;
  auto put = [&](const auto& v) { bytes.append(reinterpret_cast<const char*>(&v), sizeof v); };
  put(uint64_t{1});
  put(uint32_t{5});
  put(int32_t{1});  // PINHOLE
  put(uint64_t{64});
  put(uint64_t{48});
  for (double p : {100.0, 110.0, 32.0, 24.0}) put(p);
  std::istringstream in(bytes);
  ColmapModel m;
  ReadColmapCamerasBinary(in, "cameras.bin", &m);
  ASSERT_EQ(m.cameras.count(5), 1u);
  EXPECT_EQ(m.cameras[5].model, "PINHOLE");
  EXPECT_EQ(m.cameras[5].params, (std::vector<double>{100, 110, 32, 24}));
  // One byte short: a clear error, not garbage.
  std::istringstream cut(bytes.substr(0, bytes.size() - 1));
  ColmapModel m2;
  try {
    ReadColmapCamerasBinary(cut, "cameras.bin", &m2);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("cameras.bin: truncated"), std::string::npos) << e.what();
  }
}

TEST(ColmapModel, ReadsCommentedTextAsColmapWritesIt) {
  // As COLMAP 3.8 writes them (doc/format.rst), with an image without points.
  std::istringstream cams(
      "# Camera list with one line of data per camera:\n"
      "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n"
      "# Number of cameras: 1\n"
      "1 SIMPLE_RADIAL 3072 2304 2559.81 1536 1152 -0.0204997\n");
  std::istringstream ims(
      "# Image list with two lines of data per image:\n"
      "1 0.851773 0.0165051 0.503764 -0.142941 -0.737434 1.02973 3.74354 1 P1180141.JPG\n"
      "2362.39 248.498 -1 1046.02 53.6093 28\n"
      "2 0.9 0 0 0.435889894354 0 0 0 1 P1180142.JPG\n"
      "\n");
  std::istringstream pts("# 3D point list\n28 1.5 -0.5 2.25 120 130 140 0.7 1 1 2 0\n");
  ColmapModel m;
  ReadColmapCamerasText(cams, "cameras.txt", &m);
  ReadColmapImagesText(ims, "images.txt", &m);
  ReadColmapPointsText(pts, "points3D.txt", &m);
  ASSERT_EQ(m.images.size(), 2u);
  EXPECT_EQ(m.images[1].name, "P1180141.JPG");
  ASSERT_EQ(m.images[1].point3D_ids.size(), 2u);
  EXPECT_EQ(m.images[1].point3D_ids[0], kColmapInvalidPoint3D);
  EXPECT_EQ(m.images[1].point3D_ids[1], 28u);
  EXPECT_TRUE(m.images[2].points2D.empty());
  ASSERT_EQ(m.points.size(), 1u);
  EXPECT_EQ(m.points[0].track.size(), 2u);
  EXPECT_EQ(m.FindImage("P1180142.JPG"), &m.images[2]);
  EXPECT_EQ(m.FindImage("/some/where/P1180142.JPG"), &m.images[2]);  // by file name
  EXPECT_EQ(m.FindImage("nope.jpg"), nullptr);
}

TEST(ColmapModel, TextErrorsNameFileAndLine) {
  std::istringstream cams("# c\n1 OPENCV 10 10 1 2 3\n");
  ColmapModel m;
  try {
    ReadColmapCamerasText(cams, "cameras.txt", &m);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("cameras.txt:2"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("OPENCV takes 8 parameters"), std::string::npos) << e.what();
  }
}

TEST(ColmapModel, FolderRoundTripBothFormatsAndRigModelsRejected) {
  TempDir tmp;
  const ColmapModel m = SampleModel();
  WriteColmapModel(tmp / "bin", m, ColmapFormat::kBinary);
  WriteColmapModel(tmp / "txt", m, ColmapFormat::kText);
  EXPECT_TRUE(IsColmapModelDir(tmp / "bin"));
  EXPECT_TRUE(IsColmapModelDir(tmp / "txt"));
  EXPECT_FALSE(IsColmapModelDir(tmp.path()));
  ExpectSameModel(m, ReadColmapModel(tmp / "bin"));
  ExpectSameModel(m, ReadColmapModel(tmp / "txt"));
  std::ofstream(tmp / "bin" / "rigs.bin") << "x";
  try {
    ReadColmapModel(tmp / "bin");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("rig model"), std::string::npos) << e.what();
  }
  EXPECT_THROW(ReadColmapModel(tmp.path()), InputError);  // no model files
}

TEST(ColmapModel, CameraConversionShiftsThePrincipalPoint) {
  ColmapCamera c;
  c.id = 1;
  c.width = 640;
  c.height = 480;
  c.model = "OPENCV";
  c.params = {500, 502, 320.5, 240.5, -0.1, 0.01, 0.001, -0.002};
  const Camera cam = ColmapCameraToCamera(c);
  EXPECT_EQ(cam.cx, 320.0);  // COLMAP's first pixel centre is (0.5, 0.5); ours (0, 0)
  EXPECT_EQ(cam.cy, 240.0);
  EXPECT_EQ(cam.fx, 500);
  EXPECT_EQ(cam.fy, 502);
  EXPECT_EQ(cam.k1, -0.1);
  EXPECT_EQ(cam.p2, -0.002);
  // And back.
  const ColmapCamera back = CameraToColmapCamera(cam);
  EXPECT_EQ(back.model, "OPENCV");
  EXPECT_EQ(back.params, c.params);
  Camera with_k3 = cam;
  with_k3.k3 = 0.05;
  EXPECT_EQ(CameraToColmapCamera(with_k3).model, "FULL_OPENCV");
  EXPECT_EQ(ColmapCameraToCamera(CameraToColmapCamera(with_k3)).k3, 0.05);

  c.model = "SIMPLE_RADIAL";
  c.params = {300, 160.5, 120.5, 0.02};
  const Camera sr = ColmapCameraToCamera(c);
  EXPECT_EQ(sr.fx, 300);
  EXPECT_EQ(sr.fy, 300);
  EXPECT_EQ(sr.k1, 0.02);
  EXPECT_EQ(sr.cx, 160);
  c.model = "OPENCV_FISHEYE";
  c.params.assign(8, 0.1);
  EXPECT_THROW(ColmapCameraToCamera(c), InputError);
}

TEST(ColmapModel, ImageCameraProjectsLikeColmap) {
  // A point projected COLMAP's way (x_c = R x_w + t, then K with its 0.5
  // convention) lands 0.5 px right and down of our projection.
  ColmapModel m = SampleModel();
  const ColmapImage& im = m.images.at(3);
  const Camera cam = ColmapImageCamera(m, im);
  const Eigen::Vector3d xw(0.2, -0.1, 0.4);
  const Eigen::Matrix3d R = Eigen::Quaterniond(im.pose.qvec[0], im.pose.qvec[1], im.pose.qvec[2], im.pose.qvec[3])
                                .toRotationMatrix();
  const Eigen::Vector3d xc = R * xw + im.pose.tvec;
  ASSERT_GT(xc.z(), 0);
  const auto& p = m.cameras.at(1).params;
  const double u = xc.x() / xc.z(), v = xc.y() / xc.z();
  const double r2 = u * u + v * v, radial = 1 + p[4] * r2 + p[5] * r2 * r2;
  const double ud = u * radial + 2 * p[6] * u * v + p[7] * (r2 + 2 * u * u);
  const double vd = v * radial + 2 * p[7] * u * v + p[6] * (r2 + 2 * v * v);
  const Eigen::Vector2d colmap_px(p[0] * ud + p[2], p[1] * vd + p[3]);
  const auto ours = ProjectToPixel(cam, xw);
  ASSERT_TRUE(ours.has_value());
  EXPECT_NEAR((OpenCvToColmapPixel(*ours) - colmap_px).norm(), 0, 1e-9)
      << "colmap " << colmap_px.transpose() << " ours " << ours->transpose();
}

}  // namespace
}  // namespace shadowsg
