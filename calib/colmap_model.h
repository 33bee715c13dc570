// COLMAP sparse models (cameras, images, points3D) in COLMAP 3.8's binary and
// text layouts (doc/format.rst and src/base/reconstruction.cc @3.8), read and
// written by our own code: Debian's colmap ships no library. Values are kept
// exactly as COLMAP stores them (pixel centres at (0.5, 0.5), world-to-camera
// poses); ColmapCameraToCamera and ColmapImageToC2w convert them to the
// project's conventions through calib/conventions.h.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <filesystem>
#include <istream>
#include <map>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "calib/camera.h"
#include "calib/conventions.h"

namespace shadowsg {

using colmap_camera_t = uint32_t;
using colmap_image_t = uint32_t;
using colmap_point3D_t = uint64_t;
// A 2D feature without a 3D point: 2^64 - 1 in binary models, -1 in text ones.
inline constexpr colmap_point3D_t kColmapInvalidPoint3D = ~colmap_point3D_t{0};

struct ColmapCamera {
  colmap_camera_t id = 0;
  std::string model;  // "PINHOLE", "OPENCV", ... (COLMAP's names)
  uint64_t width = 0, height = 0;
  std::vector<double> params;  // COLMAP's order for the model (pixel centres at 0.5)
};

struct ColmapImage {
  colmap_image_t id = 0;
  ColmapPose pose;  // world to camera
  colmap_camera_t camera_id = 0;
  std::string name;  // relative to COLMAP's image_path
  std::vector<Eigen::Vector2d> points2D;         // pixels, COLMAP's convention
  std::vector<colmap_point3D_t> point3D_ids;     // per 2D point, kColmapInvalidPoint3D when none
};

struct ColmapTrackElement {
  colmap_image_t image_id = 0;
  uint32_t point2D_idx = 0;
};

struct ColmapPoint3D {
  colmap_point3D_t id = 0;
  Eigen::Vector3d xyz = Eigen::Vector3d::Zero();
  std::array<uint8_t, 3> rgb{0, 0, 0};
  double error = 0.0;  // mean reprojection error, pixels
  std::vector<ColmapTrackElement> track;
};

struct ColmapModel {
  std::map<colmap_camera_t, ColmapCamera> cameras;
  std::map<colmap_image_t, ColmapImage> images;
  std::vector<ColmapPoint3D> points;

  // The image called `name`, or else the only one whose file name (without
  // folders) is `name`; nullptr when there is none.
  const ColmapImage* FindImage(const std::string& name) const;
  const ColmapPoint3D* FindPoint(colmap_point3D_t id) const;
};

// Parameter count of a COLMAP camera model, and its name <-> id (camera_models.h
// @3.8); -1 / "" for unknown ones.
int ColmapModelParamCount(const std::string& model);
int ColmapModelId(const std::string& model);
std::string ColmapModelName(int model_id);

// ---- Readers and writers (InputError names the file and the problem) ------
// A model folder holds cameras, images and points3D, all .bin or all .txt.
// Models with rigs/frames (COLMAP >= 3.12) are rejected with a clear message.
ColmapModel ReadColmapModel(const std::filesystem::path& dir);
enum class ColmapFormat { kBinary, kText };
void WriteColmapModel(const std::filesystem::path& dir, const ColmapModel& model, ColmapFormat format);
// True when `dir` holds a (binary or text) model.
bool IsColmapModelDir(const std::filesystem::path& dir);

// Stream versions; `name` is used in messages.
void ReadColmapCamerasBinary(std::istream& in, const std::string& name, ColmapModel* model);
void ReadColmapImagesBinary(std::istream& in, const std::string& name, ColmapModel* model);
void ReadColmapPointsBinary(std::istream& in, const std::string& name, ColmapModel* model);
void ReadColmapCamerasText(std::istream& in, const std::string& name, ColmapModel* model);
void ReadColmapImagesText(std::istream& in, const std::string& name, ColmapModel* model);
void ReadColmapPointsText(std::istream& in, const std::string& name, ColmapModel* model);
void WriteColmapCamerasBinary(std::ostream& out, const ColmapModel& model);
void WriteColmapImagesBinary(std::ostream& out, const ColmapModel& model);
void WriteColmapPointsBinary(std::ostream& out, const ColmapModel& model);
void WriteColmapCamerasText(std::ostream& out, const ColmapModel& model);
void WriteColmapImagesText(std::ostream& out, const ColmapModel& model);
void WriteColmapPointsText(std::ostream& out, const ColmapModel& model);

// ---- Conversion to the project's conventions -------------------------------
// Intrinsics in our camera model (OpenCV pixel centres, c2w = identity).
// Supported: SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV, and
// FULL_OPENCV when k4 = k5 = k6 = 0; others (fisheye, FOV, ...) throw
// InputError naming `where` and the model.
Camera ColmapCameraToCamera(const ColmapCamera& camera, const std::string& where = "COLMAP model");
// The inverse: an OPENCV camera (FULL_OPENCV when k3 != 0) with COLMAP's
// pixel convention, for --ImageReader.camera_params.
ColmapCamera CameraToColmapCamera(const Camera& camera);
// The image's full camera: intrinsics and c2w (camera to the model's world).
Camera ColmapImageCamera(const ColmapModel& model, const ColmapImage& image);

}  // namespace shadowsg
