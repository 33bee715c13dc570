#include "solver/sg_lobe_scan.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "calib/error.h"
#include "solver/nnls.h"

namespace shadowsg {
namespace {

constexpr double kDeg = M_PI / 180;
// Candidates stay above this elevation (a lobe a little below the horizon
// still lights the plane through its width) and below the pole, where
// azimuth loses its meaning.
constexpr double kMinElevation = -5 * kDeg;
constexpr double kMaxElevation = 89 * kDeg;

}  // namespace

LobeScanResult ScanBrightestSharpLobe(const ShadowPlaneModel& model, const std::vector<double>& weight,
                                      const std::vector<Eigen::Vector3f>& targets, SgLighting* lighting,
                                      const LobeScanOptions& o) {
  SHADOWSG_CHECK(weight.size() == model.points.size() && targets.size() == model.points.size());
  SHADOWSG_CHECK(o.elevation_step_deg > 0 && o.azimuth_step_deg > 0);
  LobeScanResult result;
  const long L = static_cast<long>(lighting->lobes.size());
  double brightest = 0;
  for (long i = 0; i < L; ++i) {
    const SgLobe& l = lighting->lobes[i];
    if (l.sharpness < o.min_sharpness) continue;
    const double lit = EvalProductLobe(l.axis, l.sharpness, model.normal, model.cosine, false).scale * l.amplitude.sum();
    if (lit > brightest) brightest = lit, result.lobe = static_cast<int>(i);
  }
  if (result.lobe < 0) return result;
  const SgLobe scanned = lighting->lobes[result.lobe];
  const Eigen::Vector3d n = model.normal;
  Eigen::Vector3d toward = scanned.axis - scanned.axis.dot(n) * n;  // the lobe's azimuth on the plane
  if (toward.norm() < 1e-6) return result;                          // at the pole: no azimuth to scan
  toward.normalize();
  const Eigen::Vector3d side = n.cross(toward);
  const double elevation = std::asin(std::clamp(scanned.axis.dot(n), -1.0, 1.0));

  std::vector<SgLobe> others;
  for (long i = 0; i < L; ++i)
    if (i != result.lobe) others.push_back(lighting->lobes[i]);
  struct Candidate {
    double elevation_shift, azimuth_shift, factor;
  };
  std::vector<Candidate> grid;
  std::vector<SgLobe> candidates;
  std::vector<double> factors = o.sharpness_factors;
  if (std::find(factors.begin(), factors.end(), 1.0) == factors.end()) factors.push_back(1.0);
  const int ne = static_cast<int>(std::floor(o.elevation_range_deg / o.elevation_step_deg + 1e-9));
  const int na = static_cast<int>(std::floor(o.azimuth_range_deg / o.azimuth_step_deg + 1e-9));
  long own = -1;
  for (int a = -na; a <= na; ++a)
    for (int e = -ne; e <= ne; ++e) {
      const double de = e * o.elevation_step_deg * kDeg, da = a * o.azimuth_step_deg * kDeg;
      // The lobe's own place is always a candidate, even past the limits
      // (a lobe 0.5 degrees from the pole: best, pub_torus_sunsky seed 0).
      const bool own_place = a == 0 && e == 0;
      if (!own_place && (elevation + de < kMinElevation || elevation + de > kMaxElevation)) continue;
      const Eigen::Vector3d h = std::cos(da) * toward + std::sin(da) * side;
      const Eigen::Vector3d axis = (std::cos(elevation + de) * h + std::sin(elevation + de) * n).normalized();
      for (double f : factors) {
        if (own_place && f == 1.0) own = static_cast<long>(candidates.size());
        grid.push_back({de, da, f});
        candidates.push_back({own_place ? scanned.axis : axis, scanned.sharpness * f, scanned.amplitude});
      }
    }
  SHADOWSG_CHECK(own >= 0);

  // Per channel, the normal equations of [others | candidate j] share the
  // others' block; only the candidate's row changes.
  auto shading = [&](const std::vector<SgLobe>& lobes) {
    std::vector<Eigen::Vector3d> axes;
    std::vector<double> sharpness;
    SplitLobes(lobes, &axes, &sharpness);
    return LobeColumns(model, axes, sharpness);
  };
  const LobeShadingColumns ao = shading(others), ac = shading(candidates);
  const long m = static_cast<long>(others.size()), nc = static_cast<long>(candidates.size());
  Eigen::VectorXd error = Eigen::VectorXd::Zero(nc);
  double signal = 0;  // b^T b over the channels
  std::array<Eigen::MatrixXd, 3> amplitude;  // (m + 1) x candidates
  for (int c = 0; c < 3; ++c) {
    Eigen::VectorXd b(static_cast<long>(targets.size()));
    for (long k = 0; k < b.size(); ++k) b[k] = std::sqrt(weight[k]) * targets[k][c];
    // In double: the error is b^T b less nearly as much, and float sums
    // would leave rounding of the order of a good fit's error.
    const Eigen::MatrixXd o_col = ao.Weighted(model, weight, c), c_col = ac.Weighted(model, weight, c);
    const Eigen::MatrixXd goo = o_col.transpose() * o_col;
    const Eigen::MatrixXd goc = o_col.transpose() * c_col;
    const Eigen::VectorXd gcc = c_col.colwise().squaredNorm().transpose();
    const Eigen::VectorXd fo = o_col.transpose() * b;
    const Eigen::VectorXd fc = c_col.transpose() * b;
    const double btb = b.squaredNorm();
    signal += btb;
    amplitude[c].resize(m + 1, nc);
    Eigen::MatrixXd h(m + 1, m + 1);
    Eigen::VectorXd f(m + 1);
    h.topLeftCorner(m, m) = goo;
    f.head(m) = fo;
    for (long j = 0; j < nc; ++j) {
      h.col(m).head(m) = goc.col(j);
      h.row(m).head(m) = goc.col(j).transpose();
      h(m, m) = gcc[j];
      f[m] = fc[j];
      const Eigen::VectorXd x = SolveNnls(h, f);
      error[j] += btb - 2 * x.dot(f) + x.dot(h * x);
      amplitude[c].col(j) = x;
    }
  }
  long best = own;
  for (long j = 0; j < nc; ++j)
    if (error[j] < error[best]) best = j;
  result.error_before = error[own];
  result.error_after = error[best];
  result.elevation_shift_deg = grid[best].elevation_shift / kDeg;
  result.azimuth_shift_deg = grid[best].azimuth_shift / kDeg;
  result.sharpness_factor = grid[best].factor;
  // Below kNoiseFloor of the signal, error differences are rounding (the
  // shading columns are float), and a perfect fit would "move" on them.
  constexpr double kNoiseFloor = 1e-6;
  result.moved = best != own && result.error_after < (1 - o.min_gain) * result.error_before - kNoiseFloor * signal;
  if (!result.moved) return result;
  std::vector<SgLobe> lobes = others;
  lobes.push_back(candidates[best]);
  for (long i = 0; i <= m; ++i)
    for (int c = 0; c < 3; ++c) lobes[i].amplitude[c] = amplitude[c](i, best);
  lighting->lobes = std::move(lobes);
  return result;
}

}  // namespace shadowsg
