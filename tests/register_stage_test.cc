// `shadowsg register` on a hero view rendered by the path tracer with known
// camera, plane, object and tag: the scene folder loads, the object lands at
// its true pose, the mask leaves out the object, the tag, clipped pixels and
// everything off the plane rectangle, the albedo comes from the tag's paper,
// and a world without metric scale is rescaled to pose.json's units.
#include "stages/register_stage.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

#include "calib/apriltag_detect.h"
#include "calib/error.h"
#include "solver/ray_caster.h"
#include "stages/io/capture_io.h"
#include "stages/io/image_io.h"
#include "stages/io/mesh_io.h"
#include "stages/io/scene_io.h"
#include "multiview_capture.h"
#include "quiet_context.h"
#include "test_util.h"

namespace shadowsg {
namespace {

namespace fs = std::filesystem;
using testing::TempDir;

Eigen::Matrix4d Inverse(const Eigen::Matrix4d& T) {
  Eigen::Matrix4d inv = Eigen::Matrix4d::Identity();
  inv.topLeftCorner<3, 3>() = T.topLeftCorner<3, 3>().transpose();
  inv.topRightCorner<3, 1>() = -T.topLeftCorner<3, 3>().transpose() * T.topRightCorner<3, 1>();
  return inv;
}

using shadowsg::testing::QuietContext;

// Writes the stage inputs for the capture's hero view into tmp; `world_scale`
// multiplies plane.json's lengths (a world in other units).
struct Inputs {
  testing::MultiviewCapture cap;
  Image linear;
  RegisterStageOptions options;
};

Inputs MakeInputs(const TempDir& tmp) {
  testing::MultiviewSpec spec;
  spec.noise = 0;  // a uniform plane: its albedo is well defined
  spec.plane_half = 0.7;
  spec.spp = 16;
  spec.k1 = 0;
  Inputs in{testing::MakeMultiviewCapture(spec, 0), Image(), RegisterStageOptions()};
  in.linear = testing::RenderView(in.cap, in.cap.hero_c2w, 5);
  WriteExr(tmp / "linear.exr", in.linear);
  CameraFile cf;
  cf.camera = in.cap.lens;
  WriteJsonFile(tmp / "camera.json", CameraFileToJson(cf));
  WriteObj(tmp / "box.obj", in.cap.scene.objects[0].mesh);
  RegisterStageOptions& o = in.options;
  o.camera = tmp / "camera.json";
  o.image = tmp / "linear.exr";
  o.plane = tmp / "plane.json";
  o.pose = tmp / "pose.json";
  o.mesh = tmp / "box.obj";
  o.out = tmp / "scene";
  return in;
}

void WritePlaneAndPose(const TempDir& tmp, const Inputs& in, double world_scale, bool with_plane_c) {
  PlaneFile pf;
  pf.hero_image = "hero.png";
  pf.hero_c2w = in.cap.hero_c2w;
  pf.hero_c2w.topRightCorner<3, 1>() *= world_scale;
  pf.half_extent = Eigen::Vector2d::Constant(in.cap.spec.plane_half * world_scale);
  pf.scale_source = world_scale == 1.0 ? "apriltag" : "none";
  pf.registered_images = 20;
  pf.plane_inliers = 1000;
  WriteJsonFile(tmp / "plane.json", PlaneFileToJson(pf));
  PoseFile pose;
  const Eigen::Matrix4d w2c = Inverse(in.cap.hero_c2w);
  pose.o2c = w2c * in.cap.scene.objects[0].o2w;
  pose.method = "apriltag";
  pose.rms_px = 0.1;
  if (with_plane_c) {
    PlaneInCamera pc;
    pc.xyz = (w2c * Eigen::Vector4d(0.4, -0.35, 0, 1)).head<3>();
    pc.normal = w2c.topLeftCorner<3, 3>() * Eigen::Vector3d::UnitZ();
    pose.plane_c = pc;
  }
  WriteJsonFile(tmp / "pose.json", PoseFileToJson(pose));
}

TEST(RegisterStage, WritesASceneThatMatchesTheTruth) {
  TempDir tmp;
  Inputs in = MakeInputs(tmp);
  WritePlaneAndPose(tmp, in, 1.0, true);
  // Clipped pixels flagged the way `shadowsg linearize` does, beside the image.
  const int W = in.linear.width, H = in.linear.height;
  Image clipped(W, H, 1, 0.0f);
  for (int y = 200; y < 210; ++y)
    for (int x = 20; x < 30; ++x) clipped.at(x, y, 0) = 1;
  WriteLdr(tmp / "linear_clipped.png", clipped);

  const RegisterStageResult r = RunRegisterStage(in.options, QuietContext(2));
  EXPECT_EQ(r.units_from, "plane.json");
  ASSERT_TRUE(r.plane_c_ratio.has_value());
  EXPECT_NEAR(*r.plane_c_ratio, 1.0, 1e-9);
  EXPECT_NEAR(r.object_gap, 0.0, 1e-6);  // OBJ keeps ~7 digits
  EXPECT_EQ(r.tags_masked, 1);
  EXPECT_EQ(r.clipped_pixels, 100u);

  // The folder loads, with the true geometry.
  const Scene scene = LoadScene(tmp / "scene");
  EXPECT_TRUE(scene.camera.c2w.isApprox(in.cap.hero_c2w, 1e-9));
  EXPECT_EQ(scene.camera.fx, in.cap.lens.fx);
  ASSERT_EQ(scene.objects.size(), 1u);
  EXPECT_TRUE(scene.objects[0].o2w.isApprox(in.cap.scene.objects[0].o2w, 1e-9));
  EXPECT_EQ(scene.plane.xyz, Eigen::Vector3d::Zero());
  EXPECT_EQ(scene.plane.normal, Eigen::Vector3d::UnitZ());
  EXPECT_NEAR(scene.plane.scale.x(), 0.7, 1e-9);
  ASSERT_TRUE(scene.mask.has_value());
  EXPECT_EQ(scene.image.width, W);

  // Albedo from the tag's paper (0.85) against the plane's (0.55 0.45 0.35).
  EXPECT_EQ(r.albedo_source, "apriltag");
  const Eigen::Vector3d truth = in.cap.spec.plane_albedo;
  std::printf("albedo estimate %.4f %.4f %.4f (truth %.2f %.2f %.2f)\n", scene.plane.diffuse.x(),
              scene.plane.diffuse.y(), scene.plane.diffuse.z(), truth.x(), truth.y(), truth.z());
  for (int k = 0; k < 3; ++k) EXPECT_NEAR(scene.plane.diffuse[k] / truth[k], 1.0, 0.04) << k;

  // The mask against the truth, pixel by pixel.
  RayCaster caster;
  caster.AddMesh(in.cap.scene.objects[0].WorldMesh());
  caster.Commit();
  Camera cam = in.cap.lens;
  cam.c2w = in.cap.hero_c2w;
  const TagPattern pattern = MakeTagPattern("tag36h11", in.cap.spec.tag_id);
  const double pattern_half = 0.5 * in.cap.spec.tag_size * pattern.total_width / pattern.border_width;
  int object_leaks = 0, tag_leaks = 0, off_plane_leaks = 0, clipped_leaks = 0, plane_kept = 0, plane_total = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const bool m = scene.mask->at(x, y, 0) > 0;
      const Ray ray = PixelRay(cam, x, y);
      const double t = ray.dir.z() < 0 ? -ray.origin.z() / ray.dir.z() : 1e30;
      const Eigen::Vector3d p = ray.origin + t * ray.dir;
      const bool object = caster.Intersect(ray.origin, ray.dir, 0, t).has_value();
      const bool on_rect = t < 1e29 && std::abs(p.x()) <= 0.7 && std::abs(p.y()) <= 0.7;
      const Eigen::Vector2d d = p.head<2>() - in.cap.spec.tag_centre;
      const bool tag = on_rect && d.cwiseAbs().maxCoeff() <= pattern_half;
      const bool clip = clipped.at(x, y, 0) > 0;
      object_leaks += m && object;
      tag_leaks += m && tag;
      off_plane_leaks += m && !on_rect;
      clipped_leaks += m && clip;
      if (on_rect && !object && !tag && !clip) {
        ++plane_total;
        plane_kept += m;
      }
    }
  EXPECT_EQ(object_leaks, 0);
  EXPECT_EQ(tag_leaks, 0);
  EXPECT_EQ(off_plane_leaks, 0);
  EXPECT_EQ(clipped_leaks, 0);
  EXPECT_GT(plane_kept, 0.85 * plane_total);  // margins and the paper cost a little
  EXPECT_TRUE(fs::exists(tmp / "scene" / "mask_preview.png"));
  EXPECT_TRUE(fs::exists(tmp / "scene" / "geometry" / "mesh.obj"));
}

TEST(RegisterStage, WorldWithoutScaleTakesPoseUnits) {
  TempDir tmp;
  Inputs in = MakeInputs(tmp);
  in.options.albedo_mode = AlbedoMode::kConvention;
  for (bool plane_c : {true, false}) {
    WritePlaneAndPose(tmp, in, 2.5, plane_c);  // plane.json in units 2.5 x smaller than metres
    const RegisterStageResult r = RunRegisterStage(in.options, QuietContext(2));
    EXPECT_EQ(r.units_from, plane_c ? "plane_c" : "contact");
    // The contact scale comes from the mesh as read back from OBJ (~7 digits).
    EXPECT_NEAR(r.pose_units_per_world_unit, 0.4, 1e-6);
    EXPECT_TRUE(r.scene.camera.c2w.isApprox(in.cap.hero_c2w, 1e-6));
    EXPECT_TRUE(r.scene.objects[0].o2w.isApprox(in.cap.scene.objects[0].o2w, 1e-6));
    EXPECT_NEAR(r.scene.plane.scale.x(), 0.7, 1e-6);
    EXPECT_EQ(r.albedo_source, "convention");
    EXPECT_EQ(r.scene.plane.diffuse, Eigen::Vector3d::Constant(kConventionAlbedo));
  }
  const Json j = ReadJsonFile(tmp / "scene" / "scene.json");
  EXPECT_EQ(j["registration"]["albedo_source"], "convention");
  EXPECT_NE(j["registration"]["albedo_note"].get<std::string>().find("relative"), std::string::npos);
}

TEST(RegisterStage, GivenAlbedoAndClearErrors) {
  TempDir tmp;
  Inputs in = MakeInputs(tmp);
  WritePlaneAndPose(tmp, in, 1.0, false);
  in.options.albedo_mode = AlbedoMode::kGiven;
  in.options.albedo = Eigen::Vector3d(0.5, 0.4, 0.3);
  in.options.snap_to_plane = true;
  const RegisterStageResult r = RunRegisterStage(in.options, QuietContext(2));
  EXPECT_EQ(r.scene.plane.diffuse, Eigen::Vector3d(0.5, 0.4, 0.3));
  EXPECT_EQ(r.albedo_source, "given");

  RegisterStageOptions bad = in.options;
  bad.mesh = tmp / "missing.obj";
  EXPECT_THROW(RunRegisterStage(bad, QuietContext(2)), InputError);
  bad = in.options;
  bad.camera = tmp / "camera_wrong.json";
  CameraFile cf;
  cf.camera = in.cap.lens;
  cf.camera.width = 100;  // another aspect ratio
  WriteJsonFile(bad.camera, CameraFileToJson(cf));
  try {
    RunRegisterStage(bad, QuietContext(2));
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("but the image is 320x240"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace shadowsg
