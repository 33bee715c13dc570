#include "solver/medial_spheres.h"

#include <algorithm>
#include <cmath>

namespace shadowsg {
namespace {

// The ball through p and q tangent at p converges in a handful of steps on
// clean surface samples (Ma et al. report < 10); the cap only guards loops.
constexpr int kMaxShrinkSteps = 64;
// Relative slack of the emptiness test: p itself lies on the ball.
constexpr double kEmptySlack = 1e-9;
// Seeds run in batches of this many (in parallel); between batches, seeds that
// an earlier ball already touches are dropped. A fixed batch keeps the result
// independent of the thread count.
constexpr size_t kBatch = 256;
// A surface point "is touched" by a ball when it lies within the tolerance of
// its surface and its inward normal points at the centre to within this angle
// (cosine of 5.7 degrees): its own ball would be nearly the same one.
constexpr double kTouchCosine = 0.995;

}  // namespace

std::vector<MedialSphere> ShrinkingBallSpheres(const PointKdTree& surface,
                                               const std::vector<Eigen::Vector3d>& inward_normals,
                                               const std::vector<int>& seeds,
                                               const std::vector<double>& start_radius, double min_radius,
                                               double touch_tolerance) {
  const auto& pts = surface.points();
  std::vector<MedialSphere> out;
  std::vector<char> touched(pts.size(), 0);
  std::vector<int> shell;
  for (size_t b0 = 0; b0 < seeds.size(); b0 += kBatch) {
    const size_t b1 = std::min(seeds.size(), b0 + kBatch);
    std::vector<MedialSphere> found(b1 - b0);
#pragma omp parallel for schedule(dynamic, 8)
    for (long s = static_cast<long>(b0); s < static_cast<long>(b1); ++s) {
      const int i = seeds[s];
      const Eigen::Vector3d& p = pts[i];
      const Eigen::Vector3d& n = inward_normals[i];
      if (n.squaredNorm() == 0 || touched[i]) continue;
      double r = start_radius[s];
      for (int step = 0; step < kMaxShrinkSteps; ++step) {
        const Eigen::Vector3d c = p + r * n;
        double d2;
        const int q = surface.Nearest(c, &d2);
        if (q < 0 || std::sqrt(d2) >= r * (1 - kEmptySlack)) break;  // empty: done
        // The ball tangent at p through q: |p + r n - q| = r.
        const Eigen::Vector3d pq = pts[q] - p;
        const double along = pq.dot(n);
        if (along <= 0) break;  // q is not on the inward side (rounding); keep r
        const double next = pq.squaredNorm() / (2 * along);
        if (!(next < r)) break;
        r = next;
      }
      if (r > min_radius) found[s - b0] = {p + r * n, r, i};
    }
    for (const auto& m : found) {
      if (m.seed < 0) continue;
      out.push_back(m);
      if (touch_tolerance <= 0) continue;
      shell.clear();
      surface.WithinRadius(m.centre, m.radius + touch_tolerance, &shell);
      for (int q : shell) {
        const Eigen::Vector3d to = m.centre - pts[q];
        const double d = to.norm();
        if (d >= m.radius - touch_tolerance && inward_normals[q].dot(to) >= kTouchCosine * d) touched[q] = 1;
      }
    }
  }
  return out;
}

}  // namespace shadowsg
