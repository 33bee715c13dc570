// Camera intrinsics from photos of a planar checkerboard: sub-pixel corner
// detection and OpenCV's calibrateCamera with the Brown-Conrady model
// (k1 k2 p1 p2 k3), with rejection of views that are outliers.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "calib/camera.h"
#include "calib/image.h"

namespace shadowsg {

enum class CornerDetector {
  kSectorBased,  // cv::findChessboardCornersSB (accurate, robust to blur); falls back to kClassic
  kClassic,      // cv::findChessboardCorners + cv::cornerSubPix
};

struct CheckerboardOptions {
  int cols = 0;  // inner corners per row (OpenCV's pattern width: 9 for a board of 10x7 squares)
  int rows = 0;  // inner corners per column
  CornerDetector detector = CornerDetector::kSectorBased;
  // Larger images are searched at this size, then the corners are refined at
  // full resolution (speed on 20+ megapixel photos).
  int max_detect_side = 2000;

  bool IsValid(std::string* why) const;
};

// Inner corners row by row (OpenCV's order), pixel centres at integers; nullopt
// when the whole board is not found. `image` is display-referred, in [0, 1].
std::optional<std::vector<Eigen::Vector2d>> DetectCheckerboard(const Image& image, const CheckerboardOptions& options);

struct CalibrationView {
  std::string name;
  std::vector<Eigen::Vector2d> corners;  // as from DetectCheckerboard
};

struct IntrinsicsOptions {
  int cols = 0, rows = 0;            // inner corners (as CheckerboardOptions)
  double square = 1.0;               // square side, any length unit (only the extrinsics depend on it)
  bool fix_aspect = false;           // fx = fy (CALIB_FIX_ASPECT_RATIO with ratio 1)
  bool fix_principal_point = false;  // cx, cy at the image centre
  bool zero_tangential = false;      // p1 = p2 = 0
  bool fix_k3 = false;               // k3 = 0
  // A view whose RMS reprojection error exceeds this is rejected (worst first,
  // then the camera is re-fitted). 0: automatic, kOutlierMedianFactor times the
  // median view RMS but at least kOutlierFloorPx.
  double max_view_rms_px = 0.0;
  int min_views = 3;

  bool IsValid(std::string* why) const;
};

// Automatic outlier rule: a view is an outlier when its RMS is more than
// kOutlierMedianFactor times the median view's (a robust scale of the noise;
// good views of one shoot agree within a factor of 2.5: 0.15-0.47 px on
// OpenCV's sample set but for left02.jpg at 0.91 px, 0.04-0.10 px on rendered
// boards) and more than kOutlierFloorPx,
// below which a view is never called an outlier (when every view is
// excellent, a ratio alone would reject good ones). Rendered boards show why
// it matters: one view through another lens, at 1.4 px against a median of
// 0.18 px, pulls the distortion model 9 px off at the image corners.
inline constexpr double kOutlierMedianFactor = 3.0;
inline constexpr double kOutlierFloorPx = 0.5;

struct ViewReport {
  std::string name;
  bool used = false;
  double rms_px = 0.0;    // with the final camera (also for rejected views)
  std::string rejection;  // why it was rejected, empty when used
  Eigen::Matrix4d board_to_camera = Eigen::Matrix4d::Identity();
  std::vector<Eigen::Vector2d> corners;  // detected
};

struct IntrinsicsResult {
  Camera camera;                  // c2w = identity
  double rms_px = 0.0;            // over all corners of the used views
  std::vector<ViewReport> views;  // in input order
  // One standard deviation of fx fy cx cy k1 k2 p1 p2 k3 (OpenCV's estimate).
  std::vector<double> std_dev;

  int UsedViews() const;
};

// Throws InputError when fewer than options.min_views views remain.
IntrinsicsResult CalibrateIntrinsics(const std::vector<CalibrationView>& views, int width, int height,
                                     const IntrinsicsOptions& options);

// Board corner positions in the board frame (x along a row, z = 0), the order
// of DetectCheckerboard.
std::vector<Eigen::Vector3d> CheckerboardObjectPoints(int cols, int rows, double square);

}  // namespace shadowsg
