#include "calib/pose_estimation.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <opencv2/calib3d.hpp>

#include "calib/error.h"
#include "calib/internal/opencv_bridge.h"
#include "calib/plane_fit.h"

namespace shadowsg {

using internal::CvCameraMatrix;
using internal::CvDistortion;
using internal::PoseFromRvecTvec;
using internal::PoseToRvecTvec;
using internal::ToCvPoints;

namespace {

Eigen::Matrix4d RigidInverse(const Eigen::Matrix4d& T) {
  Eigen::Matrix4d inv = Eigen::Matrix4d::Identity();
  inv.topLeftCorner<3, 3>() = T.topLeftCorner<3, 3>().transpose();
  inv.topRightCorner<3, 1>() = -inv.topLeftCorner<3, 3>() * T.topRightCorner<3, 1>();
  return inv;
}

Eigen::Matrix4d Rotation(const Eigen::Vector3d& axis, double angle) {
  Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
  T.topLeftCorner<3, 3>() = Eigen::AngleAxisd(angle, axis).toRotationMatrix();
  return T;
}

Eigen::Matrix4d Translation(const Eigen::Vector3d& t) {
  Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
  T.topRightCorner<3, 1>() = t;
  return T;
}

Eigen::Vector3d Apply(const Eigen::Matrix4d& T, const Eigen::Vector3d& p) {
  return T.topLeftCorner<3, 3>() * p + T.topRightCorner<3, 1>();
}

PoseEstimate Evaluate(const std::vector<Eigen::Vector3d>& object, const std::vector<Eigen::Vector2d>& image,
                      const Camera& camera, const Eigen::Matrix4d& o2c, double inlier_px) {
  PoseEstimate e;
  e.o2c = o2c;
  e.reprojected = ProjectPoints(object, o2c, camera);
  double sq = 0;
  for (size_t i = 0; i < object.size(); ++i) {
    const double d = (e.reprojected[i] - image[i]).norm();
    const bool in = std::isfinite(d) && d <= inlier_px;
    e.inliers.push_back(in);
    if (in) {
      sq += d * d;
      ++e.num_inliers;
    }
  }
  e.rms_px = e.num_inliers ? std::sqrt(sq / e.num_inliers) : std::numeric_limits<double>::infinity();
  return e;
}

}  // namespace

std::vector<Eigen::Vector2d> ProjectPoints(const std::vector<Eigen::Vector3d>& object, const Eigen::Matrix4d& o2c,
                                           const Camera& camera) {
  Camera local = camera;
  local.c2w = Eigen::Matrix4d::Identity();
  std::vector<Eigen::Vector2d> out;
  out.reserve(object.size());
  for (const auto& p : object) {
    const auto px = ProjectToPixel(local, Apply(o2c, p));
    out.push_back(px ? *px : Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN()));
  }
  return out;
}

double ReprojectionRms(const std::vector<Eigen::Vector3d>& object, const std::vector<Eigen::Vector2d>& image,
                       const Eigen::Matrix4d& o2c, const Camera& camera) {
  SHADOWSG_CHECK(object.size() == image.size() && !object.empty());
  const auto proj = ProjectPoints(object, o2c, camera);
  double sq = 0;
  for (size_t i = 0; i < proj.size(); ++i) sq += (proj[i] - image[i]).squaredNorm();
  return std::sqrt(sq / proj.size());
}

PoseEstimate RefinePose(const std::vector<Eigen::Vector3d>& object, const std::vector<Eigen::Vector2d>& image,
                        const Camera& camera, const Eigen::Matrix4d& initial) {
  SHADOWSG_CHECK(object.size() == image.size() && object.size() >= 3);
  cv::Vec3d rvec, tvec;
  PoseToRvecTvec(initial, &rvec, &tvec);
  cv::solvePnPRefineLM(ToCvPoints(object), ToCvPoints(image), CvCameraMatrix(camera), CvDistortion(camera), rvec, tvec,
                       cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 100, 1e-12));
  return Evaluate(object, image, camera, PoseFromRvecTvec(rvec, tvec), std::numeric_limits<double>::infinity());
}

bool PnpOptions::IsValid(std::string* why) const {
  if (!(ransac_threshold_px > 0)) {
    *why = "the RANSAC threshold must be positive";
    return false;
  }
  if (ransac_iterations < 1) {
    *why = "RANSAC needs at least one iteration";
    return false;
  }
  if (!(confidence > 0 && confidence < 1)) {
    *why = "the RANSAC confidence must be in (0, 1)";
    return false;
  }
  return true;
}

