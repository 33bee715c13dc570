#include "calib/camera.h"

#include <cmath>

namespace shadowsg {

Eigen::Vector2d Distort(const Camera& c, const Eigen::Vector2d& p) {
  const double x = p.x(), y = p.y();
  const double r2 = x * x + y * y;
  const double radial = 1 + r2 * (c.k1 + r2 * (c.k2 + r2 * c.k3));
  return {x * radial + 2 * c.p1 * x * y + c.p2 * (r2 + 2 * x * x),
          y * radial + c.p1 * (r2 + 2 * y * y) + 2 * c.p2 * x * y};
}

Eigen::Vector2d Undistort(const Camera& c, const Eigen::Vector2d& d) {
  if (!c.HasDistortion()) return d;
  // Newton on f(p) = Distort(p) - d with a numerical Jacobian: converges in a
  // handful of steps for any lens that OpenCV can calibrate.
  Eigen::Vector2d p = d;
  for (int it = 0; it < 20; ++it) {
    const Eigen::Vector2d f = Distort(c, p) - d;
    if (f.squaredNorm() < 1e-24) break;
    constexpr double h = 1e-7;
    Eigen::Matrix2d J;
    J.col(0) = (Distort(c, p + Eigen::Vector2d(h, 0)) - Distort(c, p - Eigen::Vector2d(h, 0))) / (2 * h);
    J.col(1) = (Distort(c, p + Eigen::Vector2d(0, h)) - Distort(c, p - Eigen::Vector2d(0, h))) / (2 * h);
    p -= J.partialPivLu().solve(f);
  }
  return p;
}

Eigen::Matrix3d IntrinsicMatrix(const Camera& c) {
  Eigen::Matrix3d K;
  K << c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1;
  return K;
}

namespace {

// The reference code's orthographic camera: NDC coordinates flipped in both
// axes, unprojected through the inverse of its projection matrix at z_ndc = 0.
Eigen::Vector3d OrthoCameraPoint(const Camera& c, double u, double v) {
  const double u_ndc = (c.width - 1 - u) / c.width * 2 - 1;
  const double v_ndc = (c.height - 1 - v) / c.height * 2 - 1;
  const double wx = c.max_x - c.min_x, wy = c.max_y - c.min_y, wz = c.zfar - c.znear;
  return {(u_ndc - (c.max_x + c.min_x) / wx) * wx / (-2 * c.scale),
          (v_ndc - (c.max_y + c.min_y) / wy) * wy / (-2 * c.scale),
          (0 - (c.zfar + c.znear) / wz) * wz / (-2 * c.scale)};
}

}  // namespace

Ray PixelRay(const Camera& c, double u, double v) {
  const Eigen::Matrix3d R = c.Rotation();
  if (c.projection == Projection::kOrthographic) {
    const Eigen::Vector3d p = OrthoCameraPoint(c, u, v);
    return {R * p + c.Centre(), R.col(2).normalized()};
  }
  const Eigen::Vector2d distorted((u - c.cx) / c.fx, (v - c.cy) / c.fy);
  const Eigen::Vector2d n = Undistort(c, distorted);
  return {c.Centre(), (R * Eigen::Vector3d(n.x(), n.y(), 1.0)).normalized()};
}

std::optional<Eigen::Vector2d> ProjectToPixel(const Camera& c, const Eigen::Vector3d& world) {
  const Eigen::Matrix3d R = c.Rotation();
  const Eigen::Vector3d p = R.transpose() * (world - c.Centre());
  if (c.projection == Projection::kOrthographic) {
    // Invert OrthoCameraPoint for x and y.
    const double wx = c.max_x - c.min_x, wy = c.max_y - c.min_y;
    const double u_ndc = p.x() * (-2 * c.scale) / wx + (c.max_x + c.min_x) / wx;
    const double v_ndc = p.y() * (-2 * c.scale) / wy + (c.max_y + c.min_y) / wy;
    return Eigen::Vector2d(c.width - 1 - (u_ndc + 1) / 2 * c.width,
                           c.height - 1 - (v_ndc + 1) / 2 * c.height);
  }
  if (p.z() <= 0) return std::nullopt;
  const Eigen::Vector2d d = Distort(c, Eigen::Vector2d(p.x() / p.z(), p.y() / p.z()));
  return Eigen::Vector2d(c.fx * d.x() + c.cx, c.fy * d.y() + c.cy);
}

}  // namespace shadowsg
