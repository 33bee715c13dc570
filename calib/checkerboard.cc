#include "calib/checkerboard.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/error.h"
#include "calib/internal/opencv_bridge.h"

namespace shadowsg {

using internal::PoseFromRvecTvec;

bool CheckerboardOptions::IsValid(std::string* why) const {
  if (cols < 2 || rows < 2) {
    *why = "the board needs at least 2x2 inner corners";
    return false;
  }
  if (max_detect_side < 200) {
    *why = "max_detect_side must be at least 200 pixels";
    return false;
  }
  return true;
}

bool IntrinsicsOptions::IsValid(std::string* why) const {
  if (cols < 2 || rows < 2) {
    *why = "the board needs at least 2x2 inner corners";
    return false;
  }
  if (!(square > 0) || !std::isfinite(square)) {
    *why = "the square size must be positive";
    return false;
  }
  if (max_view_rms_px < 0) {
    *why = "the view RMS limit must be positive (or 0: automatic)";
    return false;
  }
  if (min_views < 1) {
    *why = "at least one view is needed";
    return false;
  }
  return true;
}

int IntrinsicsResult::UsedViews() const {
  return static_cast<int>(std::count_if(views.begin(), views.end(), [](const ViewReport& v) { return v.used; }));
}

std::vector<Eigen::Vector3d> CheckerboardObjectPoints(int cols, int rows, double square) {
  std::vector<Eigen::Vector3d> pts;
  pts.reserve(static_cast<size_t>(cols) * rows);
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) pts.emplace_back(c * square, r * square, 0.0);
  return pts;
}

namespace {

// Half-size of the cornerSubPix window: half the smallest corner spacing, so
// that the window stays within the four squares around its corner (no other
// grid line crosses it), at most 11 (OpenCV's calibration sample: a 23x23
// window, the setting of its published calibration of the sample set).
int SubPixHalfWindow(const std::vector<cv::Point2f>& corners, int cols) {
  double spacing = 1e9;
  for (size_t i = 0; i < corners.size(); ++i) {
    if ((i + 1) % cols != 0) spacing = std::min(spacing, cv::norm(corners[i + 1] - corners[i]));
    if (i + cols < corners.size()) spacing = std::min(spacing, cv::norm(corners[i + cols] - corners[i]));
  }
  return std::clamp(static_cast<int>(0.5 * spacing), 2, 11);
}

}  // namespace

std::optional<std::vector<Eigen::Vector2d>> DetectCheckerboard(const Image& image, const CheckerboardOptions& o) {
  std::string why;
  SHADOWSG_CHECK(o.IsValid(&why));
  const cv::Mat gray = internal::ToGray8(image);
  const cv::Size pattern(o.cols, o.rows);
  const int side = std::max(gray.cols, gray.rows);
  const double scale = side > o.max_detect_side ? static_cast<double>(o.max_detect_side) / side : 1.0;
  cv::Mat small = gray;
  if (scale < 1.0) cv::resize(gray, small, cv::Size(), scale, scale, cv::INTER_AREA);

  std::vector<cv::Point2f> corners;
  bool found = false;
  if (o.detector == CornerDetector::kSectorBased) {
    // The quick search first (0.1 s at 640x480), the exhaustive one (4x
    // slower) only when it fails. CALIB_CB_ACCURACY is not asked for:
    // cornerSubPix below does better.
    found = cv::findChessboardCornersSB(small, pattern, corners, cv::CALIB_CB_NORMALIZE_IMAGE);
    if (!found)
      found =
          cv::findChessboardCornersSB(small, pattern, corners, cv::CALIB_CB_NORMALIZE_IMAGE | cv::CALIB_CB_EXHAUSTIVE);
  }
  if (!found) {
    found =
        cv::findChessboardCorners(small, pattern, corners, cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE);
  }
  if (!found || corners.size() != static_cast<size_t>(o.cols) * o.rows) return std::nullopt;
  if (scale < 1.0) {
    // Pixel centres at integers: small pixel i covers full-resolution
    // [i / s - 0.5, (i + 1) / s - 0.5), its centre maps to (i + 0.5) / s - 0.5.
    for (auto& c : corners) c = cv::Point2f((c.x + 0.5f) / float(scale) - 0.5f, (c.y + 0.5f) / float(scale) - 0.5f);
  }
  // Both detectors' corners are refined to the saddle point with cornerSubPix
  // at full resolution: on rendered boards with known corners this halves the
  // worst error of findChessboardCornersSB's own sub-pixel estimate (0.40 ->
  // 0.20 px), and it is the refinement of OpenCV's published calibration.
  const int half = SubPixHalfWindow(corners, o.cols);
  cv::cornerSubPix(gray, corners, cv::Size(half, half), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 50, 1e-3));
  std::vector<Eigen::Vector2d> out;
  out.reserve(corners.size());
  for (const auto& c : corners) out.emplace_back(c.x, c.y);
  return out;
}

