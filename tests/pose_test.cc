// shadowsg pose: AprilTags rendered through the camera model at known poses
// (bit patterns from libapriltag's family data), single and combined; PnP
// from 2D-3D correspondences with outliers; the stage's files and errors.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <fstream>
#include <random>

#include "calib/apriltag_detect.h"
#include "calib/error.h"
#include "calib/pose_estimation.h"
#include "solver/mesh.h"
#include "stages/io/capture_io.h"
#include "stages/io/image_io.h"
#include "stages/io/mesh_io.h"
#include "stages/pose_stage.h"
#include "synthetic_capture.h"
#include "test_util.h"

namespace shadowsg {
namespace {

namespace fs = std::filesystem;
using testing::PlacedTag;
using testing::PlaneRenderer;
using testing::Pose;
using testing::RotationErrorDeg;
using testing::TempDir;

Camera TagCamera() {
  Camera c;
  c.width = 800;
  c.height = 600;
  c.fx = 700;
  c.fy = 702;
  c.cx = 402.0;
  c.cy = 297.5;
  c.k1 = -0.15;
  c.k2 = 0.05;
  c.p1 = 0.0005;
  return c;
}

double TranslationErrorFraction(const Eigen::Matrix4d& est, const Eigen::Matrix4d& truth) {
  return (est.topRightCorner<3, 1>() - truth.topRightCorner<3, 1>()).norm() / truth.topRightCorner<3, 1>().norm();
}

// A ground plane seen obliquely: plane frame z into the ground, `tilt`
// degrees from facing the camera, `distance` to its origin.
Eigen::Matrix4d GroundToCamera(double tilt, double yaw, double distance) {
  const Eigen::Matrix3d R = (Eigen::AngleAxisd(tilt * M_PI / 180, Eigen::Vector3d::UnitX()) *
                             Eigen::AngleAxisd(yaw * M_PI / 180, Eigen::Vector3d::UnitZ()))
                                .toRotationMatrix();
  Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
  T.topLeftCorner<3, 3>() = R;
  T.topRightCorner<3, 1>() = Eigen::Vector3d(0.01, 0.02, distance);
  return T;
}

TEST(AprilTag, PatternHasTheFamilyLayout) {
  const TagPattern p = MakeTagPattern("tag36h11", 0);
  ASSERT_EQ(p.total_width, 10);
  ASSERT_EQ(p.border_width, 8);
  for (int i = 0; i < 10; ++i) {
    EXPECT_TRUE(p.at(i, 0) && p.at(0, i) && p.at(i, 9) && p.at(9, i));  // white ring
    if (i >= 1 && i <= 8) {
      EXPECT_TRUE(!p.at(i, 1) && !p.at(1, i) && !p.at(i, 8) && !p.at(8, i));  // black border
    }
  }
  EXPECT_EQ(TagFamilySize("tag36h11"), 587);
  EXPECT_THROW(MakeTagPattern("tag99h1", 0), InputError);
  EXPECT_THROW(MakeTagPattern("tag36h11", 587), InputError);
}

TEST(AprilTag, DetectsRenderedTagsAtTheirCorners) {
  const Camera cam = TagCamera();
  const Eigen::Matrix4d ground = GroundToCamera(35, 20, 0.6);
  std::vector<PlacedTag> tags;
  for (int k = 0; k < 3; ++k) {
    PlacedTag t;
    t.id = 5 + 10 * k;
    t.centre = Eigen::Vector2d(-0.12 + 0.12 * k, 0.02 * k);
    t.size = 0.07;
    t.rotation_rad = 0.4 * k;
    tags.push_back(t);
  }
  Image img = PlaneRenderer(cam).Render(ground, testing::TagsTexture(tags));
  testing::AddNoiseAndQuantise(&img, 0.01, 3);
  const std::vector<TagDetection> det = DetectTags(img, TagDetectorOptions());
  ASSERT_EQ(det.size(), 3u);
  Eigen::Vector2d bias = Eigen::Vector2d::Zero();
  double worst = 0;
  for (size_t k = 0; k < 3; ++k) {
    EXPECT_EQ(det[k].id, tags[k].id);
    // The detector's corner order in the tag frame (x right, y down).
    const auto corners = TagCornerPoints(tags[k].size);
    const double c = std::cos(tags[k].rotation_rad), s = std::sin(tags[k].rotation_rad);
    for (int i = 0; i < 4; ++i) {
      const Eigen::Vector3d in_plane(tags[k].centre.x() + c * corners[i].x() - s * corners[i].y(),
                                     tags[k].centre.y() + s * corners[i].x() + c * corners[i].y(), 0);
      const Eigen::Vector2d truth = *ProjectToPixel(cam, (ground * in_plane.homogeneous()).head<3>());
      bias += (det[k].corners[i] - truth) / 12;
      worst = std::max(worst, (det[k].corners[i] - truth).norm());
    }
  }
  std::printf("tag corners: worst %.3f px, mean offset %.3f %.3f px\n", worst, bias.x(), bias.y());
  EXPECT_LT(worst, 0.5);
  EXPECT_LT(bias.norm(), 0.1);  // pixel-centre convention agrees with the camera model's
}

struct SingleTagCase {
  double tilt, yaw, distance;
};

TEST(TagPose, SingleTagObjectOnItsPlane) {
  const Camera cam = TagCamera();
  const PlaneRenderer renderer(cam);
  TempDir tmp;
  CameraFile cf;
  cf.camera = cam;
  WriteJsonFile(tmp / "camera.json", CameraFileToJson(cf));
  const Eigen::Vector3d offset(0.03, 0.05, 0.0);  // object 5 cm "above" the tag (towards its top edge)
  for (const SingleTagCase& c :
       {SingleTagCase{30, 10, 0.5}, SingleTagCase{55, -40, 0.8}, SingleTagCase{10, 170, 0.35}}) {
    const Eigen::Matrix4d tag2c = GroundToCamera(c.tilt, c.yaw, c.distance);
    PlacedTag tag;
    tag.id = 42;
    tag.size = 0.08;
    Image img = renderer.Render(tag2c, testing::TagsTexture({tag}));
    testing::AddNoiseAndQuantise(&img, 0.01, 11);
    WriteLdr(tmp / "photo.png", testing::ToRgb(img));

    PoseStageOptions o;
    o.image = tmp / "photo.png";
    o.camera = tmp / "camera.json";
    o.out = tmp / "pose.json";
    o.tag_size = 0.08;
    o.offset = offset;
    const PoseStageResult r = RunPoseStage(o, StageContext());
    // Independent of TagToObjectOnPlane: the object origin is the tag centre
    // moved along the tag's x and up its face (-y), and the object's +z is
    // the plane normal towards the camera (-z of the tag).
    const Eigen::Matrix3d Rt = tag2c.topLeftCorner<3, 3>();
    Eigen::Matrix4d truth = Eigen::Matrix4d::Identity();
    truth.topLeftCorner<3, 3>() = Rt * Eigen::Vector3d(1, -1, -1).asDiagonal();
    truth.topRightCorner<3, 1>() = tag2c.topRightCorner<3, 1>() + Rt * Eigen::Vector3d(offset.x(), -offset.y(), 0);
    const double rot = RotationErrorDeg(r.pose.o2c, truth), trans = TranslationErrorFraction(r.pose.o2c, truth);
    std::printf(
        "single tag (tilt %.0f, distance %.2f): rotation error %.3f deg, translation error %.3f %%, rms %.3f px\n",
        c.tilt, c.distance, rot, 100 * trans, r.pose.rms_px);
    EXPECT_LT(rot, 0.5);
    EXPECT_LT(trans, 0.01);
    ASSERT_TRUE(r.plane.has_value());
    EXPECT_LT(std::acos(std::min(1.0, r.plane->second.dot(-Rt.col(2)))) * 180 / M_PI, 0.5);
    EXPECT_LT(std::abs((r.plane->first - tag2c.topRightCorner<3, 1>()).dot(Rt.col(2))), 0.01 * c.distance);

    const PoseFile file = ReadPoseFile(r.pose_json);
    EXPECT_EQ(file.method, "apriltag");
    EXPECT_TRUE(file.o2c.isApprox(r.pose.o2c, 1e-9));
    ASSERT_TRUE(file.plane_c.has_value());
    EXPECT_TRUE(fs::exists(r.overlay_png));
  }
}

TEST(TagPose, SeveralTagsCombinedByLayout) {
  const Camera cam = TagCamera();
  TempDir tmp;
  CameraFile cf;
  cf.camera = cam;
  WriteJsonFile(tmp / "camera.json", CameraFileToJson(cf));
  // Four tags around the object on the ground (object frame z up), and a
  // stray tag that the layout does not name.
  struct Placed {
    int id;
    double x, y, yaw_deg;
  };
  const std::vector<Placed> layout = {
      {3, -0.12, -0.09, 0}, {7, 0.12, -0.09, 90}, {11, 0.12, 0.09, 180}, {20, -0.12, 0.09, -45}};
  const double size = 0.05;
  Json lj;
  lj["size"] = size;
  lj["tags"] = Json::array();
  std::vector<PlacedTag> tags;
  for (const auto& p : layout) {
    lj["tags"].push_back({{"id", p.id}, {"center", {p.x, p.y}}, {"yaw_deg", p.yaw_deg}});
    // Render plane = object ground turned half a turn about x (z into the ground).
    PlacedTag t;
    t.id = p.id;
    t.size = size;
    t.centre = Eigen::Vector2d(p.x, -p.y);
    t.rotation_rad = -p.yaw_deg * M_PI / 180;
    tags.push_back(t);
  }
  PlacedTag stray;
  stray.id = 30;
  stray.size = size;
  stray.centre = Eigen::Vector2d(0, 0.2);
  tags.push_back(stray);
  WriteJsonFile(tmp / "layout.json", lj);
  const Eigen::Matrix4d ground2c = GroundToCamera(50, 25, 0.7);
  Image img = PlaneRenderer(cam).Render(ground2c, testing::TagsTexture(tags));
  testing::AddNoiseAndQuantise(&img, 0.01, 5);
  WriteLdr(tmp / "photo.png", testing::ToRgb(img));
  const Eigen::Matrix4d truth = ground2c * Pose(Eigen::Vector3d::UnitX(), 180, Eigen::Vector3d::Zero());

  // A cube as the object, for the overlay.
  TriangleMesh cube;
  for (int i = 0; i < 8; ++i)
    cube.vertices.emplace_back(0.04 * ((i & 1) ? 1 : -1), 0.04 * ((i & 2) ? 1 : -1), (i & 4) ? 0.08 : 0.0);
  const int f[12][3] = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                        {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  for (const auto& t : f) cube.faces.emplace_back(t[0], t[1], t[2]);
  WriteObj(tmp / "cube.obj", cube);

  PoseStageOptions o;
  o.image = tmp / "photo.png";
  o.camera = tmp / "camera.json";
  o.out = tmp / "pose.json";
  o.tag_layout = tmp / "layout.json";
  o.mesh = tmp / "cube.obj";
  const PoseStageResult r = RunPoseStage(o, StageContext());
  EXPECT_EQ(r.used_ids, (std::vector<int>{3, 7, 11, 20}));
  const double rot = RotationErrorDeg(r.pose.o2c, truth), trans = TranslationErrorFraction(r.pose.o2c, truth);
  std::printf("4 tags by layout: rotation error %.3f deg, translation error %.3f %%, rms %.3f px\n", rot, 100 * trans,
              r.pose.rms_px);
  EXPECT_LT(rot, 0.5);
  EXPECT_LT(trans, 0.01);
  ASSERT_TRUE(r.plane.has_value());
  EXPECT_LT(std::acos(std::min(1.0, r.plane->second.dot(truth.topLeftCorner<3, 3>().col(2)))) * 180 / M_PI, 0.5);
  EXPECT_LT((r.plane->first - truth.topRightCorner<3, 1>()).norm(), 0.01 * 0.7);  // the object stands at the origin
  const Json j = ReadJsonFile(r.pose_json);
  EXPECT_EQ(j["ignored_tags"], Json::array({30}));
  const Image overlay = ReadLdr(r.overlay_png);
  EXPECT_EQ(overlay.width, cam.width);

  // Without a layout, several tags are ambiguous: one clear error.
  o.tag_layout.clear();
  o.tag_size = size;
  try {
    RunPoseStage(o, StageContext());
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("--tag-id"), std::string::npos) << e.what();
  }
  o.tag_id = 7;  // or choose one
  EXPECT_NO_THROW(RunPoseStage(o, StageContext()));
}

TEST(TagPose, NoTagIsOneClearError) {
  TempDir tmp;
  CameraFile cf;
  cf.camera = TagCamera();
  WriteJsonFile(tmp / "camera.json", CameraFileToJson(cf));
  WriteLdr(tmp / "empty.png", Image(800, 600, 3, 0.6f));
  PoseStageOptions o;
  o.image = tmp / "empty.png";
  o.camera = tmp / "camera.json";
  o.out = tmp / "pose.json";
  o.tag_size = 0.05;
  try {
    RunPoseStage(o, StageContext());
    FAIL() << "no error";
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("empty.png"), std::string::npos) << msg;
    EXPECT_NE(msg.find("no tag36h11 tag"), std::string::npos) << msg;
  }
  EXPECT_FALSE(fs::exists(tmp / "pose.json"));
  WriteLdr(tmp / "small.png", Image(400, 200, 3, 0.6f));  // wrong aspect for the camera
  o.image = tmp / "small.png";
  EXPECT_THROW(RunPoseStage(o, StageContext()), InputError);
}

TEST(PnpPose, RansacAndRefinementWithOutliers) {
  const Camera cam = TagCamera();
  const Eigen::Matrix4d truth = Pose({0.3, 1, 0.2}, 35, {0.05, -0.03, 0.9});
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> box(-0.15, 0.15);
  std::normal_distribution<double> noise(0, 0.3);
  std::vector<Eigen::Vector3d> obj;
  std::vector<Eigen::Vector2d> img;
  for (int i = 0; i < 24; ++i) {
    obj.emplace_back(box(rng), box(rng), box(rng) + 0.15);
    img.push_back(ProjectPoints({obj.back()}, truth, cam)[0] + Eigen::Vector2d(noise(rng), noise(rng)));
  }
  for (int i : {2, 9, 17}) img[i] += Eigen::Vector2d(40, -25);  // gross outliers
  TempDir tmp;
  {
    std::ofstream csv(tmp / "points.csv");
    csv << "u,v,x,y,z\n# three of these are wrong\n";
    for (size_t i = 0; i < obj.size(); ++i)
      csv << img[i].x() << ',' << img[i].y() << ',' << obj[i].x() << ',' << obj[i].y() << ',' << obj[i].z() << '\n';
  }
  CameraFile cf;
  cf.camera = cam;
  WriteJsonFile(tmp / "camera.json", CameraFileToJson(cf));
  WriteLdr(tmp / "photo.jpg", Image(cam.width, cam.height, 3, 0.4f));
  PoseStageOptions o;
  o.method = PoseMethod::kPnp;
  o.image = tmp / "photo.jpg";
  o.camera = tmp / "camera.json";
  o.points = tmp / "points.csv";
  o.out = tmp / "pose.json";
  o.ground_z = 0.0;
  const PoseStageResult r = RunPoseStage(o, StageContext());
  const double rot = RotationErrorDeg(r.pose.o2c, truth), trans = TranslationErrorFraction(r.pose.o2c, truth);
  std::printf(
      "PnP (24 points, 3 outliers, 0.3 px noise): rotation error %.3f deg, translation error %.3f %%, rms %.3f px\n",
      rot, 100 * trans, r.pose.rms_px);
  EXPECT_LT(rot, 0.5);
  EXPECT_LT(trans, 0.01);
  EXPECT_EQ(r.pose.num_inliers, 21);
  EXPECT_FALSE(r.pose.inliers[2] || r.pose.inliers[9] || r.pose.inliers[17]);
  const PoseFile file = ReadPoseFile(r.pose_json);
  EXPECT_EQ(file.method, "pnp");
  EXPECT_TRUE(file.plane_c.has_value());
  EXPECT_TRUE(fs::exists(r.overlay_png));
}

TEST(CaptureIo, CorrespondencesCsvErrorsNameTheLine) {
  std::istringstream ok("u v x y z\n1 2 3 4 5\n\n# comment\n6,7,8,9,10\n");
  const Correspondences c = ReadCorrespondences(ok, "p.csv");
  ASSERT_EQ(c.image.size(), 2u);
  EXPECT_EQ(c.object[1], Eigen::Vector3d(8, 9, 10));
  std::istringstream bad("1 2 3 4 5\n1 2 3 4\n");
  try {
    ReadCorrespondences(bad, "p.csv");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("p.csv:2"), std::string::npos) << e.what();
  }
}

TEST(CaptureIo, CameraFileAcceptsSceneJsonAndMissingPose) {
  const Json camera_only = ParseJson(R"({"width": 640, "height": 480, "fx": 500, "fy": 501, "cx": 320, "cy": 240,
      "k1": -0.1, "rms_px": 0.3, "views_used": ["a.jpg"], "views_rejected": []})",
                                     "camera.json");
  const CameraFile a = ParseCameraFile(camera_only, "camera.json");
  EXPECT_EQ(a.camera.fy, 501);
  EXPECT_EQ(a.camera.k1, -0.1);
  EXPECT_EQ(a.views_used.size(), 1u);
  Json scene;
  scene["camera"] = camera_only;
  EXPECT_EQ(ParseCameraFile(scene, "scene.json").camera.fx, 500);
  Json broken = camera_only;
  broken["fx"] = "wide";
  try {
    ParseCameraFile(broken, "camera.json");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("camera.json: fx"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace shadowsg
