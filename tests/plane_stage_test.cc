// `shadowsg plane` without running COLMAP: sparse models made from a known
// scene (cameras on a ring, points on the ground and on a box) in an
// arbitrary similarity frame, as COLMAP would give them; the registered frame,
// the metric scale from a known distance, and the errors.
#include "stages/plane_stage.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <fstream>
#include <random>

#include "calib/error.h"
#include "stages/io/capture_io.h"
#include "stages/io/image_io.h"
#include "stages/synth_stage.h"
#include "multiview_capture.h"
#include "quiet_context.h"
#include "test_util.h"

namespace shadowsg {
namespace {

namespace fs = std::filesystem;
using testing::AlignAboutZ;
using testing::RotationAngleDeg;
using testing::TempDir;

struct ModelCase {
  ColmapModel model;
  std::map<std::string, Eigen::Matrix4d> truth;  // c2w in the true (metric) world
  Camera lens;
  Eigen::Matrix4d gt_to_model;  // similarity: x_model = gt_to_model * x_true
  double model_units_per_metre;
  std::vector<uint64_t> ground_ids;  // two plane points
  Eigen::Vector3d ground_a, ground_b;  // their true positions
};

// `views` cameras on a ring (hero = "hero.png"), `ground` plane points with
// noise `noise` (metres), `box` points on a box standing on the plane.
ModelCase MakeModel(int views, int ground, int box, double noise, uint64_t seed) {
  ModelCase mc;
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uni(-1, 1);
  std::normal_distribution<double> gauss(0, 1);
  mc.lens.width = 320;
  mc.lens.height = 240;
  mc.lens.fx = mc.lens.fy = 300;
  mc.lens.cx = 159.5;
  mc.lens.cy = 119.5;
  // COLMAP's frame: an arbitrary rotation, offset and scale of the true one.
  mc.model_units_per_metre = 3.7;
  Eigen::Matrix4d S = Eigen::Matrix4d::Identity();
  S.topLeftCorner<3, 3>() = mc.model_units_per_metre *
                            Eigen::AngleAxisd(1.1, Eigen::Vector3d(0.3, -1, 0.2).normalized()).toRotationMatrix();
  S.topRightCorner<3, 1>() = Eigen::Vector3d(5, -2, 0.7);
  mc.gt_to_model = S;
  auto to_model = [&](const Eigen::Vector3d& x) { return Eigen::Vector3d((S * x.homogeneous()).head<3>()); };

  ColmapCamera cam = CameraToColmapCamera(mc.lens);
  cam.id = 1;
  mc.model.cameras[1] = cam;
  auto add_image = [&](const std::string& name, const Eigen::Matrix4d& c2w_true) {
    mc.truth[name] = c2w_true;
    Eigen::Matrix4d c2w_model = Eigen::Matrix4d::Identity();
    c2w_model.topLeftCorner<3, 3>() = S.topLeftCorner<3, 3>() / mc.model_units_per_metre * c2w_true.topLeftCorner<3, 3>();
    c2w_model.topRightCorner<3, 1>() = to_model(c2w_true.topRightCorner<3, 1>());
    ColmapImage im;
    im.id = static_cast<colmap_image_t>(mc.model.images.size() + 1);
    im.camera_id = 1;
    im.name = name;
    im.pose = C2wToColmapPose(c2w_model);
    mc.model.images[im.id] = im;
  };
  for (int i = 0; i < views; ++i) {
    const double az = 2 * M_PI * i / views;
    char name[32];
    std::snprintf(name, sizeof name, "view_%02d.png", i);
    add_image(name, LookAt(Eigen::Vector3d(1.3 * std::cos(az), 1.3 * std::sin(az), 0.9), Eigen::Vector3d(0, 0, 0.05),
                           Eigen::Vector3d::UnitZ()));
  }
  add_image("hero.png", LookAt(Eigen::Vector3d(0.35, -1.3, 1.0), Eigen::Vector3d(0.1, -0.05, 0.05),
                               Eigen::Vector3d::UnitZ()));
  uint64_t id = 1;
  auto add_point = [&](const Eigen::Vector3d& x_true) {
    ColmapPoint3D p;
    p.id = id++;
    p.xyz = to_model(x_true);
    mc.model.points.push_back(p);
    return p.id;
  };
  mc.ground_a = Eigen::Vector3d(-0.3, 0.2, 0);
  mc.ground_b = Eigen::Vector3d(0.5, -0.4, 0);
  mc.ground_ids = {add_point(mc.ground_a), add_point(mc.ground_b)};
  for (int i = 0; i < ground; ++i) add_point({uni(rng), 0.8 * uni(rng), noise * gauss(rng)});
  for (int i = 0; i < box; ++i) add_point({0.1 * uni(rng), 0.08 * uni(rng), 0.15 + 0.15 * uni(rng)});
  return mc;
}

PlaneStageOptions Options() {
  PlaneStageOptions o;
  o.colmap_model = "unused";
  o.hero = "hero.png";
  return o;
}

using shadowsg::testing::QuietContext;

TEST(PlaneStage, RegisteredFrameAndMetricScaleFromTwoPoints) {
  const ModelCase mc = MakeModel(16, 1500, 400, 0.001, 1);
  PlaneStageOptions o = Options();
  o.distance = (mc.ground_a - mc.ground_b).norm();
  o.distance_points = mc.ground_ids;
  const PlaneStageResult r = RegisterPlane(mc.model, o, QuietContext());
  EXPECT_EQ(r.scale_source, "distance");
  EXPECT_NEAR(r.scale * mc.model_units_per_metre, 1.0, 1e-9);
  EXPECT_EQ(r.registered_images, 17);
  EXPECT_EQ(r.cameras_below, 0);
  EXPECT_EQ(r.hero_intrinsics, "colmap");
  EXPECT_NEAR(r.hero.cx, mc.lens.cx, 1e-9);  // through COLMAP's pixel convention and back
  // The registered frame differs from the true one by a turn about z and a
  // shift in the plane only: align on the camera centres.
  std::vector<Eigen::Vector3d> est, gt;
  for (const auto& [name, c2w] : r.cameras) {
    est.push_back(c2w.topRightCorner<3, 1>());
    gt.push_back(mc.truth.at(name).topRightCorner<3, 1>());
  }
  const Eigen::Matrix4d A = AlignAboutZ(est, gt);
  const Eigen::Matrix4d hero = A * r.hero.c2w, hero_gt = mc.truth.at("hero.png");
  EXPECT_LT(RotationAngleDeg(hero.topLeftCorner<3, 3>(), hero_gt.topLeftCorner<3, 3>()), 0.05);
  EXPECT_LT((hero.topRightCorner<3, 1>() - hero_gt.topRightCorner<3, 1>()).norm(), 2e-3);
  // Hero's x axis lies in the world's x-z plane (x = the hero's right edge on the ground).
  EXPECT_NEAR(r.hero.c2w(1, 0), 0, 1e-9);
  EXPECT_GT(r.hero.c2w(0, 0), 0);
  // The rectangle spans the ground points (+-1 x +-0.8, 2 % in from each
  // side, in axes turned ~11 degrees with the hero's heading).
  EXPECT_NEAR(r.half_extent.x(), 0.98, 0.06);
  EXPECT_NEAR(r.half_extent.y(), 0.82, 0.06);
  // colmap_to_world maps the model's points onto z = 0.
  const Eigen::Vector3d a = (r.colmap_to_world * mc.model.points[0].xyz.homogeneous()).head<3>();
  EXPECT_NEAR(a.z(), 0, 1e-3);
}

TEST(PlaneStage, ScaleFromTwoHeroPixelsOnThePlane) {
  const ModelCase mc = MakeModel(12, 1000, 200, 0.0, 2);
  Camera hero = mc.lens;
  hero.c2w = mc.truth.at("hero.png");
  PlaneStageOptions o = Options();
  o.distance = 0.5;
  o.distance_pixels = {*ProjectToPixel(hero, Eigen::Vector3d(0, 0, 0)),
                       *ProjectToPixel(hero, Eigen::Vector3d(0.3, 0.4, 0))};
  const PlaneStageResult r = RegisterPlane(mc.model, o, QuietContext());
  // Box points within the inlier threshold of the ground pull the plane up
  // by ~1e-4 of the viewing distance.
  EXPECT_NEAR(r.scale * mc.model_units_per_metre, 1.0, 1e-3);
  EXPECT_NEAR(r.hero.c2w(2, 3), 1.0, 1e-3);  // the hero's true height
}

TEST(PlaneStage, WithoutScaleLengthsStayInColmapUnits) {
  const ModelCase mc = MakeModel(12, 1000, 200, 0.0, 3);
  const PlaneStageResult r = RegisterPlane(mc.model, Options(), QuietContext());
  EXPECT_EQ(r.scale_source, "none");
  EXPECT_EQ(r.scale, 1.0);
  EXPECT_NEAR(r.hero.c2w(2, 3), 1.0 * mc.model_units_per_metre, 1e-3 * mc.model_units_per_metre);
}

TEST(PlaneStage, HeroIntrinsicsFromCameraJson) {
  TempDir tmp;
  const ModelCase mc = MakeModel(12, 1000, 200, 0.0, 4);
  CameraFile cf;
  cf.camera = mc.lens;
  cf.camera.width *= 2;  // calibrated at twice the size: rescaled
  cf.camera.height *= 2;
  cf.camera.fx = cf.camera.fy = 620;
  cf.camera.cx = 2 * (mc.lens.cx + 0.5) - 0.5;
  cf.camera.cy = 2 * (mc.lens.cy + 0.5) - 0.5;
  WriteJsonFile(tmp / "camera.json", CameraFileToJson(cf));
  PlaneStageOptions o = Options();
  o.camera = tmp / "camera.json";
  StageContext ctx = QuietContext();
  const PlaneStageResult r = RegisterPlane(mc.model, o, ctx);
  EXPECT_EQ(r.hero_intrinsics, "camera.json");
  EXPECT_EQ(r.hero.width, 320);
  EXPECT_NEAR(r.hero.fx, 310, 1e-9);
  EXPECT_NEAR(r.hero.cx, mc.lens.cx, 1e-9);
}

template <typename Fn>
std::string ErrorOf(Fn fn) {
  try {
    fn();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST(PlaneStage, ClearErrors) {
  const ModelCase mc = MakeModel(6, 1000, 100, 0.0, 5);
  PlaneStageOptions o = Options();
  o.min_registered = 10;
  EXPECT_NE(ErrorOf([&] { RegisterPlane(mc.model, o, QuietContext()); }).find("registered only 7 image(s)"),
            std::string::npos);
  o = Options();
  o.hero = "missing.png";
  EXPECT_NE(ErrorOf([&] { RegisterPlane(mc.model, o, QuietContext()); }).find("not registered by COLMAP"),
            std::string::npos);
  // Scattered points: no dominant plane.
  ModelCase scattered = MakeModel(8, 0, 0, 0.0, 6);
  std::mt19937_64 rng(1);
  std::uniform_real_distribution<double> uni(-1, 1);
  for (int i = 0; i < 500; ++i) {
    ColmapPoint3D p;
    p.id = 1000 + i;
    p.xyz = Eigen::Vector3d(uni(rng), uni(rng), uni(rng)) * 3;
    scattered.model.points.push_back(p);
  }
  EXPECT_NE(ErrorOf([&] { RegisterPlane(scattered.model, Options(), QuietContext()); }).find("no dominant plane"),
            std::string::npos);
  // Options.
  o = Options();
  o.distance = 1;
  EXPECT_NE(ErrorOf([&] { RegisterPlane(mc.model, o, QuietContext()); }).find("--distance needs its two points"),
            std::string::npos);
}

TEST(PlaneStage, MissingColmapIsOneClearLine) {
  TempDir tmp;
  fs::create_directories(tmp / "images");
  WriteLdr(tmp / "images" / "hero.png", Image(8, 8, 3, 0.5f));
  PlaneStageOptions o;
  o.images = tmp / "images";
  o.hero = "hero.png";
  o.out = tmp / "plane.json";
  o.colmap = "shadowsg-no-such-colmap";
  const std::string e = ErrorOf([&] { RunPlaneStage(o, QuietContext()); });
  EXPECT_NE(e.find("COLMAP not found on PATH"), std::string::npos) << e;
  EXPECT_EQ(e.find('\n'), std::string::npos);
  o.hero = "other.png";
  EXPECT_NE(ErrorOf([&] { RunPlaneStage(o, QuietContext()); }).find("not among the 1 photos"), std::string::npos);
}

TEST(PlaneStage, ReadsTheLargestModelOfAFolderAndWritesPlaneJson) {
  TempDir tmp;
  const ModelCase big = MakeModel(12, 1000, 200, 0.0, 7);
  const ModelCase small = MakeModel(4, 300, 10, 0.0, 8);
  WriteColmapModel(tmp / "sparse" / "0", small.model, ColmapFormat::kBinary);
  WriteColmapModel(tmp / "sparse" / "1", big.model, ColmapFormat::kText);
  EXPECT_EQ(SelectColmapModel(tmp / "sparse"), tmp / "sparse" / "1");
  PlaneStageOptions o;
  o.colmap_model = tmp / "sparse";
  o.hero = "hero.png";
  o.out = tmp / "out" / "plane.json";
  const PlaneStageResult r = RunPlaneStage(o, QuietContext());
  EXPECT_EQ(r.registered_images, 13);
  const PlaneFile f = ReadPlaneFile(tmp / "out" / "plane.json");
  EXPECT_EQ(f.xyz, Eigen::Vector3d::Zero());
  EXPECT_EQ(f.normal, Eigen::Vector3d::UnitZ());
  EXPECT_EQ(f.hero_image, "hero.png");
  EXPECT_TRUE(f.hero_c2w.isApprox(r.hero.c2w, 1e-12));
  EXPECT_EQ(f.scale_source, "none");
  EXPECT_EQ(f.registered_images, 13);
  EXPECT_EQ(f.plane_inliers, r.fit.num_inliers);
  ASSERT_TRUE(f.hero_camera.has_value());
  EXPECT_EQ(f.hero_camera->fx, 300);
  ASSERT_TRUE(f.half_extent.has_value());
  EXPECT_EQ(f.extra["images"].size(), 13u);
  // Round trip of the artifact.
  const PlaneFile again = ParsePlaneFile(PlaneFileToJson(f), "plane.json");
  EXPECT_TRUE(again.hero_c2w.isApprox(f.hero_c2w, 1e-12));
  EXPECT_EQ(again.extra["images"].size(), 13u);
}

}  // namespace
}  // namespace shadowsg
