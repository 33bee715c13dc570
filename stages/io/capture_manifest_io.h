// capture.json ("capture/1"): what a capture folder holds, for `shadowsg run`
// (README, "shadowsg run"): the checkerboard photos (or a camera.json), the
// walk-around photos, the hero photo and its linear source, the object's mesh,
// the AprilTags, and the settings of register, solve and composite.
//
// Paths are relative to the folder holding capture.json. The reader checks
// what it can without running anything (keys, types, ranges, that named files
// and folders exist) and throws InputError naming capture.json and the key.
// Settings a capture leaves out are std::nullopt / empty: the stage's own
// default applies (defaults live with the stages, not here).
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "stages/io/json_util.h"

namespace shadowsg {

inline constexpr const char* kCaptureFormat = "capture/1";

struct CaptureManifest {
  std::filesystem::path file;  // capture.json
  std::filesystem::path dir;   // its folder: relative paths start here

  // "intrinsics": a camera.json to use as it is, or checkerboard photos.
  struct Intrinsics {
    std::filesystem::path camera;  // given: the intrinsics stage is not run
    std::filesystem::path images;  // folder of checkerboard photos
    int cols = 0, rows = 0;        // inner corners ("board": "9x6" or [9, 6])
    std::optional<double> square, max_view_rms;
    std::optional<int> min_views;
    std::string detector;  // "sb" | "classic"; empty: the stage's default
    bool fix_aspect = false, fix_principal_point = false, zero_tangential = false, fix_k3 = false;
  } intrinsics;

  // "walkaround": the photos COLMAP reconstructs (the hero among them).
  struct Walkaround {
    std::filesystem::path images;
    std::filesystem::path colmap_model;  // optional existing sparse model: COLMAP is not run
    std::string matcher, camera_model;
    std::optional<int> max_image_size, max_features, min_registered;
    std::optional<double> plane_threshold_fraction;
  } walkaround;

  // "hero": the view the scene is registered in.
  struct Hero {
    std::filesystem::path photo;                // 8-bit photo in walkaround.images (COLMAP, pose)
    std::vector<std::filesystem::path> linear;  // linearize's inputs; empty: the photo
    std::vector<double> times;                  // exposure times (s), one per linear input
    std::string response, colour, wb;           // linearize's --response, --colour, --wb
    bool half_size = false, align = false;
    bool undistort = false;  // resample the linear image to the pinhole camera
  } hero;

  // "object": the real shadow caster.
  struct Object {
    std::filesystem::path mesh;
    std::string up = "z";  // mesh axis along the plane normal: "z" | "y"
    std::optional<Eigen::Vector3d> albedo;
    bool snap_to_plane = false;
  } object;

  // "tags": AprilTags for the object's pose and the plane's metric scale.
  struct Tags {
    std::string family;  // empty: the stages' default (tag36h11)
    double size = 0.0;   // black border edge (from the layout's "size" when absent here)
    int id = -1;         // the one tag to use; -1: the only one seen (pose) / every one (plane)
    std::optional<Eigen::Vector3d> offset;  // object origin from the tag centre (pose, one tag)
    std::filesystem::path layout;           // several tags placed on the object (pose)
  } tags;

  // "plane": the registered plane's albedo and extent.
  struct PlaneSettings {
    std::string albedo = "auto";  // "auto" | "tag" | "convention" | "given" (albedo_rgb)
    Eigen::Vector3d albedo_rgb = Eigen::Vector3d::Zero();
    std::optional<double> paper_albedo;
    std::optional<Eigen::Vector2d> half_size;
  } plane;

  // "solve": the lighting solver (stages/solve_stage.h).
  struct Solve {
    std::string method, budget, ssdf;
    std::optional<int> lobes, steps, map_height;
  } solve;

  // "composite": virtual objects to insert (the stage is off without them).
  struct Composite {
    std::filesystem::path objects;  // "objects/1" file
    std::string quality;            // "final" | "preview"
    std::optional<int> spp, bounces, supersampling;
  } composite;

  Json json;  // the document as read (each stage's settings, for resuming)
};

// `name_for_errors` names the document; `dir` resolves relative paths.
CaptureManifest ParseCaptureManifest(const Json& json, const std::string& name_for_errors,
                                     const std::filesystem::path& dir);
// CAPTURE_DIR/capture.json, or a path to the file itself.
CaptureManifest ReadCaptureManifest(const std::filesystem::path& capture);

}  // namespace shadowsg
