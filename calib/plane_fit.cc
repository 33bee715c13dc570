#include "calib/plane_fit.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

namespace shadowsg {

namespace {

// Three points closer to collinear than this (|cross| relative to the
// squared edge lengths, i.e. the sine of the smallest angle) give no plane.
constexpr double kMinTripleSine = 1e-6;

int CountInliers(const std::vector<Eigen::Vector3d>& pts, const Eigen::Vector3d& p0, const Eigen::Vector3d& n,
                 double thr) {
  int count = 0;
  for (const auto& p : pts) count += std::abs(n.dot(p - p0)) <= thr;
  return count;
}

}  // namespace

bool PlaneRansacOptions::IsValid(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (!(inlier_threshold > 0) || !std::isfinite(inlier_threshold)) return fail("plane inlier threshold must be > 0");
  if (max_iterations < 1) return fail("RANSAC iterations must be >= 1");
  if (!(confidence > 0 && confidence < 1)) return fail("RANSAC confidence must lie in (0, 1)");
  if (refine_iterations < 0) return fail("refinement iterations must be >= 0");
  return true;
}

std::optional<std::pair<Eigen::Vector3d, Eigen::Vector3d>> LeastSquaresPlane(
    const std::vector<Eigen::Vector3d>& points) {
  if (points.size() < 3) return std::nullopt;
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (const auto& p : points) c += p;
  c /= static_cast<double>(points.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& p : points) cov += (p - c) * (p - c).transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  const Eigen::Vector3d ev = eig.eigenvalues();  // ascending
  if (!(ev(1) > 1e-12 * ev(2))) return std::nullopt;  // collinear (or one point repeated)
  return std::make_pair(c, eig.eigenvectors().col(0).normalized());
}

std::optional<PlaneFitResult> FitPlaneRansac(const std::vector<Eigen::Vector3d>& pts,
                                             const PlaneRansacOptions& o) {
  const int n = static_cast<int>(pts.size());
  if (n < 3) return std::nullopt;
  std::mt19937_64 rng(o.seed);
  std::uniform_int_distribution<int> pick(0, n - 1);
  const double thr = o.inlier_threshold;

  int best_count = -1;
  Eigen::Vector3d best_p = Eigen::Vector3d::Zero(), best_n = Eigen::Vector3d::UnitZ();
  int it = 0;
  int needed = o.max_iterations;
  for (; it < std::min(needed, o.max_iterations); ++it) {
    const int a = pick(rng), b = pick(rng), c = pick(rng);
    if (a == b || b == c || a == c) continue;
    const Eigen::Vector3d e1 = pts[b] - pts[a], e2 = pts[c] - pts[a];
    const Eigen::Vector3d cr = e1.cross(e2);
    const double scale = e1.norm() * e2.norm();
    if (!(cr.norm() > kMinTripleSine * scale)) continue;
    const Eigen::Vector3d normal = cr.normalized();
    const int count = CountInliers(pts, pts[a], normal, thr);
    if (count > best_count) {
      best_count = count;
      best_p = pts[a];
      best_n = normal;
      // Hypotheses needed so that an all-inlier triple has been drawn with
      // the requested confidence, given the best inlier ratio so far.
      const double w = static_cast<double>(count) / n;
      const double w3 = w * w * w;
      if (w3 >= 1.0 - 1e-12) {
        needed = it + 1;
      } else if (w3 > 0) {
        const double k = std::log(1.0 - o.confidence) / std::log(1.0 - w3);
        needed = static_cast<int>(std::min<double>(std::ceil(k), o.max_iterations));
      }
    }
  }
  if (best_count < 3) return std::nullopt;

  PlaneFitResult r;
  r.iterations = it;
  r.point = best_p;
  r.normal = best_n;
  for (int round = 0; round <= o.refine_iterations; ++round) {
    std::vector<Eigen::Vector3d> in;
    in.reserve(static_cast<size_t>(best_count));
    for (const auto& p : pts)
      if (std::abs(r.Distance(p)) <= thr) in.push_back(p);
    const auto ls = LeastSquaresPlane(in);
    if (!ls) break;
    const bool same_side = ls->second.dot(r.normal) >= 0;
    r.point = ls->first;
    r.normal = same_side ? ls->second : Eigen::Vector3d(-ls->second);
  }
  r.inliers.assign(pts.size(), false);
  double sum2 = 0;
  r.num_inliers = 0;
  for (int i = 0; i < n; ++i) {
    const double d = r.Distance(pts[i]);
    if (std::abs(d) <= thr) {
      r.inliers[i] = true;
      ++r.num_inliers;
      sum2 += d * d;
    }
  }
  r.rms = r.num_inliers > 0 ? std::sqrt(sum2 / r.num_inliers) : 0.0;
  return r;
}

double PlaneInlierThreshold(const std::vector<Eigen::Vector3d>& points,
                            const std::vector<Eigen::Vector3d>& centres, double fraction) {
  if (points.empty() || centres.empty()) return 0.0;
  // A strided subset keeps this cheap on large clouds; the median is robust.
  constexpr size_t kMaxSamples = 20000;
  const size_t stride = std::max<size_t>(1, points.size() / kMaxSamples);
  std::vector<double> dist;
  dist.reserve(points.size() / stride + 1);
  for (size_t i = 0; i < points.size(); i += stride) {
    double best = std::numeric_limits<double>::infinity();
    for (const auto& c : centres) best = std::min(best, (points[i] - c).squaredNorm());
    dist.push_back(std::sqrt(best));
  }
  std::nth_element(dist.begin(), dist.begin() + dist.size() / 2, dist.end());
  return fraction * dist[dist.size() / 2];
}

int OrientPlaneNormal(const std::vector<Eigen::Vector3d>& centres, PlaneFitResult* plane) {
  int above = 0, below = 0;
  for (const auto& c : centres) (plane->Distance(c) >= 0 ? above : below)++;
  if (below > above) {
    plane->normal = -plane->normal;
    std::swap(above, below);
  }
  return below;
}

}  // namespace shadowsg
