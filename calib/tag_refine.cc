#include "calib/tag_refine.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <vector>

namespace shadowsg {

namespace {

// Edge samples run along this middle share of each edge (the corners
// themselves are blurred by both edges).
constexpr double kEdgeMargin = 0.12;
// The intensity profile across an edge spans this many cells to each side:
// inside the one-cell black border and the one-cell white frame.
constexpr double kProfileHalfCells = 0.6;
// Profile step, pixels.
constexpr double kProfileStepPx = 0.1;
// Edges shorter than this (pixels) are not refined.
constexpr double kMinEdgePx = 8.0;
// Black border vs white frame: at least this contrast (|hi - lo| / max).
constexpr double kMinContrast = 0.3;
// A fitted edge line with a larger RMS residual (pixels) is rejected, and so
// are corners that move further than kMaxCornerShiftPx from the detector's.
constexpr double kMaxLineRmsPx = 0.5;
constexpr double kMaxCornerShiftPx = 2.0;

Eigen::Vector2d Apply(const Eigen::Matrix3d& H, const Eigen::Vector2d& p) { return (H * p.homogeneous()).hnormalized(); }

}  // namespace

Eigen::Matrix3d HomographyFrom4(const std::array<Eigen::Vector2d, 4>& src, const std::array<Eigen::Vector2d, 4>& dst) {
  Eigen::Matrix<double, 8, 8> A;
  Eigen::Matrix<double, 8, 1> b;
  for (int k = 0; k < 4; ++k) {
    const double x = src[k].x(), y = src[k].y(), u = dst[k].x(), v = dst[k].y();
    A.row(2 * k) << x, y, 1, 0, 0, 0, -u * x, -u * y;
    A.row(2 * k + 1) << 0, 0, 0, x, y, 1, -v * x, -v * y;
    b(2 * k) = u;
    b(2 * k + 1) = v;
  }
  const Eigen::Matrix<double, 8, 1> h = A.fullPivLu().solve(b);
  Eigen::Matrix3d H;
  H << h(0), h(1), h(2), h(3), h(4), h(5), h(6), h(7), 1.0;
  return H;
}

namespace {

// The black square's corners in pattern coordinates, TagDetection's order
// (bottom-left, bottom-right, top-right, top-left of the upright tag).
std::array<Eigen::Vector2d, 4> PatternCorners(const TagPattern& p) {
  const double off = 0.5 * (p.total_width - p.border_width), B = p.border_width;
  return {Eigen::Vector2d(off, off + B), Eigen::Vector2d(off + B, off + B), Eigen::Vector2d(off + B, off),
          Eigen::Vector2d(off, off)};
}

}  // namespace

Eigen::Matrix3d TagPatternToImage(const TagDetection& d, const TagPattern& pattern) {
  return HomographyFrom4(PatternCorners(pattern), d.corners);
}

std::optional<double> SampleGrey(const Image& img, double u, double v) {
  if (!(u >= 0 && v >= 0 && u <= img.width - 1 && v <= img.height - 1) || img.width < 2 || img.height < 2)
    return std::nullopt;
  const int x0 = std::min(static_cast<int>(u), img.width - 2), y0 = std::min(static_cast<int>(v), img.height - 2);
  const double fx = u - x0, fy = v - y0;
  auto grey = [&](int x, int y) {
    double s = 0;
    for (int c = 0; c < img.channels; ++c) s += img.at(x, y, c);
    return s / img.channels;
  };
  return (1 - fy) * ((1 - fx) * grey(x0, y0) + fx * grey(x0 + 1, y0)) +
         fy * ((1 - fx) * grey(x0, y0 + 1) + fx * grey(x0 + 1, y0 + 1));
}

std::optional<std::array<Eigen::Vector2d, 4>> RefineTagCorners(const Image& linear, const TagDetection& d,
                                                                const TagPattern& pattern) {
  const std::array<Eigen::Vector2d, 4> src = PatternCorners(pattern);
  const Eigen::Matrix3d H = HomographyFrom4(src, d.corners);
  const Eigen::Vector2d centre = Eigen::Vector2d::Constant(0.5 * pattern.total_width);
  struct Line {
    Eigen::Vector2d point, dir;
  };
  std::array<Line, 4> lines;
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector2d a = src[k], b = src[(k + 1) % 4];
    const double edge_px = (d.corners[(k + 1) % 4] - d.corners[k]).norm();
    if (edge_px < kMinEdgePx) return std::nullopt;
    Eigen::Vector2d n(-(b - a).y(), (b - a).x());
    n.normalize();
    if (n.dot(0.5 * (a + b) - centre) < 0) n = -n;  // outwards
    const int samples = std::clamp(static_cast<int>(edge_px), 8, 64);
    std::vector<Eigen::Vector2d> points;
    for (int s = 0; s < samples; ++s) {
      const double t = kEdgeMargin + (1 - 2 * kEdgeMargin) * (s + 0.5) / samples;
      const Eigen::Vector2d p = a + t * (b - a);
      const Eigen::Vector2d in = Apply(H, p - kProfileHalfCells * n), out = Apply(H, p + kProfileHalfCells * n);
      const int steps = std::max(4, static_cast<int>(std::ceil((out - in).norm() / kProfileStepPx)));
      std::vector<double> profile(steps + 1);
      bool ok = true;
      for (int i = 0; i <= steps && ok; ++i) {
        const auto v = SampleGrey(linear, in.x() + (out.x() - in.x()) * i / steps, in.y() + (out.y() - in.y()) * i / steps);
        ok = v.has_value();
        if (ok) profile[i] = *v;
      }
      if (!ok) continue;
      const int ends = std::max(1, steps * 15 / 100);
      double lo = 0, hi = 0;
      for (int i = 0; i < ends; ++i) lo += profile[i] / ends, hi += profile[steps - i] / ends;
      if (std::abs(hi - lo) < kMinContrast * std::max(std::abs(hi), std::abs(lo))) continue;
      const double mid = 0.5 * (lo + hi);
      // The half-way crossing nearest the profile's middle (the detected edge).
      double best = -1, best_dist = 1e9;
      for (int i = 0; i < steps; ++i) {
        const double f0 = profile[i] - mid, f1 = profile[i + 1] - mid;
        if ((f0 <= 0) == (f1 <= 0)) continue;
        const double x = (i + f0 / (f0 - f1)) / steps;
        if (std::abs(x - 0.5) < best_dist) best = x, best_dist = std::abs(x - 0.5);
      }
      if (best >= 0) points.push_back(in + best * (out - in));
    }
    if (points.size() < 6) return std::nullopt;
    Eigen::Vector2d c = Eigen::Vector2d::Zero();
    for (const auto& p : points) c += p / static_cast<double>(points.size());
    Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
    for (const auto& p : points) cov += (p - c) * (p - c).transpose();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(cov);
    const Eigen::Vector2d dir = eig.eigenvectors().col(1);
    if (std::sqrt(std::max(0.0, eig.eigenvalues()(0)) / points.size()) > kMaxLineRmsPx) return std::nullopt;
    lines[k] = {c, dir};
  }
  std::array<Eigen::Vector2d, 4> corners;
  for (int k = 0; k < 4; ++k) {
    // Corner k joins edge k - 1 (from corner k - 1) and edge k (to corner k + 1).
    const Line& l0 = lines[(k + 3) % 4];
    const Line& l1 = lines[k];
    Eigen::Matrix2d M;
    M.col(0) = l0.dir;
    M.col(1) = -l1.dir;
    if (std::abs(M.determinant()) < 1e-6) return std::nullopt;
    const Eigen::Vector2d st = M.partialPivLu().solve(l1.point - l0.point);
    corners[k] = l0.point + st(0) * l0.dir;
    if ((corners[k] - d.corners[k]).norm() > kMaxCornerShiftPx) return std::nullopt;
  }
  return corners;
}

}  // namespace shadowsg
