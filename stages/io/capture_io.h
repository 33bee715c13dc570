// The capture stages' artifacts (scene-format.md, "Stage artifacts"):
// camera.json (intrinsics) and pose.json (object pose), their readers and
// writers, and the small text formats the stages take (2D-3D points CSV).
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <istream>
#include <optional>
#include <string>
#include <vector>

#include "calib/camera.h"
#include "stages/io/json_util.h"

namespace shadowsg {

// ---- camera.json --------------------------------------------------------
// The scene.json camera block (CameraToJson) plus the calibration's record.
struct CameraFile {
  Camera camera;
  double rms_px = 0.0;
  std::vector<std::string> views_used, views_rejected;
};

Json CameraFileToJson(const CameraFile& file);
// Accepts a camera.json, or a scene.json (its "camera" block). "c2w" may be
// absent (identity). InputError names the file and key on any problem.
CameraFile ParseCameraFile(const Json& json, const std::string& name_for_errors);
CameraFile ReadCameraFile(const std::filesystem::path& path);

// ---- pose.json ----------------------------------------------------------
struct PlaneInCamera {
  Eigen::Vector3d xyz = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // unit, towards the camera
};

struct PoseFile {
  Eigen::Matrix4d o2c = Eigen::Matrix4d::Identity();
  double rms_px = 0.0;
  std::string method;  // "apriltag" or "pnp"
  std::optional<PlaneInCamera> plane_c;
};

Json PoseFileToJson(const PoseFile& file);
PoseFile ParsePoseFile(const Json& json, const std::string& name_for_errors);
PoseFile ReadPoseFile(const std::filesystem::path& path);

// ---- 2D-3D correspondences ----------------------------------------------
// One correspondence a line: u, v (pixels, centres at integers), x, y, z
// (object coordinates), separated by commas or white space. Lines starting
// with '#' and a first line that is not numeric (a header) are skipped.
struct Correspondences {
  std::vector<Eigen::Vector2d> image;
  std::vector<Eigen::Vector3d> object;
};
Correspondences ReadCorrespondences(std::istream& in, const std::string& name_for_errors);
Correspondences ReadCorrespondencesFile(const std::filesystem::path& path);

// ---- plane.json (`shadowsg plane`) ----------------------------------------
// The ground plane and the hero camera in the registered world frame (plane
// z = 0, +z its normal towards the cameras).
struct PlaneFile {
  Eigen::Vector3d xyz = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  // "plane": {"scale": [hx, hy, 1]}: half extents of the rectangle the plane's
  // reconstructed points cover (optional extra key).
  std::optional<Eigen::Vector2d> half_extent;
  std::string hero_image;
  Eigen::Matrix4d hero_c2w = Eigen::Matrix4d::Identity();
  std::optional<Camera> hero_camera;  // "hero": {"camera": {...}}: the intrinsics used (extra key)
  std::string scale_source = "none";  // "apriltag", "distance" or "none" (COLMAP's units)
  int registered_images = 0;
  int plane_inliers = 0;
  Json extra = Json::object();  // further keys, written as they are
};

Json PlaneFileToJson(const PlaneFile& file);
PlaneFile ParsePlaneFile(const Json& json, const std::string& name_for_errors);
PlaneFile ReadPlaneFile(const std::filesystem::path& path);

}  // namespace shadowsg
