// Human-checkable pictures of the capture stages (coverage of calibration
// views, tag detections, projected meshes): an 8-bit RGB drawing surface with
// anti-aliased primitives at sub-pixel positions. Pixel centres sit at integer
// coordinates (conventions.h), so a point drawn at (u, v) lands on the pixel
// that the camera model projects to (u, v).
#pragma once

#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "calib/image.h"

namespace shadowsg {

class Canvas {
 public:
  // Starts from a display-referred image (values in [0, 1], 1 or 3 channels),
  // its brightness scaled by `dim` (1: unchanged).
  explicit Canvas(const Image& background, float dim = 1.0f);
  // A blank canvas of one colour.
  Canvas(int width, int height, const Eigen::Vector3f& colour);
  ~Canvas();
  Canvas(const Canvas&) = delete;
  Canvas& operator=(const Canvas&) = delete;

  int width() const;
  int height() const;

  void Line(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector3f& colour, int thickness = 1);
  void Polyline(const std::vector<Eigen::Vector2d>& points, bool closed, const Eigen::Vector3f& colour,
                int thickness = 1);
  void Circle(const Eigen::Vector2d& centre, double radius, const Eigen::Vector3f& colour, int thickness = 1);
  void Disc(const Eigen::Vector2d& centre, double radius, const Eigen::Vector3f& colour);
  void Cross(const Eigen::Vector2d& centre, double half_size, const Eigen::Vector3f& colour, int thickness = 1);
  // Text with its baseline starting at `origin`; height about 20 * scale pixels,
  // drawn with a dark outline so that it reads on any background.
  void Text(const Eigen::Vector2d& origin, const std::string& text, const Eigen::Vector3f& colour, double scale = 0.5);
  // Blends `overlay` into this canvas with weight alpha (same size).
  void BlendFrom(const Canvas& overlay, float alpha);

  // RGB values in [0, 1], ready for WriteLdr.
  Image ToImage() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// A distinct colour for item i of n (hue ramp), for colouring views or tags.
Eigen::Vector3f CategoricalColour(int i, int n);

}  // namespace shadowsg
