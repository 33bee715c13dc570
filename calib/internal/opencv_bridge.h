// Internal to shadowsg_capture (never included by a public header): the one
// place where project types meet OpenCV's. Camera matrices and distortion
// vectors follow OpenCV's conventions, which are the project's (camera.h).
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <vector>

#include "calib/camera.h"
#include "calib/image.h"

namespace shadowsg::internal {

cv::Matx33d CvCameraMatrix(const Camera& camera);
// k1 k2 p1 p2 k3, OpenCV's order.
cv::Mat CvDistortion(const Camera& camera);

// 8-bit luma (Rec. 601 weights, like cv::COLOR_RGB2GRAY) of an image whose
// values are display-referred in [0, 1].
cv::Mat ToGray8(const Image& image);
// Float RGB (or 1-channel) copy, channel order kept.
cv::Mat ToCvFloat(const Image& image);
Image FromCvFloat(const cv::Mat& mat);

Eigen::Matrix4d PoseFromRvecTvec(const cv::Vec3d& rvec, const cv::Vec3d& tvec);
void PoseToRvecTvec(const Eigen::Matrix4d& pose, cv::Vec3d* rvec, cv::Vec3d* tvec);

std::vector<cv::Point2d> ToCvPoints(const std::vector<Eigen::Vector2d>& points);
std::vector<cv::Point3d> ToCvPoints(const std::vector<Eigen::Vector3d>& points);

}  // namespace shadowsg::internal
