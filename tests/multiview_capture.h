// A synthetic multi-view capture rendered by the project's own path tracer
// (solver/path_tracer.h): a textured ground plane (value noise, so that SIFT
// finds features, and an AprilTag printed on white paper), a box resting on
// it, a sun and a sky; views on a ring around the object, a hero view, and a
// set of checkerboard photos through the same lens. Ground truth for the
// plane and register stages.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "calib/camera.h"
#include "calib/image.h"
#include "solver/lights.h"
#include "solver/scene.h"

namespace shadowsg::testing {

struct MultiviewSpec {
  int width = 320, height = 240;
  double fx = 300, fy = 300;
  double k1 = -0.05;
  double plane_half = 1.0;               // metres
  double noise = 1.0;                    // 0: a uniform plane of albedo `plane_albedo`
  Eigen::Vector3d plane_albedo = Eigen::Vector3d(0.55, 0.45, 0.35);
  double paper_albedo = 0.85;
  int tag_id = 3;
  double tag_size = 0.2;                 // black border edge, metres
  Eigen::Vector2d tag_centre = Eigen::Vector2d(0.4, -0.35);
  Eigen::Vector3d box_half = Eigen::Vector3d(0.1, 0.08, 0.15);  // resting on the plane at the origin
  int texture_size = 1280;  // 1.5625 mm texels: the tag's cells are whole texels (sharp, unbiased edges)
  int spp = 4;
  uint64_t seed = 7;
};

struct MultiviewCapture {
  MultiviewSpec spec;
  Scene scene;        // camera = the hero; plane with its albedo texture; the box
  LightSet lights;
  Camera lens;        // intrinsics shared by every view (c2w = identity)
  std::vector<Eigen::Matrix4d> ring;  // c2w of the ring views
  Eigen::Matrix4d hero_c2w = Eigen::Matrix4d::Identity();
  double exposure = 1.0;  // linear -> display scale for the 8-bit photos
};

MultiviewCapture MakeMultiviewCapture(const MultiviewSpec& spec, int ring_views);

// Linear RGB render of the capture from c2w.
Image RenderView(const MultiviewCapture& capture, const Eigen::Matrix4d& c2w, uint64_t seed);
// The 8-bit photo of a linear render: exposure, sRGB curve (values in [0, 1]).
Image ToPhoto(const Image& linear, double exposure);

// Checkerboard photos (cols x rows inner corners, square side `square`)
// rendered through `lens` into dir/board_XX.png.
void RenderCheckerboardSet(const Camera& lens, int cols, int rows, double square, int views,
                           const std::filesystem::path& dir, int spp, uint64_t seed);

// The capture as a folder `shadowsg run` reads, and its capture.json:
//   boards/board_XX.png   checkerboard photos (board_cols x board_rows inner corners)
//   images/view_XX.png    the ring views, 8-bit
//   images/hero.png       the hero view, 8-bit (COLMAP and the pose stage)
//   hero.exr              the hero view, linear (the photo a camera raw would give)
//   box.obj               the caster in the pose stage's object frame: its centre,
//                         axes along the tag's (= the world's), so its mesh is the
//                         box turned as it stands; the tag offset puts it there
// capture.json sets "intrinsics", "walkaround", "hero", "object" and "tags";
// the returned document is what was written (add "solve", "composite", ...
// and write it again as needed).
struct CaptureFolderOptions {
  int board_cols = 8, board_rows = 5, board_views = 12;
  double board_square = 0.03;
  int max_features = 768;  // CPU matching is brute force: fewer features keep the pairs quick
};
nlohmann::json WriteCaptureFolder(const MultiviewCapture& capture, const std::filesystem::path& dir,
                                  const CaptureFolderOptions& options = {});

// Angle between the rotations of two c2w matrices, degrees.
double RotationAngleDeg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b);

// The rigid motion that keeps the plane z = 0 (a turn about z and a shift in
// x, y) best mapping `from` onto `to` (least squares over the x, y of point
// pairs): how two registered frames of the same plane differ.
Eigen::Matrix4d AlignAboutZ(const std::vector<Eigen::Vector3d>& from, const std::vector<Eigen::Vector3d>& to);

}  // namespace shadowsg::testing
