// Conventions are code: every place that maps pixels, texels or frames between
// this project and the outside world goes through here, and each is tested in
// tests/conventions_test.cc.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace shadowsg {

// ---- Image pixels ----------------------------------------------------------
// Our pixel (u, v) has its centre at (u, v) (OpenCV). COLMAP puts the centre of
// the first pixel at (0.5, 0.5): cx_opencv = cx_colmap - 0.5.
inline constexpr double kColmapPixelShift = 0.5;
inline Eigen::Vector2d ColmapToOpenCvPixel(const Eigen::Vector2d& p) {
  return p - Eigen::Vector2d::Constant(kColmapPixelShift);
}
inline Eigen::Vector2d OpenCvToColmapPixel(const Eigen::Vector2d& p) {
  return p + Eigen::Vector2d::Constant(kColmapPixelShift);
}
// libapriltag 3 reports tag corners and centres with the first pixel's centre
// at (0.5, 0.5) too: corners of tags rendered through our camera model come
// back offset by (+0.50, +0.50) px (tests/pose_test.cc).
inline constexpr double kAprilTagPixelShift = 0.5;
inline Eigen::Vector2d AprilTagToOpenCvPixel(const Eigen::Vector2d& p) {
  return p - Eigen::Vector2d::Constant(kAprilTagPixelShift);
}

// ---- COLMAP image poses -------------------------------------------------------
// COLMAP stores an image's pose world-to-camera, x_cam = R(q) x_world + t, with
// q = (qw, qx, qy, qz) a Hamilton unit quaternion, w first (doc/format.rst @3.8;
// Eigen::Quaterniond(w, x, y, z) is Hamilton too). Its camera axes are OpenCV's,
// so c2w = [R^T | -R^T t] needs no axis flip.
struct ColmapPose {
  Eigen::Vector4d qvec = Eigen::Vector4d(1, 0, 0, 0);  // qw, qx, qy, qz
  Eigen::Vector3d tvec = Eigen::Vector3d::Zero();
};
// q need not be exactly unit length (text models round it); it is normalised.
Eigen::Matrix4d ColmapPoseToC2w(const ColmapPose& pose);
// The inverse, with qw >= 0; c2w's 3x3 must be a rotation.
ColmapPose C2wToColmapPose(const Eigen::Matrix4d& c2w);

// ---- Environment maps (scene-format.md) -------------------------------------
// Equirectangular, width = 2 * height, pole = world +z. Texel (u, v) looks along
// (cos phi sin theta, sin phi sin theta, cos theta) with
// phi = 2 pi (u + 0.5) / W - pi and theta = pi (v + 0.5) / H.
Eigen::Vector3d EnvTexelDirection(double u, double v, int width, int height);
// Continuous texel coordinates (u, v) of a direction (inverse of the above,
// so that texel centres come back as integers).
Eigen::Vector2d EnvDirectionToTexel(const Eigen::Vector3d& dir, int width, int height);
// Exact solid angle of texel row v (all texels of a row share it).
double EnvTexelSolidAngle(int v, int width, int height);

// ---- Plane frame ------------------------------------------------------------
// The minimal rotation R with R * normal = +z (scene-format.md, plane rectangle).
Eigen::Matrix3d MinimalRotationToZ(const Eigen::Vector3d& normal);

// ---- Other tools' lat-long conventions ---------------------------------------
// OpenEXR/USD lat-long: +Y up, longitude 0 -> +Z, longitude pi/2 -> +X, first
// pixel at latitude +pi/2, longitude +pi. Blender's world equirect is z-up with
// u = -atan2(dir.y, dir.x) / (2 pi) + 0.5 (the image centre looks along +x).
// These map a direction in OUR world frame to that tool's frame and back.
Eigen::Vector3d WorldToUsdDirection(const Eigen::Vector3d& d);
Eigen::Vector3d UsdToWorldDirection(const Eigen::Vector3d& d);
// Texel of a direction (in the tool's own frame) for an OpenEXR/USD lat-long map.
Eigen::Vector3d UsdTexelDirection(double u, double v, int width, int height);
// Blender equirect texel -> direction in Blender world (= our world, both z-up).
Eigen::Vector3d BlenderTexelDirection(double u, double v, int width, int height);

}  // namespace shadowsg
