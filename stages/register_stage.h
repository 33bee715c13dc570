// `shadowsg register`: assembles a registered scene folder (scene-format.md)
// from the capture stages' artifacts: the hero camera's intrinsics
// (camera.json) and pose (plane.json), the linear hero photo, the object's
// pose in that photo (pose.json) and its mesh. Writes scene.json, image.exr,
// geometry/mesh.obj, mask.png (plane pixels that may be used: not clipped,
// not the object, not an AprilTag and its paper, inside the plane rectangle)
// and mask_preview.png.
//
// Units. plane.json's world is metric when its scale_source is "apriltag" or
// "distance" (the unit of that reference; the mesh and pose.json must use the
// same one). When it is "none" (COLMAP's arbitrary units) the world is
// rescaled to pose.json's units: from the camera-to-plane distance in
// pose.json's plane_c when there is one, else by assuming the object rests on
// the plane (its lowest vertex touches it).
//
// Albedo. A single photo fixes only albedo x light: the plane's albedo is
// given (--albedo), or measured against the white paper of an AprilTag seen
// in the photo (known paper albedo), or else set by convention (kConventionAlbedo,
// grey): the recovered lighting then carries the true albedo's scale and colour.
// scene.json records which in "registration": {"albedo_source": ...}.
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <optional>
#include <string>

#include "solver/scene.h"
#include "stages/stage_context.h"

namespace shadowsg {

// Plane albedo when nothing measures it: the reference code's default.
inline constexpr double kConventionAlbedo = 0.8;
// Diffuse reflectance of office printer paper: 0.8-0.9 in the visible range
// (ISO 2469 brightness of common copy paper is ~ 90 %); measure yours for better.
inline constexpr double kPaperAlbedo = 0.85;
// Projected tag cells smaller than this (pixels) are too blurred to sample
// the paper's white.
inline constexpr double kMinTagCellPx = 3.0;
// Fewer white cell samples than this give no albedo estimate.
inline constexpr int kMinPaperSamples = 8;

enum class AlbedoMode { kAuto, kGiven, kTag, kConvention };

struct RegisterStageOptions {
  std::filesystem::path camera;  // camera.json for the linear image; empty: plane.json's hero camera
  std::filesystem::path image;   // linear hero photo (EXR)
  std::filesystem::path plane;   // plane.json
  std::filesystem::path pose;    // pose.json
  std::filesystem::path mesh;    // the object (OBJ/PLY, pose.json's units)
  std::filesystem::path out;     // the scene folder

  // Clipped pixels: a mask (non-zero = clipped); empty: <image stem>_clipped.png
  // beside the image when it exists (what `shadowsg linearize` writes).
  std::filesystem::path clipped;
  // > 0: pixels with a channel at or above this are clipped too. 0: automatic,
  // the image's maximum when at least kMinSaturatedPixels pixels reach it.
  double clip_level = 0.0;
  // Half extents of the plane rectangle (world units after rescaling); empty:
  // plane.json's "scale" (the extent of the reconstructed plane points).
  std::optional<Eigen::Vector2d> plane_half_size;
  int object_margin_px = 2;  // masked border around the object, tags and clipped pixels

  AlbedoMode albedo_mode = AlbedoMode::kAuto;  // auto: tag when one is found, else convention
  Eigen::Vector3d albedo = Eigen::Vector3d::Constant(kConventionAlbedo);  // kGiven
  double paper_albedo = kPaperAlbedo;
  Eigen::Vector3d object_albedo = Eigen::Vector3d::Constant(kConventionAlbedo);

  // AprilTags in the photo are masked out (with their paper: the square
  // tag_exclude_scale times the tag's whole pattern).
  bool mask_tags = true;
  std::string tag_family = "tag36h11";
  double tag_exclude_scale = 1.5;

  // Moves the object along the normal so that its lowest vertex touches the
  // plane (otherwise only reported).
  bool snap_to_plane = false;

  // Message naming the bad option, or empty.
  std::string Validate() const;
};

inline constexpr int kMinSaturatedPixels = 16;

struct RegisterStageResult {
  Scene scene;  // as written (image included)
  double pose_units_per_world_unit = 1.0;
  std::string units_from;  // "plane.json", "plane_c", "contact"
  std::optional<double> plane_c_ratio;  // plane_c's camera height / plane.json's (cross-check)
  std::string albedo_source;  // "given", "apriltag", "convention"
  double object_gap = 0.0;   // lowest vertex above the plane (world units; < 0: below)
  size_t mask_pixels = 0;
  size_t clipped_pixels = 0;
  int tags_masked = 0;
  std::filesystem::path scene_dir;
};

RegisterStageResult RunRegisterStage(const RegisterStageOptions& options, const StageContext& ctx);

}  // namespace shadowsg