PoseEstimate SolvePnp(const std::vector<Eigen::Vector3d>& object, const std::vector<Eigen::Vector2d>& image,
                      const Camera& camera, const PnpOptions& o) {
  std::string why;
  if (!o.IsValid(&why)) throw InputError("pnp", why);
  SHADOWSG_CHECK(object.size() == image.size());
  if (object.size() < 4)
    throw InputError("pnp", "needs at least 4 correspondences, got " + std::to_string(object.size()));
  cv::Vec3d rvec, tvec;
  std::vector<int> inliers;
  bool ok = false;
  try {
    ok = cv::solvePnPRansac(ToCvPoints(object), ToCvPoints(image), CvCameraMatrix(camera), CvDistortion(camera), rvec,
                            tvec, false, o.ransac_iterations, static_cast<float>(o.ransac_threshold_px), o.confidence,
                            inliers, object.size() >= 6 ? cv::SOLVEPNP_EPNP : cv::SOLVEPNP_ITERATIVE);
  } catch (const cv::Exception& e) {
    throw InputError("pnp", "no pose (degenerate correspondences?): " + e.err);
  }
  if (!ok || inliers.size() < 4)
    throw InputError("pnp", "no pose fits at least 4 of the " + std::to_string(object.size()) +
                                " correspondences within " + std::to_string(o.ransac_threshold_px) + " px");
  // Refine on the inliers, then re-classify all points against the final pose.
  std::vector<Eigen::Vector3d> obj_in;
  std::vector<Eigen::Vector2d> img_in;
  for (int i : inliers) {
    obj_in.push_back(object[i]);
    img_in.push_back(image[i]);
  }
  Eigen::Matrix4d pose = RefinePose(obj_in, img_in, camera, PoseFromRvecTvec(rvec, tvec)).o2c;
  PoseEstimate e = Evaluate(object, image, camera, pose, o.ransac_threshold_px);
  if (e.num_inliers >= 4 && e.num_inliers != static_cast<int>(obj_in.size())) {
    obj_in.clear();
    img_in.clear();
    for (size_t i = 0; i < object.size(); ++i)
      if (e.inliers[i]) {
        obj_in.push_back(object[i]);
        img_in.push_back(image[i]);
      }
    pose = RefinePose(obj_in, img_in, camera, pose).o2c;
    e = Evaluate(object, image, camera, pose, o.ransac_threshold_px);
  }
  return e;
}

std::array<Eigen::Vector3d, 4> TagCornerPoints(double size) {
  const double s = size / 2;
  return {Eigen::Vector3d(-s, s, 0), Eigen::Vector3d(s, s, 0), Eigen::Vector3d(s, -s, 0), Eigen::Vector3d(-s, -s, 0)};
}

std::vector<Eigen::Matrix4d> SquarePoseCandidates(const std::array<Eigen::Vector2d, 4>& corners, double size,
                                                  const Camera& camera) {
  const auto obj3 = TagCornerPoints(size);
  std::vector<cv::Point3d> obj;
  std::vector<cv::Point2d> img;
  for (int k = 0; k < 4; ++k) {
    obj.emplace_back(obj3[k].x(), obj3[k].y(), obj3[k].z());
    img.emplace_back(corners[k].x(), corners[k].y());
  }
  std::vector<cv::Mat> rvecs, tvecs;
  cv::solvePnPGeneric(obj, img, CvCameraMatrix(camera), CvDistortion(camera), rvecs, tvecs, false,
                      cv::SOLVEPNP_IPPE_SQUARE);
  std::vector<Eigen::Matrix4d> out;
  for (size_t i = 0; i < rvecs.size(); ++i) out.push_back(PoseFromRvecTvec(cv::Vec3d(rvecs[i]), cv::Vec3d(tvecs[i])));
  return out;
}

Eigen::Matrix4d TagToObjectOnPlane(const Eigen::Vector3d& offset, MeshUp up) {
  // The tag's up frame is its own frame turned half a turn about x
  // (y_up = -y_tag, z_up = -z_tag); a y-up mesh is turned a quarter turn so
  // that its +y lands on +z.
  const Eigen::Matrix4d up_to_tag = Rotation(Eigen::Vector3d::UnitX(), M_PI);
  const Eigen::Matrix4d mesh_to_up =
      up == MeshUp::kY ? Rotation(Eigen::Vector3d::UnitX(), M_PI / 2) : Eigen::Matrix4d::Identity();
  const Eigen::Matrix4d o2t = up_to_tag * Translation(offset) * mesh_to_up;
  return RigidInverse(o2t);
}

