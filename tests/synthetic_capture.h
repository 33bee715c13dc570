// Test images rendered through the project's camera model (camera.h): a
// textured plane (checkerboard, AprilTags) seen by a camera with known K,
// distortion and pose, anti-aliased by supersampling, with optional sensor
// noise and 8-bit quantisation. Ground truth for the capture stages' tests.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "calib/camera.h"
#include "calib/image.h"

namespace shadowsg::testing {

// Reflectance in [0, 1] at plane point (x, y); the plane frame's z points
// into the surface (away from the camera), like a tag's or a board's.
using PlaneTexture = std::function<float(double x, double y)>;

class PlaneRenderer {
 public:
  // `supersample`^2 samples per pixel (box filter over the pixel's area).
  explicit PlaneRenderer(const Camera& camera, int supersample = 3);
  // 1-channel image; pixels whose ray misses the plane get `background`.
  Image Render(const Eigen::Matrix4d& plane_to_camera, const PlaneTexture& texture, float background = 0.5f) const;

 private:
  Eigen::Vector2d Ray(double u, double v) const;  // undistorted normalised coordinates
  Camera camera_;
  int ss_;
  int gw_, gh_;
  std::vector<Eigen::Vector2d> grid_;  // Undistort at integer pixel positions -1..W, -1..H
};

// A checkerboard with cols x rows inner corners, the first at (0, 0), square
// side `square`, surrounded by two squares of white margin.
PlaneTexture CheckerboardTexture(int cols, int rows, double square);

struct PlacedTag {
  std::string family = "tag36h11";
  int id = 0;
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();  // plane coordinates
  double size = 0.1;                                 // black border edge
  double rotation_rad = 0.0;                         // the tag's x axis, from the plane's x towards its y
};
// White paper with tags on it (tag axes = plane axes).
PlaneTexture TagsTexture(const std::vector<PlacedTag>& tags);

// Adds Gaussian noise (sigma in [0, 1] units) and rounds to 8-bit levels.
void AddNoiseAndQuantise(Image* image, double sigma, uint32_t seed);

// Gray to RGB (for stages that read colour photos).
Image ToRgb(const Image& gray);

// Rotation about an axis by degrees, as a 4x4 with translation t.
Eigen::Matrix4d Pose(const Eigen::Vector3d& axis, double degrees, const Eigen::Vector3d& t);

// Angle of R_a^T R_b in degrees.
double RotationErrorDeg(const Eigen::Matrix4d& a, const Eigen::Matrix4d& b);

}  // namespace shadowsg::testing
