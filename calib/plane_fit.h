// The dominant plane of a 3D point cloud (an SfM reconstruction's ground):
// RANSAC on point triples, then least-squares refinement (total least
// squares, i.e. the smallest principal axis of the inliers) alternating with
// re-selecting the inliers.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace shadowsg {

struct PlaneRansacOptions {
  // Largest point-to-plane distance of an inlier, in the cloud's units; > 0.
  // See PlaneInlierThreshold for one derived from the reconstruction's scale.
  double inlier_threshold = 0.0;
  int max_iterations = 2000;     // RANSAC hypotheses at most
  double confidence = 0.9999;    // stop early once a better plane is this unlikely
  int refine_iterations = 5;     // least-squares fit / inlier re-selection rounds
  uint64_t seed = 0;             // same seed, same planes

  bool IsValid(std::string* why) const;
};

struct PlaneFitResult {
  Eigen::Vector3d point = Eigen::Vector3d::Zero();   // centroid of the inliers
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();  // unit; sign as fitted (see OrientPlaneNormal)
  std::vector<bool> inliers;                           // per input point
  int num_inliers = 0;
  double rms = 0.0;      // RMS point-to-plane distance over the inliers
  int iterations = 0;    // RANSAC hypotheses drawn

  double Distance(const Eigen::Vector3d& p) const { return normal.dot(p - point); }
};

// nullopt when there are fewer than 3 points or every sample is degenerate
// (collinear). Deterministic for a given seed.
std::optional<PlaneFitResult> FitPlaneRansac(const std::vector<Eigen::Vector3d>& points,
                                             const PlaneRansacOptions& options);

// Total-least-squares plane through points (centroid, unit normal); nullopt
// when they are collinear or fewer than 3.
std::optional<std::pair<Eigen::Vector3d, Eigen::Vector3d>> LeastSquaresPlane(
    const std::vector<Eigen::Vector3d>& points);

// Inlier threshold from the reconstruction's scale: kPlaneThresholdFraction of
// the median distance from a point to its nearest camera centre (the viewing
// distance). Scale-free, so it suits SfM's arbitrary units.
inline constexpr double kPlaneThresholdFraction = 0.01;
// Objects resting on the plane rise well above 1 % of the viewing distance,
// while SfM noise on a textured surface stays well below it (COLMAP's
// ~0.5 px reprojection error at f ~ 1000 px is 0.05 % of the depth per view).
double PlaneInlierThreshold(const std::vector<Eigen::Vector3d>& points,
                            const std::vector<Eigen::Vector3d>& camera_centres,
                            double fraction = kPlaneThresholdFraction);

// Flips `normal` so that most camera centres lie on its positive side;
// returns how many lie on the other side (0 when all agree).
int OrientPlaneNormal(const std::vector<Eigen::Vector3d>& camera_centres, PlaneFitResult* plane);

}  // namespace shadowsg
