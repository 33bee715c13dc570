// The capture chain on a synthetic capture made by the project's own path
// tracer, with the real COLMAP program (Debian's colmap 3.8, CPU): checkerboard
// photos -> intrinsics; 20 ring views and a hero view -> COLMAP -> plane.json
// (AprilTag scale); the hero photo -> pose.json; -> register -> a scene.
// The plane normal must come back within 1 degree and the hero camera within
// 1 degree and 1 % of its distance. CTest label "colmap": run alone with
// `ctest -L colmap`; skipped when colmap is not on PATH.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "calib/error.h"
#include "stages/colmap_runner.h"
#include "stages/intrinsics_stage.h"
#include "stages/io/capture_io.h"
#include "stages/io/image_io.h"
#include "stages/io/mesh_io.h"
#include "stages/io/scene_io.h"
#include "stages/plane_stage.h"
#include "stages/pose_stage.h"
#include "stages/register_stage.h"
#include "stages/stage_util.h"
#include "multiview_capture.h"
#include "test_util.h"

namespace shadowsg {
namespace {

namespace fs = std::filesystem;
using testing::AlignAboutZ;
using testing::RotationAngleDeg;
using testing::TempDir;

constexpr int kRingViews = 20;
// CPU matching is brute force: fewer features keep the 210 pairs quick.
constexpr int kMaxFeatures = 768;
constexpr int kBoardCols = 8, kBoardRows = 5, kBoardViews = 12;
constexpr double kBoardSquare = 0.03;

TEST(PlaneColmap, SyntheticCaptureRecoversPlaneAndHeroCamera) {
  if (!FindExecutable("colmap")) GTEST_SKIP() << "colmap is not on PATH";
  // SHADOWSG_COLMAP_TEST_DIR keeps the capture and COLMAP's workspace there.
  const char* keep = std::getenv("SHADOWSG_COLMAP_TEST_DIR");
  TempDir scratch;
  const fs::path tmp = keep ? fs::path(keep) : scratch.path();
  StageContext ctx;
  ctx.threads = 2;
  ctx.quiet = true;
  ctx.seed = 1;
  const Stopwatch total;

  // ---- Render the capture -------------------------------------------------
  const testing::MultiviewSpec spec;
  const testing::MultiviewCapture cap = testing::MakeMultiviewCapture(spec, kRingViews);
  testing::CaptureFolderOptions folder;
  folder.board_cols = kBoardCols;
  folder.board_rows = kBoardRows;
  folder.board_views = kBoardViews;
  folder.board_square = kBoardSquare;
  folder.max_features = kMaxFeatures;
  testing::WriteCaptureFolder(cap, tmp, folder);  // boards/, images/, hero.exr, box.obj
  const double render_seconds = total.Seconds();

  // ---- Intrinsics from the checkerboards ----------------------------------
  IntrinsicsStageOptions io;
  io.images = tmp / "boards";
  io.out = tmp / "camera.json";
  io.calibration.cols = kBoardCols;
  io.calibration.rows = kBoardRows;
  io.calibration.square = kBoardSquare;
  io.calibration.fix_k3 = true;
  io.calibration.zero_tangential = true;
  const IntrinsicsStageResult ir = RunIntrinsicsStage(io, ctx);
  const Camera& k = ir.calibration.camera;
  std::printf("intrinsics: fx %.2f fy %.2f cx %.2f cy %.2f k1 %.4f (truth %.1f %.1f %.2f %.2f %.3f), rms %.3f px\n",
              k.fx, k.fy, k.cx, k.cy, k.k1, cap.lens.fx, cap.lens.fy, cap.lens.cx, cap.lens.cy, cap.lens.k1,
              ir.calibration.rms_px);
  EXPECT_NEAR(k.fx / cap.lens.fx, 1.0, 0.01);

  // ---- COLMAP and the plane --------------------------------------------------
  PlaneStageOptions po;
  po.images = tmp / "images";
  po.hero = "hero.png";
  po.camera = tmp / "camera.json";
  po.out = tmp / "plane.json";
  po.tag_size = spec.tag_size;
  po.max_features = kMaxFeatures;
  const PlaneStageResult pr = RunPlaneStage(po, ctx);
  EXPECT_EQ(pr.input_images, kRingViews + 1);
  EXPECT_GE(pr.registered_images, kRingViews);
  EXPECT_EQ(pr.scale_source, "apriltag");
  EXPECT_EQ(pr.cameras_below, 0);

  // Plane normal, compared in the hero camera's frame (frame-independent).
  const Eigen::Matrix3d R_gt = cap.hero_c2w.topLeftCorner<3, 3>(), R_est = pr.hero.c2w.topLeftCorner<3, 3>();
  const Eigen::Vector3d n_gt = R_gt.transpose() * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d n_est = R_est.transpose() * Eigen::Vector3d::UnitZ();
  const double normal_deg = std::acos(std::clamp(n_gt.dot(n_est), -1.0, 1.0)) * 180 / M_PI;

  // The registered frame may differ from the truth by a turn about z and a
  // shift in the plane: align on the ring cameras' centres.
  std::vector<Eigen::Vector3d> est, gt;
  for (const auto& [name, c2w] : pr.cameras) {
    if (name == "hero.png") continue;
    est.push_back(c2w.topRightCorner<3, 1>());
    gt.push_back(cap.ring[std::stoi(name.substr(5, 2))].topRightCorner<3, 1>());
  }
  const Eigen::Matrix4d A = AlignAboutZ(est, gt);
  const Eigen::Matrix4d hero = A * pr.hero.c2w;
  const double hero_deg = RotationAngleDeg(hero.topLeftCorner<3, 3>(), R_gt);
  const Eigen::Vector3d c_gt = cap.hero_c2w.topRightCorner<3, 1>();
  const double hero_distance = (c_gt - Eigen::Vector3d(0, 0, 0)).norm();
  const double hero_rel = (hero.topRightCorner<3, 1>() - c_gt).norm() / hero_distance;
  const double height_rel = std::abs(pr.hero.c2w(2, 3) / c_gt.z() - 1);
  std::printf(
      "COLMAP %.1f s (render %.1f s): %d/%d registered, %zu points, %d plane inliers; normal error %.3f deg; hero "
      "rotation %.3f deg, position %.3f %% of its distance, height %.3f %%; scale from %zu tag(s)\n",
      pr.colmap_seconds, render_seconds, pr.registered_images, pr.input_images, pr.points, pr.fit.num_inliers,
      normal_deg, hero_deg, 100 * hero_rel, 100 * height_rel, pr.tags.size());
  RecordProperty("colmap_seconds", std::to_string(pr.colmap_seconds));
  RecordProperty("normal_error_deg", std::to_string(normal_deg));
  RecordProperty("hero_rotation_error_deg", std::to_string(hero_deg));
  RecordProperty("hero_position_error_percent", std::to_string(100 * hero_rel));
  EXPECT_LT(normal_deg, 1.0);
  EXPECT_LT(hero_deg, 1.0);
  EXPECT_LT(hero_rel, 0.01);
  EXPECT_LT(height_rel, 0.01);

  // ---- Pose and register: the object lands where it is ----------------------
  // box.obj is in the pose stage's object frame: the box's centre, axes along
  // the tag's (= world axes); so its mesh is the box turned as it stands.
  const SceneObject& box = cap.scene.objects[0];
  TriangleMesh mesh = box.mesh;
  for (auto& v : mesh.vertices) v = box.o2w.topLeftCorner<3, 3>() * v;  // as box.obj
  PoseStageOptions pose;
  pose.image = tmp / "images" / "hero.png";
  pose.camera = tmp / "camera.json";
  pose.out = tmp / "pose.json";
  pose.tag_size = spec.tag_size;
  pose.offset = Eigen::Vector3d(-spec.tag_centre.x(), -spec.tag_centre.y(), spec.box_half.z());
  RunPoseStage(pose, ctx);
  RegisterStageOptions ro;
  ro.camera = tmp / "camera.json";
  ro.image = tmp / "hero.exr";
  ro.plane = tmp / "plane.json";
  ro.pose = tmp / "pose.json";
  ro.mesh = tmp / "box.obj";
  ro.out = tmp / "scene";
  const RegisterStageResult rr = RunRegisterStage(ro, ctx);
  const Scene scene = LoadScene(tmp / "scene");
  double worst = 0;
  for (const auto& v : mesh.vertices) {
    const Eigen::Vector3d est_v = (A * scene.objects[0].o2w * v.homogeneous()).head<3>();
    const Eigen::Vector3d gt_v = box.o2w.topRightCorner<3, 1>() + v;
    worst = std::max(worst, (est_v - gt_v).norm());
  }
  std::printf("register: object vertices within %.2f cm of the truth, lowest point %.2f cm from the plane, %zu "
              "mask pixels, total %.1f s\n",
              100 * worst, 100 * rr.object_gap, rr.mask_pixels, total.Seconds());
  EXPECT_LT(worst, 0.02);
  EXPECT_LT(std::abs(rr.object_gap), 0.01);
}

}  // namespace
}  // namespace shadowsg
