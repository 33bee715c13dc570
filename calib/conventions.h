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
// OpenEXR/USD lat-long (ImfEnvmap.h; UsdLuxDomeLight): +Y up, longitude 0 ->
// +Z, longitude pi/2 -> +X, the first pixel at latitude +pi/2 and longitude
// +pi. Our world is z-up; it maps to that y-up frame by the rotation of -90
// degrees about x, (x, y, z) -> (x, z, -y), the usual z-up to y-up conversion
// (Blender's USD and glTF exporters use it), so a scene exported with the same
// conversion keeps its lighting. Texel centres sit at (u + 0.5) / W as in every
// texture lookup; ImfEnvmap's LatLongMap::direction puts pixel centres at the
// ends of [+pi, -pi] instead (half a texel apart, 180 / W degrees).
// Blender's world equirect (Cycles direction_to_equirectangular): z-up like
// ours, u = 0.5 - atan2(y, x) / (2 pi) (the image centre looks along +x,
// longitude increasing to the LEFT), v = 1 - acos(z) / pi counted from the
// bottom row. Same frame as ours, mirrored in azimuth.
// These map a direction in OUR world frame to that tool's frame and back.
Eigen::Vector3d WorldToUsdDirection(const Eigen::Vector3d& d);
Eigen::Vector3d UsdToWorldDirection(const Eigen::Vector3d& d);
// Texel of a direction (in the tool's own frame) for an OpenEXR/USD lat-long map.
Eigen::Vector3d UsdTexelDirection(double u, double v, int width, int height);
// Blender equirect texel -> direction in Blender world (= our world, both z-up).
Eigen::Vector3d BlenderTexelDirection(double u, double v, int width, int height);

// The three lat-long layouts a map of ours may be written in.
enum class LatLongConvention {
  kShadowSg,  // scene-format.md (EnvTexelDirection)
  kOpenExr,   // OpenEXR / USD DomeLight, in the y-up frame above
  kBlender,   // Blender's Environment Texture node (world z-up)
};
// Direction in OUR world frame of texel (u, v) (row v from the top of the
// file) of a W x H map laid out in `convention`.
Eigen::Vector3d LatLongTexelDirection(LatLongConvention convention, double u, double v, int width, int height);
// Inverse: continuous texel coordinates (texel centres at integers, u in
// [-0.5, W - 0.5)) of a direction given in OUR world frame.
Eigen::Vector2d LatLongDirectionToTexel(LatLongConvention convention, const Eigen::Vector3d& world_dir, int width,
                                        int height);

}  // namespace shadowsg
