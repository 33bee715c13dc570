// `shadowsg plane`: the ground plane and the hero camera from a multi-view
// capture. Runs COLMAP (colmap_runner.h) on a folder of photos, or reads an
// existing sparse model; fits the dominant plane to the 3D points (RANSAC,
// then least squares); orients its normal towards the cameras; scales the
// model to metric units with an AprilTag of known size or a known distance;
// and writes plane.json (scene-format.md, "Stage artifacts") in the
// registered world frame: the plane at z = 0, +z its normal, x along the hero
// camera's right edge, the origin at the centre of the plane points' extent.
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "calib/camera.h"
#include "calib/colmap_model.h"
#include "calib/plane_fit.h"
#include "stages/colmap_runner.h"
#include "stages/stage_context.h"

namespace shadowsg {

// A plane holding fewer of the points than this share is not "dominant".
inline constexpr double kMinPlaneInlierFraction = 0.2;
// ... nor one with fewer points than this (a plane from a handful of points
// has no reliable normal).
inline constexpr int kMinPlaneInliers = 30;
// The rectangle written to plane.json spans these percentiles of the inlier
// points along each axis (robust to stray points far along the plane).
inline constexpr double kExtentPercentile = 0.02;

struct PlaneStageOptions {
  std::filesystem::path images;        // the photos (COLMAP's image_path; tags are found here)
  std::filesystem::path colmap_model;  // an existing sparse model: skips COLMAP
  std::string hero;                    // the hero photo's name in `images` (or a path: its file name is used)
  std::filesystem::path out = "plane.json";
  std::filesystem::path camera;     // camera.json: hero intrinsics, and fixed intrinsics for COLMAP
  std::filesystem::path workspace;  // empty: <out stem>_colmap beside out

  // COLMAP (see ColmapRunOptions)
  std::string colmap = "colmap";
  std::string matcher = "exhaustive";
  std::string camera_model = "SIMPLE_RADIAL";
  int max_image_size = 3200;
  int max_features = 8192;
  int min_registered = 3;  // fewer registered images is an error

  // Plane fit
  double inlier_threshold = 0.0;  // model units; 0: threshold_fraction x the median viewing distance
  double threshold_fraction = kPlaneThresholdFraction;
  int ransac_iterations = 2000;
  double min_inlier_fraction = kMinPlaneInlierFraction;

  // Metric scale: an AprilTag of known size, or a known distance between two
  // points (on the plane in the hero photo, or two COLMAP 3D point ids).
  double tag_size = 0.0;  // black border edge; > 0 enables the tag
  std::string tag_family = "tag36h11";
  int tag_id = -1;  // -1: every tag of the family that is found
  double distance = 0.0;
  std::vector<Eigen::Vector2d> distance_pixels;  // 2 hero pixels (centres at integers)
  std::vector<uint64_t> distance_points;         // 2 COLMAP point3D ids

  // Message naming the bad option, or empty.
  std::string Validate() const;
};

struct TagScaleReport {
  int tag_id = -1;
  int views = 0;             // images the tag was found in
  double edge_model = 0.0;   // mean black-border edge in model units
  double squareness = 0.0;   // |diagonal ratio - 1| of the reconstructed square
  bool triangulated = false; // false: one view, corners intersected with the plane
};

struct PlaneStageResult {
  // x_world = colmap_to_world * x_model: a similarity (rotation, translation,
  // uniform scale `scale`).
  Eigen::Matrix4d colmap_to_world = Eigen::Matrix4d::Identity();
  double scale = 1.0;  // world units per model unit
  std::string scale_source = "none";
  std::vector<TagScaleReport> tags;
  std::string hero_name;
  Camera hero;                    // intrinsics as used, c2w in the world frame
  std::string hero_intrinsics;    // "camera.json" or "colmap"
  Eigen::Vector2d half_extent = Eigen::Vector2d::Zero();  // world units
  PlaneFitResult fit;             // model units and frame
  double threshold = 0.0;         // model units
  int cameras_below = 0;          // registered cameras on the far side of the plane
  int input_images = 0;           // 0 when unknown (an existing model)
  int registered_images = 0;
  size_t points = 0;
  std::vector<std::pair<std::string, Eigen::Matrix4d>> cameras;  // every registered image: name, c2w (world)
  double colmap_seconds = 0.0;
  std::filesystem::path model_dir, plane_json;
};

PlaneStageResult RunPlaneStage(const PlaneStageOptions& options, const StageContext& ctx);

// The part after COLMAP, on a model in memory (images are read from
// options.images only for the AprilTag scale). Writes nothing.
PlaneStageResult RegisterPlane(const ColmapModel& model, const PlaneStageOptions& options, const StageContext& ctx);

// The photos of a folder COLMAP reads (file names, sorted; .jpg .jpeg .png
// .tif .tiff .bmp: FreeImage formats, linear EXRs are not photos).
std::vector<std::string> ListPhotos(const std::filesystem::path& dir);

// The model to use in a COLMAP output folder: `dir` itself when it holds
// one, else the numbered sub-folder (0/, 1/, ...) with the most images.
std::filesystem::path SelectColmapModel(const std::filesystem::path& dir);

}  // namespace shadowsg
