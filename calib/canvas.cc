#include "calib/canvas.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "calib/error.h"

namespace shadowsg {

// Coordinates go to OpenCV with this many fractional bits (sub-pixel drawing).
constexpr int kShift = 4;
constexpr double kShiftScale = 1 << kShift;

struct Canvas::Impl {
  cv::Mat bgr;  // CV_8UC3
};

namespace {

cv::Scalar Bgr(const Eigen::Vector3f& rgb) {
  auto c = [](float v) { return std::clamp(static_cast<double>(v), 0.0, 1.0) * 255.0; };
  return {c(rgb.z()), c(rgb.y()), c(rgb.x())};
}

cv::Point Fixed(const Eigen::Vector2d& p) {
  // Keeps far-away points (e.g. projections near the horizon) inside int range;
  // OpenCV clips lines to the image.
  constexpr double kLimit = 1 << 20;
  return {static_cast<int>(std::lround(std::clamp(p.x(), -kLimit, kLimit) * kShiftScale)),
          static_cast<int>(std::lround(std::clamp(p.y(), -kLimit, kLimit) * kShiftScale))};
}

}  // namespace

Canvas::Canvas(const Image& background, float dim) : impl_(std::make_unique<Impl>()) {
  SHADOWSG_CHECK(!background.empty());
  impl_->bgr.create(background.height, background.width, CV_8UC3);
  for (int y = 0; y < background.height; ++y) {
    auto* row = impl_->bgr.ptr<cv::Vec3b>(y);
    for (int x = 0; x < background.width; ++x) {
      const Eigen::Vector3f v = background.rgb(background.index(x, y)) * dim;
      for (int c = 0; c < 3; ++c)
        row[x][2 - c] = static_cast<unsigned char>(std::lround(std::clamp(v[c], 0.0f, 1.0f) * 255.0f));
    }
  }
}

Canvas::Canvas(int width, int height, const Eigen::Vector3f& colour) : impl_(std::make_unique<Impl>()) {
  impl_->bgr = cv::Mat(height, width, CV_8UC3, Bgr(colour));
}

Canvas::~Canvas() = default;

int Canvas::width() const { return impl_->bgr.cols; }
int Canvas::height() const { return impl_->bgr.rows; }

void Canvas::Line(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector3f& colour, int thickness) {
  if (!a.allFinite() || !b.allFinite()) return;
  cv::line(impl_->bgr, Fixed(a), Fixed(b), Bgr(colour), thickness, cv::LINE_AA, kShift);
}

void Canvas::Polyline(const std::vector<Eigen::Vector2d>& points, bool closed, const Eigen::Vector3f& colour,
                      int thickness) {
  std::vector<cv::Point> pts;
  for (const auto& p : points)
    if (p.allFinite()) pts.push_back(Fixed(p));
  if (pts.size() < 2) return;
  cv::polylines(impl_->bgr, pts, closed, Bgr(colour), thickness, cv::LINE_AA, kShift);
}

void Canvas::Circle(const Eigen::Vector2d& c, double radius, const Eigen::Vector3f& colour, int thickness) {
  if (!c.allFinite()) return;
  cv::circle(impl_->bgr, Fixed(c), static_cast<int>(std::lround(radius * kShiftScale)), Bgr(colour), thickness,
             cv::LINE_AA, kShift);
}

void Canvas::Disc(const Eigen::Vector2d& c, double radius, const Eigen::Vector3f& colour) {
  if (!c.allFinite()) return;
  cv::circle(impl_->bgr, Fixed(c), static_cast<int>(std::lround(radius * kShiftScale)), Bgr(colour), cv::FILLED,
             cv::LINE_AA, kShift);
}

void Canvas::Cross(const Eigen::Vector2d& c, double h, const Eigen::Vector3f& colour, int thickness) {
  Line(c + Eigen::Vector2d(-h, -h), c + Eigen::Vector2d(h, h), colour, thickness);
  Line(c + Eigen::Vector2d(-h, h), c + Eigen::Vector2d(h, -h), colour, thickness);
}

void Canvas::Text(const Eigen::Vector2d& origin, const std::string& text, const Eigen::Vector3f& colour, double scale) {
  const cv::Point o(static_cast<int>(std::lround(origin.x())), static_cast<int>(std::lround(origin.y())));
  const int thick = std::max(1, static_cast<int>(std::lround(2 * scale)));
  cv::putText(impl_->bgr, text, o, cv::FONT_HERSHEY_SIMPLEX, scale, cv::Scalar(0, 0, 0), thick + 2, cv::LINE_AA);
  cv::putText(impl_->bgr, text, o, cv::FONT_HERSHEY_SIMPLEX, scale, Bgr(colour), thick, cv::LINE_AA);
}

void Canvas::BlendFrom(const Canvas& overlay, float alpha) {
  SHADOWSG_CHECK(overlay.width() == width() && overlay.height() == height());
  cv::addWeighted(overlay.impl_->bgr, alpha, impl_->bgr, 1.0 - alpha, 0.0, impl_->bgr);
}

Image Canvas::ToImage() const {
  Image img(width(), height(), 3);
  for (int y = 0; y < height(); ++y) {
    const auto* row = impl_->bgr.ptr<cv::Vec3b>(y);
    for (int x = 0; x < width(); ++x)
      for (int c = 0; c < 3; ++c) img.at(x, y, c) = row[x][2 - c] / 255.0f;
  }
  return img;
}

Eigen::Vector3f CategoricalColour(int i, int n) {
  // HSV hue ramp at full saturation and value, skipping pure red (reserved for
  // rejections and errors).
  const double h = 30.0 + 300.0 * (n > 1 ? static_cast<double>(i) / (n - 1) : 0.0);
  const double hp = h / 60.0;
  const double x = 1.0 - std::abs(std::fmod(hp, 2.0) - 1.0);
  Eigen::Vector3f rgb;
  switch (static_cast<int>(hp) % 6) {
    case 0:
      rgb = {1, float(x), 0};
      break;
    case 1:
      rgb = {float(x), 1, 0};
      break;
    case 2:
      rgb = {0, 1, float(x)};
      break;
    case 3:
      rgb = {0, float(x), 1};
      break;
    case 4:
      rgb = {float(x), 0, 1};
      break;
    default:
      rgb = {1, 0, float(x)};
      break;
  }
  return rgb;
}

}  // namespace shadowsg