namespace {

struct Fit {
  cv::Mat K, D;
  std::vector<cv::Vec3d> rvecs, tvecs;
  std::vector<double> view_rms;
  std::vector<double> std_dev;
  double rms = 0;
};

Fit RunCalibration(const std::vector<std::vector<cv::Point3f>>& obj, const std::vector<std::vector<cv::Point2f>>& img,
                   cv::Size size, const IntrinsicsOptions& o) {
  int flags = 0;
  Fit fit;
  fit.K = cv::Mat::eye(3, 3, CV_64F);  // with FIX_ASPECT_RATIO only fx/fy = 1 is used
  if (o.fix_aspect) flags |= cv::CALIB_FIX_ASPECT_RATIO;
  if (o.fix_principal_point) flags |= cv::CALIB_FIX_PRINCIPAL_POINT;
  if (o.zero_tangential) flags |= cv::CALIB_ZERO_TANGENT_DIST;
  if (o.fix_k3) flags |= cv::CALIB_FIX_K3;
  fit.D = cv::Mat::zeros(1, 5, CV_64F);
  cv::Mat std_intr, std_extr, per_view;
  std::vector<cv::Mat> rvecs, tvecs;
  try {
    fit.rms = cv::calibrateCamera(obj, img, size, fit.K, fit.D, rvecs, tvecs, std_intr, std_extr, per_view, flags,
                                  cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 100, DBL_EPSILON));
  } catch (const cv::Exception& e) {
    throw InputError("intrinsics", "calibration failed (degenerate views?): " + e.err);
  }
  for (size_t i = 0; i < rvecs.size(); ++i) {
    fit.rvecs.emplace_back(rvecs[i]);
    fit.tvecs.emplace_back(tvecs[i]);
    fit.view_rms.push_back(per_view.at<double>(static_cast<int>(i)));
  }
  for (int i = 0; i < 9 && i < std_intr.rows; ++i) fit.std_dev.push_back(std_intr.at<double>(i));
  if (o.fix_aspect && fit.std_dev.size() > 1) fit.std_dev[0] = fit.std_dev[1];  // one parameter, fx = fy
  return fit;
}

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

std::string Fixed2(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.2f", v);
  return buf;
}

}  // namespace

