// The one camera model of the project: OpenCV pinhole with Brown-Conrady
// distortion (k1 k2 p1 p2 k3), or the reference code's orthographic camera.
// Camera axes are OpenCV's (x right, y down, z forward); c2w maps camera to
// world. Pixel centres sit at integer coordinates (see conventions.h).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <optional>

namespace shadowsg {

enum class Projection { kPerspective, kOrthographic };

struct Camera {
  Projection projection = Projection::kPerspective;
  int width = 0;
  int height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
  double k1 = 0, k2 = 0, p1 = 0, p2 = 0, k3 = 0;
  Eigen::Matrix4d c2w = Eigen::Matrix4d::Identity();
  // Orthographic parameters, as in the ShadowSG reference scene files.
  double znear = 0, zfar = 0, min_x = 0, max_x = 0, min_y = 0, max_y = 0, scale = 1;

  bool HasDistortion() const { return k1 != 0 || k2 != 0 || p1 != 0 || p2 != 0 || k3 != 0; }
  Eigen::Vector3d Centre() const { return c2w.block<3, 1>(0, 3); }
  Eigen::Matrix3d Rotation() const { return c2w.block<3, 3>(0, 0); }
};

struct Ray {
  Eigen::Vector3d origin;
  Eigen::Vector3d dir;  // unit length
};

// Brown-Conrady forward model on normalised coordinates (OpenCV's).
Eigen::Vector2d Distort(const Camera& camera, const Eigen::Vector2d& undistorted);
// Inverse of Distort by fixed-point iteration refined with Gauss-Newton.
Eigen::Vector2d Undistort(const Camera& camera, const Eigen::Vector2d& distorted);

// The world-space ray through image point (u, v) (pixel centre at integers).
Ray PixelRay(const Camera& camera, double u, double v);

// Image point of a world point; nullopt when it lies behind the camera.
std::optional<Eigen::Vector2d> ProjectToPixel(const Camera& camera, const Eigen::Vector3d& world);

Eigen::Matrix3d IntrinsicMatrix(const Camera& camera);

}  // namespace shadowsg
