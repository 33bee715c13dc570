#include "calib/conventions.h"

#include <algorithm>
#include <cmath>

namespace shadowsg {

Eigen::Vector3d EnvTexelDirection(double u, double v, int width, int height) {
  const double phi = 2 * M_PI * (u + 0.5) / width - M_PI;
  const double theta = M_PI * (v + 0.5) / height;
  return {std::cos(phi) * std::sin(theta), std::sin(phi) * std::sin(theta), std::cos(theta)};
}

Eigen::Vector2d EnvDirectionToTexel(const Eigen::Vector3d& dir, int width, int height) {
  const Eigen::Vector3d d = dir.normalized();
  const double theta = std::acos(std::clamp(d.z(), -1.0, 1.0));
  const double phi = std::atan2(d.y(), d.x());
  return {(phi + M_PI) * width / (2 * M_PI) - 0.5, theta * height / M_PI - 0.5};
}

double EnvTexelSolidAngle(int v, int width, int height) {
  const double t0 = M_PI * v / height, t1 = M_PI * (v + 1) / height;
  return (2 * M_PI / width) * (std::cos(t0) - std::cos(t1));
}

Eigen::Matrix4d ColmapPoseToC2w(const ColmapPose& pose) {
  const Eigen::Quaterniond q(pose.qvec[0], pose.qvec[1], pose.qvec[2], pose.qvec[3]);
  const Eigen::Matrix3d R_wc = q.normalized().toRotationMatrix();  // world -> camera
  Eigen::Matrix4d c2w = Eigen::Matrix4d::Identity();
  c2w.block<3, 3>(0, 0) = R_wc.transpose();
  c2w.block<3, 1>(0, 3) = -R_wc.transpose() * pose.tvec;
  return c2w;
}

ColmapPose C2wToColmapPose(const Eigen::Matrix4d& c2w) {
  const Eigen::Matrix3d R_wc = c2w.block<3, 3>(0, 0).transpose();
  Eigen::Quaterniond q(R_wc);
  if (q.w() < 0) q.coeffs() = -q.coeffs();
  ColmapPose pose;
  pose.qvec = Eigen::Vector4d(q.w(), q.x(), q.y(), q.z());
  pose.tvec = -R_wc * c2w.block<3, 1>(0, 3);
  return pose;
}

Eigen::Matrix3d MinimalRotationToZ(const Eigen::Vector3d& normal) {
  return Eigen::Quaterniond::FromTwoVectors(normal.normalized(), Eigen::Vector3d::UnitZ())
      .toRotationMatrix();
}

// Our world is z-up; USD/OpenEXR lat-long is y-up: rotate by -90 degrees
// about x, so world +z becomes usd +y (up) and world -y becomes usd +z
// (longitude 0); world +x stays +x (longitude pi/2).
Eigen::Vector3d WorldToUsdDirection(const Eigen::Vector3d& d) { return {d.x(), d.z(), -d.y()}; }
Eigen::Vector3d UsdToWorldDirection(const Eigen::Vector3d& d) { return {d.x(), -d.z(), d.y()}; }

Eigen::Vector3d UsdTexelDirection(double u, double v, int width, int height) {
  // Latitude +pi/2 at the top row, longitude +pi at the left column, decreasing
  // to the right; longitude 0 looks along +Z and pi/2 along +X.
  const double lon = M_PI - 2 * M_PI * (u + 0.5) / width;
  const double lat = M_PI / 2 - M_PI * (v + 0.5) / height;
  return {std::sin(lon) * std::cos(lat), std::sin(lat), std::cos(lon) * std::cos(lat)};
}

Eigen::Vector3d BlenderTexelDirection(double u, double v, int width, int height) {
  // Blender (Cycles, direction_to_equirectangular): u = -atan2(y, x) / (2 pi) + 0.5,
  // v = atan2(z, hypot(x, y)) / pi + 0.5 with v measured from the BOTTOM row.
  const double fu = (u + 0.5) / width, fv = 1.0 - (v + 0.5) / height;
  const double phi = -(fu - 0.5) * 2 * M_PI;
  const double lat = (fv - 0.5) * M_PI;
  return {std::cos(phi) * std::cos(lat), std::sin(phi) * std::cos(lat), std::sin(lat)};
}

namespace {

// A texel column wrapped into [-0.5, W - 0.5).
double WrapColumn(double u, int width) {
  const double w = static_cast<double>(width);
  double r = std::fmod(u + 0.5, w);
  if (r < 0) r += w;
  return r - 0.5;
}

}  // namespace

Eigen::Vector3d LatLongTexelDirection(LatLongConvention convention, double u, double v, int width, int height) {
  switch (convention) {
    case LatLongConvention::kShadowSg:
      return EnvTexelDirection(u, v, width, height);
    case LatLongConvention::kOpenExr:
      return UsdToWorldDirection(UsdTexelDirection(u, v, width, height));
    case LatLongConvention::kBlender:
      return BlenderTexelDirection(u, v, width, height);
  }
  return Eigen::Vector3d::Zero();
}

Eigen::Vector2d LatLongDirectionToTexel(LatLongConvention convention, const Eigen::Vector3d& world_dir, int width,
                                        int height) {
  const Eigen::Vector3d d = world_dir.normalized();
  switch (convention) {
    case LatLongConvention::kShadowSg:
      return EnvDirectionToTexel(d, width, height);
    case LatLongConvention::kOpenExr: {
      // Inverse of UsdTexelDirection: lon = pi - 2 pi (u + 0.5) / W,
      // lat = pi / 2 - pi (v + 0.5) / H, lon = atan2(x, z) in the usd frame.
      const Eigen::Vector3d q = WorldToUsdDirection(d);
      const double lon = std::atan2(q.x(), q.z());
      const double lat = std::atan2(q.y(), std::hypot(q.x(), q.z()));
      return {WrapColumn((M_PI - lon) * width / (2 * M_PI) - 0.5, width), (M_PI / 2 - lat) * height / M_PI - 0.5};
    }
    case LatLongConvention::kBlender: {
      // Inverse of BlenderTexelDirection: phi = pi - 2 pi (u + 0.5) / W.
      const double phi = std::atan2(d.y(), d.x());
      const double theta = std::atan2(std::hypot(d.x(), d.y()), d.z());
      return {WrapColumn((M_PI - phi) * width / (2 * M_PI) - 0.5, width), theta * height / M_PI - 0.5};
    }
  }
  return Eigen::Vector2d::Zero();
}

}  // namespace shadowsg
