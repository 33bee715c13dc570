#include "synthetic_capture.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "calib/apriltag_detect.h"

namespace shadowsg::testing {

PlaneRenderer::PlaneRenderer(const Camera& camera, int supersample)
    : camera_(camera), ss_(supersample), gw_(camera.width + 2), gh_(camera.height + 2) {
  // Undistortion is smooth: sample it once per pixel and interpolate
  // bilinearly for the sub-samples (error well below 0.01 px).
  grid_.resize(static_cast<size_t>(gw_) * gh_);
  for (int j = 0; j < gh_; ++j)
    for (int i = 0; i < gw_; ++i) {
      const double u = i - 1, v = j - 1;
      grid_[static_cast<size_t>(j) * gw_ + i] =
          Undistort(camera_, {(u - camera_.cx) / camera_.fx, (v - camera_.cy) / camera_.fy});
    }
}

Eigen::Vector2d PlaneRenderer::Ray(double u, double v) const {
  const double gx = std::clamp(u + 1, 0.0, gw_ - 1.001), gy = std::clamp(v + 1, 0.0, gh_ - 1.001);
  const int i = static_cast<int>(gx), j = static_cast<int>(gy);
  const double fx = gx - i, fy = gy - j;
  const auto g = [&](int a, int b) { return grid_[static_cast<size_t>(b) * gw_ + a]; };
  return (1 - fy) * ((1 - fx) * g(i, j) + fx * g(i + 1, j)) + fy * ((1 - fx) * g(i, j + 1) + fx * g(i + 1, j + 1));
}

Image PlaneRenderer::Render(const Eigen::Matrix4d& p2c, const PlaneTexture& texture, float background) const {
  const Eigen::Matrix3d R = p2c.topLeftCorner<3, 3>();
  const Eigen::Vector3d t = p2c.topRightCorner<3, 1>();
  const Eigen::Vector3d n = R.col(2);
  const Eigen::Matrix3d Rt = R.transpose();
  const double nt = n.dot(t);
  Image img(camera_.width, camera_.height, 1);
#pragma omp parallel for schedule(static)
  for (int v = 0; v < camera_.height; ++v)
    for (int u = 0; u < camera_.width; ++u) {
      double sum = 0;
      for (int sy = 0; sy < ss_; ++sy)
        for (int sx = 0; sx < ss_; ++sx) {
          const double su = u + (sx + 0.5) / ss_ - 0.5, sv = v + (sy + 0.5) / ss_ - 0.5;
          const Eigen::Vector2d r = Ray(su, sv);
          const Eigen::Vector3d d(r.x(), r.y(), 1.0);
          const double nd = n.dot(d);
          const double lambda = nd != 0 ? nt / nd : -1;
          if (lambda <= 0) {
            sum += background;
            continue;
          }
          const Eigen::Vector3d q = Rt * (lambda * d - t);
          sum += texture(q.x(), q.y());
        }
      img.at(u, v, 0) = static_cast<float>(sum / (ss_ * ss_));
    }
  return img;
}

PlaneTexture CheckerboardTexture(int cols, int rows, double square) {
  return [=](double x, double y) -> float {
    const double i = std::floor(x / square), j = std::floor(y / square);
    // Squares -1 .. cols-1 (x) and -1 .. rows-1 (y): (cols+1) x (rows+1)
    // squares around the inner corners, then a white margin of two squares.
    if (i < -3 || j < -3 || i > cols + 1 || j > rows + 1) return 0.5f;
    if (i < -1 || j < -1 || i > cols - 1 || j > rows - 1) return 0.95f;
    return (static_cast<long>(i + j) % 2 == 0) ? 0.05f : 0.95f;
  };
}

PlaneTexture TagsTexture(const std::vector<PlacedTag>& tags) {
  struct Prepared {
    TagPattern pattern;
    PlacedTag tag;
    double cell;
  };
  std::vector<Prepared> prepared;
  for (const auto& t : tags) {
    TagPattern p = MakeTagPattern(t.family, t.id);
    prepared.push_back({p, t, t.size / p.border_width});
  }
  return [prepared](double x, double y) -> float {
    for (const auto& p : prepared) {
      const double half = 0.5 * p.pattern.total_width * p.cell;
      const double dx = x - p.tag.centre.x(), dy = y - p.tag.centre.y();
      const double c = std::cos(p.tag.rotation_rad), s = std::sin(p.tag.rotation_rad);
      const double lx = c * dx + s * dy + half, ly = -s * dx + c * dy + half;
      if (lx < 0 || ly < 0 || lx >= 2 * half || ly >= 2 * half) continue;
      const int col = std::min(static_cast<int>(lx / p.cell), p.pattern.total_width - 1);
      const int row = std::min(static_cast<int>(ly / p.cell), p.pattern.total_width - 1);
      return p.pattern.at(col, row) ? 0.95f : 0.05f;
    }
    return 0.95f;  // paper
  };
}

void AddNoiseAndQuantise(Image* image, double sigma, uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> noise(0.0f, static_cast<float>(sigma));
  for (float& v : image->data) v = std::round(std::clamp(v + (sigma > 0 ? noise(rng) : 0.0f), 0.0f, 1.0f) * 255) / 255;
}

Image ToRgb(const Image& gray) {
  Image rgb(gray.width, gray.height, 3);
  for (size_t p = 0; p < gray.pixels(); ++p) rgb.set_rgb(p, Eigen::Vector3f::Constant(gray.data[p]));
  return rgb;
}

Eigen::Matrix4d Pose(const Eigen::Vector3d& axis, double degrees, const Eigen::Vector3d& t) {
  Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
  T.topLeftCorner<3, 3>() = Eigen::AngleAxisd(degrees * M_PI / 180, axis.normalized()).toRotationMatrix();
  T.topRightCorner<3, 1>() = t;
  return T;
}

double RotationErrorDeg(const Eigen::Matrix4d& a, const Eigen::Matrix4d& b) {
  const Eigen::Matrix3d d = a.topLeftCorner<3, 3>().transpose() * b.topLeftCorner<3, 3>();
  return Eigen::AngleAxisd(d).angle() * 180 / M_PI;
}

}  // namespace shadowsg::testing
