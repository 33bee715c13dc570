#include "calib/image_warp.h"

#include <opencv2/imgproc.hpp>

#include "calib/error.h"
#include "calib/internal/opencv_bridge.h"

namespace shadowsg {

Camera PinholeOf(const Camera& camera) {
  Camera c = camera;
  c.k1 = c.k2 = c.p1 = c.p2 = c.k3 = 0.0;
  return c;
}

Camera ResizeCamera(const Camera& camera, int width, int height) {
  SHADOWSG_CHECK(width > 0 && height > 0 && camera.width > 0 && camera.height > 0);
  Camera c = camera;
  const double sx = static_cast<double>(width) / camera.width;
  const double sy = static_cast<double>(height) / camera.height;
  c.width = width;
  c.height = height;
  c.fx *= sx;
  c.fy *= sy;
  c.cx = (c.cx + 0.5) * sx - 0.5;
  c.cy = (c.cy + 0.5) * sy - 0.5;
  return c;
}

Image UndistortImage(const Image& image, const Camera& camera, WarpSampling sampling, Image* outside) {
  SHADOWSG_CHECK(camera.projection == Projection::kPerspective);
  SHADOWSG_CHECK(image.width == camera.width && image.height == camera.height);
  // map(u, v) = where the distorted camera saw the ray of pinhole pixel (u, v).
  cv::Mat map_x(image.height, image.width, CV_32FC1), map_y(image.height, image.width, CV_32FC1);
  for (int v = 0; v < image.height; ++v) {
    float* mx = map_x.ptr<float>(v);
    float* my = map_y.ptr<float>(v);
    for (int u = 0; u < image.width; ++u) {
      const Eigen::Vector2d d = Distort(camera, {(u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy});
      mx[u] = static_cast<float>(camera.fx * d.x() + camera.cx);
      my[u] = static_cast<float>(camera.fy * d.y() + camera.cy);
    }
  }
  const cv::Mat src = internal::ToCvFloat(image);
  cv::Mat dst;
  cv::remap(src, dst, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar::all(0));
  Image out = internal::FromCvFloat(dst);
  if (sampling == WarpSampling::kAnyNonZero)
    for (float& v : out.data) v = v > 0.0f ? 1.0f : 0.0f;
  if (outside) {
    *outside = Image(image.width, image.height, 1);
    for (int v = 0; v < image.height; ++v)
      for (int u = 0; u < image.width; ++u) {
        const float x = map_x.at<float>(v, u), y = map_y.at<float>(v, u);
        const bool in = x >= 0.0f && y >= 0.0f && x <= image.width - 1.0f && y <= image.height - 1.0f;
        outside->at(u, v, 0) = in ? 0.0f : 1.0f;
      }
  }
  return out;
}

}  // namespace shadowsg