IntrinsicsResult CalibrateIntrinsics(const std::vector<CalibrationView>& views, int width, int height,
                                     const IntrinsicsOptions& o) {
  std::string why;
  if (!o.IsValid(&why)) throw InputError("intrinsics", why);
  const size_t n_corners = static_cast<size_t>(o.cols) * o.rows;
  std::vector<cv::Point3f> board;
  for (const auto& p : CheckerboardObjectPoints(o.cols, o.rows, o.square))
    board.emplace_back(float(p.x()), float(p.y()), float(p.z()));

  IntrinsicsResult result;
  std::vector<std::vector<cv::Point2f>> all_img(views.size());
  std::vector<size_t> active;
  for (size_t i = 0; i < views.size(); ++i) {
    ViewReport r;
    r.name = views[i].name;
    r.corners = views[i].corners;
    if (views[i].corners.size() != n_corners) {
      r.rejection = "wrong number of corners";
    } else {
      for (const auto& c : views[i].corners) all_img[i].emplace_back(float(c.x()), float(c.y()));
      active.push_back(i);
    }
    result.views.push_back(std::move(r));
  }
  const auto too_few = [&](size_t n) {
    return InputError("intrinsics", "only " + std::to_string(n) + " usable view(s) of a " + std::to_string(o.cols) +
                                        "x" + std::to_string(o.rows) + " board; at least " +
                                        std::to_string(o.min_views) + " are needed");
  };
  if (active.size() < static_cast<size_t>(std::max(o.min_views, 1))) throw too_few(active.size());

  const cv::Size size(width, height);
  Fit fit;
  while (true) {
    std::vector<std::vector<cv::Point3f>> obj(active.size(), board);
    std::vector<std::vector<cv::Point2f>> img;
    for (size_t i : active) img.push_back(all_img[i]);
    fit = RunCalibration(obj, img, size, o);
    if (active.size() <= static_cast<size_t>(o.min_views)) break;
    const double limit = o.max_view_rms_px > 0 ? o.max_view_rms_px
                                               : std::max(kOutlierMedianFactor * Median(fit.view_rms), kOutlierFloorPx);
    const size_t worst =
        static_cast<size_t>(std::max_element(fit.view_rms.begin(), fit.view_rms.end()) - fit.view_rms.begin());
    if (fit.view_rms[worst] <= limit) break;
    ViewReport& r = result.views[active[worst]];
    r.rejection = "outlier: reprojection RMS " + Fixed2(fit.view_rms[worst]) + " px > " + Fixed2(limit) + " px";
    active.erase(active.begin() + static_cast<long>(worst));
  }

  Camera& cam = result.camera;
  cam.width = width;
  cam.height = height;
  cam.fx = fit.K.at<double>(0, 0);
  cam.fy = fit.K.at<double>(1, 1);
  cam.cx = fit.K.at<double>(0, 2);
  cam.cy = fit.K.at<double>(1, 2);
  cam.k1 = fit.D.at<double>(0);
  cam.k2 = fit.D.at<double>(1);
  cam.p1 = fit.D.at<double>(2);
  cam.p2 = fit.D.at<double>(3);
  cam.k3 = fit.D.at<double>(4);
  result.rms_px = fit.rms;
  result.std_dev = fit.std_dev;
  for (size_t k = 0; k < active.size(); ++k) {
    ViewReport& r = result.views[active[k]];
    r.used = true;
    r.rms_px = fit.view_rms[k];
    r.board_to_camera = PoseFromRvecTvec(fit.rvecs[k], fit.tvecs[k]);
  }
  // Rejected views that have corners: their error under the final camera.
  const cv::Matx33d K = internal::CvCameraMatrix(cam);
  const cv::Mat D = internal::CvDistortion(cam);
  for (size_t i = 0; i < views.size(); ++i) {
    ViewReport& r = result.views[i];
    if (r.used || all_img[i].empty()) continue;
    cv::Vec3d rvec, tvec;
    if (!cv::solvePnP(board, all_img[i], K, D, rvec, tvec)) continue;
    std::vector<cv::Point2f> proj;
    cv::projectPoints(board, rvec, tvec, K, D, proj);
    double sq = 0;
    for (size_t j = 0; j < proj.size(); ++j) sq += std::pow(cv::norm(proj[j] - all_img[i][j]), 2);
    r.rms_px = std::sqrt(sq / proj.size());
    r.board_to_camera = PoseFromRvecTvec(rvec, tvec);
  }
  return result;
}

}  // namespace shadowsg
