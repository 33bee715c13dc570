// `shadowsg pose`: the object's pose in one photo, from AprilTags (with the
// tags' placement on the object, or "the object sits on the tag's plane at an
// offset") or from 2D-3D correspondences (RANSAC PnP). Writes pose.json
// (scene-format.md, Stage artifacts) and an overlay PNG: projected mesh edges,
// object axes, tags or points, and the ground plane, over the photo.
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "calib/apriltag_detect.h"
#include "calib/pose_estimation.h"
#include "stages/io/json_util.h"
#include "stages/stage_context.h"

namespace shadowsg {

enum class PoseMethod { kAprilTag, kPnp };

struct PoseStageOptions {
  std::filesystem::path image;   // the photo (8-bit or EXR)
  std::filesystem::path camera;  // camera.json (or a scene.json)
  std::filesystem::path out = "pose.json";
  std::filesystem::path overlay;  // empty: <out stem>_overlay.png beside out
  std::filesystem::path mesh;     // optional: the object's mesh, for the overlay
  PoseMethod method = PoseMethod::kAprilTag;

  // AprilTag
  TagDetectorOptions detector;
  double tag_size = 0.0;                             // black border edge; default for layout entries
  int tag_id = -1;                                   // single tag: which one (-1: the only one seen)
  std::filesystem::path tag_layout;                  // JSON placement of several tags (README)
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();  // single tag: object origin in the tag's up frame
  MeshUp mesh_up = MeshUp::kZ;

  // PnP
  std::filesystem::path points;  // CSV u, v, x, y, z
  PnpOptions pnp;
  std::optional<double> ground_z;  // object plane z = this is the ground (gives plane_c)

  // Message naming the bad option, or empty.
  std::string Validate() const;
};

struct PoseStageResult {
  PoseEstimate pose;
  std::string method;  // "apriltag" | "pnp"
  std::vector<TagDetection> detections;
  std::vector<int> used_ids;
  std::optional<std::pair<Eigen::Vector3d, Eigen::Vector3d>> plane;  // xyz, normal (camera)
  std::filesystem::path pose_json, overlay_png;
};

PoseStageResult RunPoseStage(const PoseStageOptions& options, const StageContext& ctx);

// Tag placements from a layout document (README, "shadowsg pose"); entries
// without "size" take `default_size`. `family` is set when the file names one.
std::vector<TagPlacement> ParseTagLayout(const Json& json, const std::string& name_for_errors, double default_size,
                                         std::string* family);

}  // namespace shadowsg
