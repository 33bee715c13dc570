// Object poses from one photo: from AprilTags whose placement on the object
// is known (several tags are fitted jointly), or from 2D-3D correspondences
// (RANSAC PnP, then refinement). Reprojection goes through the camera's full
// distortion model. OpenCV stays in pose_estimation.cc.
#pragma once

#include <Eigen/Core>
#include <array>
#include <optional>
#include <string>
#include <vector>

#include "calib/apriltag_detect.h"
#include "calib/camera.h"

namespace shadowsg {

struct PoseEstimate {
  Eigen::Matrix4d o2c = Eigen::Matrix4d::Identity();  // object to camera (OpenCV axes)
  double rms_px = 0.0;                                // over the inliers
  std::vector<bool> inliers;                          // per correspondence
  std::vector<Eigen::Vector2d> reprojected;           // per correspondence, with the final pose
  int num_inliers = 0;
};

// Reprojection of object points under o2c (pixels); RMS against `image`.
std::vector<Eigen::Vector2d> ProjectPoints(const std::vector<Eigen::Vector3d>& object, const Eigen::Matrix4d& o2c,
                                           const Camera& camera);
double ReprojectionRms(const std::vector<Eigen::Vector3d>& object, const std::vector<Eigen::Vector2d>& image,
                       const Eigen::Matrix4d& o2c, const Camera& camera);

// Levenberg-Marquardt on the reprojection error of all points from `initial`.
PoseEstimate RefinePose(const std::vector<Eigen::Vector3d>& object, const std::vector<Eigen::Vector2d>& image,
                        const Camera& camera, const Eigen::Matrix4d& initial);

struct PnpOptions {
  double ransac_threshold_px = 4.0;  // inlier distance
  int ransac_iterations = 1000;
  double confidence = 0.999;  // OpenCV 4.6's RANSAC is deterministic (fixed internal seed)

  bool IsValid(std::string* why) const;
};

// RANSAC PnP (EPnP hypotheses) then refinement on the inliers. Throws
// InputError when fewer than 4 points are given or no pose is found.
PoseEstimate SolvePnp(const std::vector<Eigen::Vector3d>& object, const std::vector<Eigen::Vector2d>& image,
                      const Camera& camera, const PnpOptions& options);

// ---- Tags ---------------------------------------------------------------
// A tag's corners in its own frame (x right, y down, z into the tag), in the
// order of TagDetection::corners; `size` is the black border's edge.
std::array<Eigen::Vector3d, 4> TagCornerPoints(double size);

// The two poses of a square (IPPE), best first by reprojection error.
std::vector<Eigen::Matrix4d> SquarePoseCandidates(const std::array<Eigen::Vector2d, 4>& corners, double size,
                                                  const Camera& camera);

// Where a tag sits on the object: t2o maps the tag frame to object coordinates.
struct TagPlacement {
  int id = -1;
  double size = 0.0;
  Eigen::Matrix4d t2o = Eigen::Matrix4d::Identity();
};

// Mesh axis that points away from the ground plane (up).
enum class MeshUp { kZ, kY };

// The object sits on the tag's plane, its origin at `offset` from the tag
// centre in the tag's "up" frame (x along the tag's x, y towards the tag's top
// edge, z along the plane normal on the camera's side), its `up` axis along
// the normal. Returns the tag-to-object transform.
Eigen::Matrix4d TagToObjectOnPlane(const Eigen::Vector3d& offset, MeshUp up);
// A tag lying face-up on the object's ground plane (z up): its centre at
// `centre` (object coordinates) and its x axis turned by `yaw_rad` about +z.
Eigen::Matrix4d TagOnGround(const Eigen::Vector3d& centre, double yaw_rad);

struct TagPoseResult {
  PoseEstimate pose;
  std::vector<int> used_ids;       // detections that entered the fit
  std::vector<int> unknown_ids;    // detected but without a placement (ignored)
  std::vector<int> duplicate_ids;  // detected again (only the first, strongest, is used)
  std::vector<double> tag_rms_px;  // per used tag, with the final pose
  // The tags' common plane in camera coordinates, normal towards the camera,
  // xyz the foot of the object origin on it; absent when the tags are not coplanar.
  std::optional<std::pair<Eigen::Vector3d, Eigen::Vector3d>> plane;
};

// Joint least-squares fit over all corners of the placed tags; each tag's two
// IPPE poses seed a candidate and the lowest total error wins. Detections
// are taken in order, so sort the strongest first (DetectTags does). Throws
// InputError when no detection has a placement.
TagPoseResult EstimatePoseFromTags(const std::vector<TagDetection>& detections,
                                   const std::vector<TagPlacement>& placements, const Camera& camera);

// The least-squares plane (LeastSquaresPlane, plane_fit.h) through `points`
// (camera coordinates) with its normal towards the camera, when they are
// coplanar within `tolerance`.
std::optional<std::pair<Eigen::Vector3d, Eigen::Vector3d>> FitPlane(const std::vector<Eigen::Vector3d>& points,
                                                                    double tolerance);

}  // namespace shadowsg
