#include "calib/internal/opencv_bridge.h"

#include <algorithm>
#include <cmath>
#include <opencv2/calib3d.hpp>

#include "calib/error.h"

namespace shadowsg::internal {

cv::Matx33d CvCameraMatrix(const Camera& c) { return {c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1}; }

cv::Mat CvDistortion(const Camera& c) { return (cv::Mat_<double>(1, 5) << c.k1, c.k2, c.p1, c.p2, c.k3); }

cv::Mat ToGray8(const Image& image) {
  SHADOWSG_CHECK(!image.empty());
  cv::Mat gray(image.height, image.width, CV_8UC1);
  const int nc = image.channels;
  for (int y = 0; y < image.height; ++y) {
    unsigned char* row = gray.ptr<unsigned char>(y);
    for (int x = 0; x < image.width; ++x) {
      const float* p = &image.data[image.index(x, y) * nc];
      const float luma = nc >= 3 ? 0.299f * p[0] + 0.587f * p[1] + 0.114f * p[2] : p[0];
      row[x] = static_cast<unsigned char>(std::lround(std::clamp(luma, 0.0f, 1.0f) * 255.0f));
    }
  }
  return gray;
}

cv::Mat ToCvFloat(const Image& image) {
  cv::Mat m(image.height, image.width, CV_32FC(image.channels));
  for (int y = 0; y < image.height; ++y)
    std::copy_n(&image.data[image.index(0, y) * image.channels], static_cast<size_t>(image.width) * image.channels,
                m.ptr<float>(y));
  return m;
}

Image FromCvFloat(const cv::Mat& mat) {
  cv::Mat f = mat;
  if (mat.depth() != CV_32F) mat.convertTo(f, CV_32F);
  Image img(f.cols, f.rows, f.channels());
  for (int y = 0; y < f.rows; ++y)
    std::copy_n(f.ptr<float>(y), static_cast<size_t>(f.cols) * f.channels(), &img.data[img.index(0, y) * img.channels]);
  return img;
}

Eigen::Matrix4d PoseFromRvecTvec(const cv::Vec3d& rvec, const cv::Vec3d& tvec) {
  cv::Matx33d R;
  cv::Rodrigues(rvec, R);
  Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) T(i, j) = R(i, j);
    T(i, 3) = tvec[i];
  }
  return T;
}

void PoseToRvecTvec(const Eigen::Matrix4d& T, cv::Vec3d* rvec, cv::Vec3d* tvec) {
  cv::Matx33d R;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) R(i, j) = T(i, j);
  cv::Rodrigues(R, *rvec);
  *tvec = cv::Vec3d(T(0, 3), T(1, 3), T(2, 3));
}

std::vector<cv::Point2d> ToCvPoints(const std::vector<Eigen::Vector2d>& points) {
  std::vector<cv::Point2d> out;
  out.reserve(points.size());
  for (const auto& p : points) out.emplace_back(p.x(), p.y());
  return out;
}

std::vector<cv::Point3d> ToCvPoints(const std::vector<Eigen::Vector3d>& points) {
  std::vector<cv::Point3d> out;
  out.reserve(points.size());
  for (const auto& p : points) out.emplace_back(p.x(), p.y(), p.z());
  return out;
}

}  // namespace shadowsg::internal