Eigen::Matrix4d TagOnGround(const Eigen::Vector3d& centre, double yaw_rad) {
  return Translation(centre) * Rotation(Eigen::Vector3d::UnitZ(), yaw_rad) * Rotation(Eigen::Vector3d::UnitX(), M_PI);
}

std::optional<std::pair<Eigen::Vector3d, Eigen::Vector3d>> FitPlane(const std::vector<Eigen::Vector3d>& points,
                                                                    double tolerance) {
  auto plane = LeastSquaresPlane(points);
  if (!plane) return std::nullopt;
  auto& [c, n] = *plane;
  for (const auto& p : points)
    if (std::abs(n.dot(p - c)) > tolerance) return std::nullopt;
  if (n.dot(-c) < 0) n = -n;  // towards the camera at the origin
  return plane;
}

TagPoseResult EstimatePoseFromTags(const std::vector<TagDetection>& detections,
                                   const std::vector<TagPlacement>& placements, const Camera& camera) {
  std::map<int, const TagPlacement*> by_id;
  for (const auto& p : placements) by_id[p.id] = &p;
  TagPoseResult r;
  std::vector<const TagDetection*> used;
  for (const auto& d : detections) {
    if (by_id.count(d.id) == 0) {
      r.unknown_ids.push_back(d.id);
      continue;
    }
    if (std::find(r.used_ids.begin(), r.used_ids.end(), d.id) != r.used_ids.end()) {
      r.duplicate_ids.push_back(d.id);
      continue;
    }
    r.used_ids.push_back(d.id);
    used.push_back(&d);
  }
  if (used.empty()) {
    std::string ids;
    for (const auto& d : detections) ids += (ids.empty() ? "" : ", ") + std::to_string(d.id);
    throw InputError("tags", detections.empty() ? "no tag detected in the image"
                                                : "none of the detected tags (ids " + ids + ") has a placement");
  }
  std::vector<Eigen::Vector3d> obj;
  std::vector<Eigen::Vector2d> img;
  double min_size = std::numeric_limits<double>::infinity();
  for (const auto* d : used) {
    const TagPlacement& p = *by_id[d->id];
    min_size = std::min(min_size, p.size);
    const auto corners = TagCornerPoints(p.size);
    for (int k = 0; k < 4; ++k) {
      obj.push_back(Apply(p.t2o, corners[k]));
      img.push_back(d->corners[k]);
    }
  }
  // Every IPPE candidate of every tag seeds a joint refinement.
  bool have = false;
  for (const auto* d : used) {
    const TagPlacement& p = *by_id[d->id];
    for (const auto& t2c : SquarePoseCandidates(d->corners, p.size, camera)) {
      const PoseEstimate e = RefinePose(obj, img, camera, t2c * RigidInverse(p.t2o));
      bool in_front = true;
      for (const auto& x : obj) in_front &= Apply(e.o2c, x).z() > 0;
      if (in_front && std::isfinite(e.rms_px) && (!have || e.rms_px < r.pose.rms_px)) {
        r.pose = e;
        have = true;
      }
    }
  }
  if (!have) throw InputError("tags", "no tag pose puts the tags in front of the camera");
  for (size_t t = 0; t < used.size(); ++t) {
    double sq = 0;
    for (int k = 0; k < 4; ++k) sq += (r.pose.reprojected[4 * t + k] - img[4 * t + k]).squaredNorm();
    r.tag_rms_px.push_back(std::sqrt(sq / 4));
  }
  std::vector<Eigen::Vector3d> cam_pts;
  for (const auto& x : obj) cam_pts.push_back(Apply(r.pose.o2c, x));
  // Tags placed on one plane are coplanar to rounding; 0.1 % of a tag's size
  // separates that from a layout with tags on different faces.
  constexpr double kCoplanarFraction = 1e-3;
  if (auto plane = FitPlane(cam_pts, kCoplanarFraction * min_size)) {
    const Eigen::Vector3d origin = r.pose.o2c.topRightCorner<3, 1>();
    const Eigen::Vector3d& n = plane->second;
    r.plane = std::make_pair(Eigen::Vector3d(origin - n.dot(origin - plane->first) * n), n);
  }
  return r;
}

}  // namespace shadowsg
