#include "solver/baselines.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <numeric>

#include "calib/error.h"
#include "solver/light_transport.h"
#include "solver/nnls.h"

namespace shadowsg {

namespace {

// The dense fit matrix (rows x texels doubles) stays below this; with 1024
// texels it allows 65536 rows, more than the default max_fit_pixels.
constexpr double kFitMatrixBytes = 512.0 * 1024 * 1024;
// Albedo gain field: bilinear over (cells + 1)^2 nodes spanning the image,
// alternated with the map fit this many times (map fit first and last).
constexpr int kAlbedoGridCells = 4;
constexpr int kAlbedoIterations = 4;
// Ridge (relative to the mean diagonal) pulling gain nodes without data to 1.
constexpr double kAlbedoRidge = 1e-6;
// Channels share one fit matrix when their row weights are proportional to
// this relative accuracy (exactly so, up to round-off, for a uniform albedo).
constexpr double kSharedChannelTolerance = 1e-9;

uint64_t SplitMix64(uint64_t x) {
  x += 0x9e3779b97f4a7c15ull;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ull;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebull;
  return x ^ (x >> 31);
}

ProgressFn SubRange(const ProgressFn& progress, double from, double to) {
  if (!progress) return {};
  return [progress, from, to](double f, const std::string& status) {
    progress(from + (to - from) * f, status);
  };
}

// Which distinct rows to fit, and the inverse of their inclusion probability.
struct FitSample {
  std::vector<int> groups;
  std::vector<double> inverse_probability;
};

// Systematic sampling in group order (= image order of first pixels), with
// probability min(1, c * count) and sum of probabilities = budget.
FitSample SampleGroups(const std::vector<double>& counts, int budget, uint64_t seed) {
  FitSample sample;
  const int g = static_cast<int>(counts.size());
  if (g <= budget) {
    sample.groups.resize(g);
    std::iota(sample.groups.begin(), sample.groups.end(), 0);
    sample.inverse_probability.assign(g, 1.0);
    return sample;
  }
  // c such that sum_g min(1, c n_g) = budget: the k largest groups are certain.
  std::vector<double> sorted = counts;
  std::sort(sorted.begin(), sorted.end(), std::greater<>());
  std::vector<double> suffix(g + 1, 0.0);
  for (int i = g - 1; i >= 0; --i) suffix[i] = suffix[i + 1] + sorted[i];
  double c = 0;
  for (int k = 0; k < budget; ++k) {
    c = (budget - k) / suffix[k];
    if (c * sorted[k] <= 1) break;
  }
  const double u = static_cast<double>(SplitMix64(seed) >> 11) * 0x1.0p-53;
  double cum = 0;
  for (int i = 0; i < g; ++i) {
    const double p = std::min(1.0, c * counts[i]);
    const double lo = cum;
    cum += p;
    if (std::floor(cum - u) > std::floor(lo - u)) {
      sample.groups.push_back(i);
      sample.inverse_probability.push_back(1 / p);
    }
  }
  return sample;
}

// The fitted least-squares system, channel c: minimise over l
//   sum_r (sqrt(weight_r) k_c T_{row_r} . l - target_rc)^2
// with T the transport's geometric rows and k > 0 a per-channel factor.
struct FitSystem {
  std::vector<size_t> rows;
  Eigen::VectorXd weight;
  Eigen::MatrixX3d target;
};

// Solves for the texels x 3 radiance of the listed channels (others zero).
Eigen::MatrixX3d FitMap(const LightTransport& transport, const FitSystem& system, const Eigen::Vector3d& k,
                        const Eigen::Vector3d& prior_scale, const std::vector<int>& channels,
                        const BaselineOptions& options, BaselineResult* result) {
  const int n = transport.cols();
  const Eigen::Index m = static_cast<Eigen::Index>(system.rows.size());
  Eigen::MatrixX3d x = Eigen::MatrixX3d::Zero(n, 3);
  if (options.method == BaselineMethod::kSS03) {
    // The only method that needs the rows themselves: Householder QR
    // (blocked, fast) reduces the tall system to R (n x n) with the same
    // singular values; the rank-revealing complete orthogonal decomposition
    // of R then gives the minimum-norm least-squares solution.
    Eigen::MatrixXd s(m, n);
#pragma omp parallel
    {
      Eigen::VectorXd row(n);
#pragma omp for schedule(static)
      for (Eigen::Index r = 0; r < m; ++r) {
        transport.GeometricRow(system.rows[r], row.data());
        s.row(r) = std::sqrt(system.weight[r]) * row.transpose();
      }
    }
    if (m > n) {
      Eigen::HouseholderQR<Eigen::Ref<Eigen::MatrixXd>> qr(s);
      Eigen::MatrixX3d z = system.target;
      z.applyOnTheLeft(qr.householderQ().adjoint());
      const Eigen::MatrixXd r = s.topRows(n).triangularView<Eigen::Upper>();
      Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod(r);
      x = cod.solve(z.topRows(n));
      result->rank = std::max(result->rank, static_cast<int>(cod.rank()));
    } else {
      Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> cod(s);
      x = cod.solve(system.target);
      result->rank = std::max(result->rank, static_cast<int>(cod.rank()));
    }
    Eigen::MatrixX3d out = Eigen::MatrixX3d::Zero(n, 3);
    for (int c : channels) out.col(c) = x.col(c) / k[c];
    return out;
  }
  // The other two need only A^T A and A^T b (per channel k_c^2 H and k_c F).
  const Eigen::MatrixXd h = transport.Gram(system.rows, system.weight);
  const Eigen::MatrixX3d f =
      transport.CrossProduct(system.rows, system.weight.cwiseSqrt().asDiagonal() * system.target);
  switch (options.method) {
    case BaselineMethod::kSS03:
      break;
    case BaselineMethod::kSS03Plus: {
      for (int c : channels) {
        NnlsSummary summary;
        x.col(c) = SolveNnls(h, f.col(c), {}, &summary) / k[c];
        result->nnls_dependent += summary.dependent;
        result->converged = result->converged && summary.converged;
      }
      break;
    }
    case BaselineMethod::kSH21: {
      const Eigen::SparseMatrix<double> d = HemisphereLaplacian(options.map_rows);
      const Eigen::MatrixXd dtd = Eigen::MatrixXd(d.transpose() * d);
      for (int c : channels) {
        // The reference solves for (albedo/pi) x (its map absorbs the
        // Lambertian factor) with (H + wL D^T D + wI I): on our radiance map
        // the same weights act as w (albedo/pi)^2, which keeps its balance
        // of data and prior.
        Eigen::MatrixXd m = k[c] * k[c] * h + prior_scale[c] * options.laplacian_weight * dtd;
        m.diagonal().array() += prior_scale[c] * options.identity_weight;
        const Eigen::VectorXd rhs = k[c] * f.col(c);
        Eigen::LLT<Eigen::MatrixXd> llt(m);
        if (llt.info() == Eigen::Success) {
          x.col(c) = llt.solve(rhs);
        } else {  // only with identity_weight = 0 and a singular system
          x.col(c) = m.completeOrthogonalDecomposition().solve(rhs);
        }
      }
      break;
    }
  }
  return x;
}

// Least-squares update of the bilinear gain field given the current
// prediction (before gain) of every plane pixel; normalised to mean 1.
void UpdateAlbedoGain(const PlanePixels& pixels, const std::vector<Eigen::Vector3d>& prediction,
                      const std::vector<Eigen::Vector3d>& observed, std::vector<double>* gain) {
  constexpr int kNodes = kAlbedoGridCells + 1;
  constexpr int kUnknowns = kNodes * kNodes;
  Eigen::Matrix<double, kUnknowns, kUnknowns> m = Eigen::Matrix<double, kUnknowns, kUnknowns>::Zero();
  Eigen::Matrix<double, kUnknowns, 1> r = Eigen::Matrix<double, kUnknowns, 1>::Zero();
  const double sx = kAlbedoGridCells / std::max(1.0, pixels.width - 1.0);
  const double sy = kAlbedoGridCells / std::max(1.0, pixels.height - 1.0);
  auto nodes = [&](size_t i, int idx[4], double w[4]) {
    const double fx = (pixels.pixel[i] % pixels.width) * sx, fy = (pixels.pixel[i] / pixels.width) * sy;
    const int x0 = std::min(static_cast<int>(fx), kAlbedoGridCells - 1);
    const int y0 = std::min(static_cast<int>(fy), kAlbedoGridCells - 1);
    const double ax = fx - x0, ay = fy - y0;
    idx[0] = y0 * kNodes + x0, w[0] = (1 - ax) * (1 - ay);
    idx[1] = y0 * kNodes + x0 + 1, w[1] = ax * (1 - ay);
    idx[2] = (y0 + 1) * kNodes + x0, w[2] = (1 - ax) * ay;
    idx[3] = (y0 + 1) * kNodes + x0 + 1, w[3] = ax * ay;
  };
  for (size_t i = 0; i < prediction.size(); ++i) {
    int idx[4];
    double w[4];
    nodes(i, idx, w);
    const double pp = prediction[i].squaredNorm(), pb = prediction[i].dot(observed[i]);
    for (int a = 0; a < 4; ++a) {
      r[idx[a]] += w[a] * pb;
      for (int b = 0; b < 4; ++b) m(idx[a], idx[b]) += w[a] * w[b] * pp;
    }
  }
  const double ridge = kAlbedoRidge * std::max(m.trace() / kUnknowns, 1e-300);
  m.diagonal().array() += ridge;
  r.array() += ridge;
  const Eigen::Matrix<double, kUnknowns, 1> a = m.ldlt().solve(r);
  std::vector<double> g(prediction.size());
  double sum = 0;
  for (size_t i = 0; i < g.size(); ++i) {
    int idx[4];
    double w[4];
    nodes(i, idx, w);
    g[i] = std::max(0.0, w[0] * a[idx[0]] + w[1] * a[idx[1]] + w[2] * a[idx[2]] + w[3] * a[idx[3]]);
    sum += g[i];
  }
  if (!(sum > 0)) return;  // degenerate (all-black prediction): keep the previous field
  const double mean = sum / g.size();
  for (double& v : g) v /= mean;
  *gain = std::move(g);
}

}  // namespace

const char* BaselineMethodName(BaselineMethod method) {
  switch (method) {
    case BaselineMethod::kSS03: return "ss03";
    case BaselineMethod::kSS03Plus: return "ss03+";
    case BaselineMethod::kSH21: return "sh21";
  }
  return "?";
}

bool ParseBaselineMethod(const std::string& name, BaselineMethod* method) {
  for (BaselineMethod m : {BaselineMethod::kSS03, BaselineMethod::kSS03Plus, BaselineMethod::kSH21})
    if (name == BaselineMethodName(m)) {
      *method = m;
      return true;
    }
  return false;
}

bool BaselineOptions::IsValid(std::string* error) const {
  auto fail = [error](const std::string& message) {
    if (error) *error = message;
    return false;
  };
  if (map_rows < kMinMapRows || map_rows > kMaxMapRows)
    return fail("map_rows must be in [" + std::to_string(kMinMapRows) + ", " + std::to_string(kMaxMapRows) +
                "], got " + std::to_string(map_rows));
  if (!(std::isfinite(laplacian_weight) && laplacian_weight >= 0))
    return fail("laplacian_weight must be finite and >= 0");
  if (!(std::isfinite(identity_weight) && identity_weight >= 0))
    return fail("identity_weight must be finite and >= 0");
  if (method == BaselineMethod::kSH21 && laplacian_weight == 0 && identity_weight == 0)
    return fail("sh21 needs laplacian_weight or identity_weight > 0 (with both 0 it is ss03)");
  if (max_fit_pixels < 1) return fail("max_fit_pixels must be >= 1");
  return true;
}

Eigen::SparseMatrix<double> HemisphereLaplacian(int map_rows) {
  SHADOWSG_CHECK(map_rows > 0);
  const HemisphereMap map{map_rows};
  const int w = map.width(), n = map.texels();
  std::vector<Eigen::Triplet<double>> entries;
  for (int v = 0; v < map_rows; ++v)
    for (int u = 0; u < w; ++u) {
      const int i = v * w + u;
      int degree = 0;
      auto link = [&](int k) {
        entries.emplace_back(i, k, -1.0);
        ++degree;
      };
      link(v * w + (u + 1) % w);
      link(v * w + (u + w - 1) % w);
      if (v > 0) link((v - 1) * w + u);
      if (v + 1 < map_rows) link((v + 1) * w + u);
      entries.emplace_back(i, i, static_cast<double>(degree));
    }
  Eigen::SparseMatrix<double> d(n, n);
  d.setFromTriplets(entries.begin(), entries.end());
  return d;
}

BaselineResult SolveBaseline(const Scene& scene, const PlanePixels& pixels, const RayCaster& casters,
                             const BaselineOptions& options, const ProgressFn& progress) {
  const auto start = std::chrono::steady_clock::now();
  auto seconds_since = [](std::chrono::steady_clock::time_point t) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
  };
  std::string error;
  if (!options.IsValid(&error)) throw InputError("baseline options", error);
  if (pixels.size() == 0) throw InputError(scene.name, "no shadow-plane pixels to fit the map to");
  if (!(scene.plane.diffuse.array() > 0).all())
    throw InputError(scene.name, "the plane albedo (plane.diffuse) must be positive in every channel");
  if (scene.image.width != pixels.width || scene.image.height != pixels.height)
    throw InputError(scene.name, "the image size differs from the camera's");

  BaselineResult result;
  LightTransport transport(scene, pixels.point, casters, options.map_rows, SubRange(progress, 0, 0.7));
  result.transport_seconds = seconds_since(start);
  result.ray_fraction = transport.RayFraction();
  const int n = transport.cols();
  const size_t rows = transport.rows();
  result.n_params = 3 * n;

  std::vector<size_t> first_row;
  const std::vector<int> group = transport.GroupIdenticalRows(&first_row);
  const int groups = static_cast<int>(first_row.size());
  result.distinct_rows = first_row.size();
  std::vector<double> counts(groups, 0.0);
  for (int g : group) counts[g] += 1;
  // Only SS03 forms the dense rows (the others work on A^T A): cap its size.
  const double row_cap = options.method == BaselineMethod::kSS03 ? std::floor(kFitMatrixBytes / (sizeof(double) * n))
                                                                  : options.max_fit_pixels;
  const int budget = static_cast<int>(std::max(1.0, std::min<double>(options.max_fit_pixels, row_cap)));
  const FitSample sample = SampleGroups(counts, budget, options.seed);
  const int m = static_cast<int>(sample.groups.size());
  result.fit_rows = m;

  std::vector<Eigen::Vector3d> observed(rows);
  for (size_t i = 0; i < rows; ++i) {
    observed[i] = scene.image.rgb(pixels.pixel[i]).cast<double>();
    if (!observed[i].allFinite())
      throw InputError(scene.name, "the image has a non-finite value at plane pixel " +
                                       std::to_string(pixels.pixel[i] % pixels.width) + "," +
                                       std::to_string(pixels.pixel[i] / pixels.width));
  }
  std::vector<double> gain(rows, 1.0);

  // Per-group irradiance T_g . l (no albedo) of every distinct row.
  auto group_irradiance = [&](const Eigen::MatrixX3d& radiance) {
    std::vector<Eigen::Vector3d> e(groups);
#pragma omp parallel for schedule(static)
    for (int g = 0; g < groups; ++g) e[g] = transport.Irradiance(first_row[g], radiance);
    return e;
  };

  Eigen::MatrixX3d radiance(n, 3);
  const int iterations = options.estimate_albedo ? kAlbedoIterations : 1;
  for (int it = 0; it < iterations; ++it) {
    // Pixel x of group g contributes (kappa_xc T_g.l_c - b_xc)^2 with
    // kappa = gain * albedo/pi; summed over the group that is exactly
    // W_gc (T_g.l_c - P_gc / W_gc)^2 + const, W = sum kappa^2, P = sum kappa b.
    Eigen::MatrixX3d w = Eigen::MatrixX3d::Zero(groups, 3), p = Eigen::MatrixX3d::Zero(groups, 3);
    for (size_t i = 0; i < rows; ++i) {
      const Eigen::Vector3d kappa = gain[i] * transport.AlbedoOverPi(i);
      w.row(group[i]) += kappa.cwiseProduct(kappa).transpose();
      p.row(group[i]) += kappa.cwiseProduct(observed[i]).transpose();
    }
    // SH21's prior weights scale with the mean squared albedo/pi (see FitMap).
    Eigen::Vector3d prior_scale = Eigen::Vector3d::Zero();
    for (size_t i = 0; i < rows; ++i) {
      const Eigen::Vector3d kappa = gain[i] * transport.AlbedoOverPi(i);
      prior_scale += kappa.cwiseProduct(kappa);
    }
    prior_scale /= std::max<double>(1, static_cast<double>(rows));
    // With a uniform albedo W_gc = r_c W_g for all groups: the channels share
    // one matrix up to the factor sqrt(r_c), and one decomposition.
    const Eigen::VectorXd w_mean = w.rowwise().mean();
    const Eigen::Vector3d ratio = (w.colwise().sum() / std::max(w_mean.sum(), 1e-300)).transpose();
    if (!(ratio.array() > 0).all())
      throw InputError(scene.name, "the plane albedo is zero in a channel over every plane pixel");
    const bool shared = ((w - w_mean * ratio.transpose()).cwiseAbs().array() <=
                         kSharedChannelTolerance * w.cwiseAbs().maxCoeff())
                            .all();
    auto build = [&](const Eigen::VectorXd& row_weight) {
      FitSystem system;
      system.rows.resize(m);
      system.weight.resize(m);
      system.target.resize(m, 3);
      for (int r = 0; r < m; ++r) {
        const int g = sample.groups[r];
        const double inv_p = sample.inverse_probability[r];
        system.rows[r] = first_row[g];
        system.weight[r] = inv_p * row_weight[g];
        for (int c = 0; c < 3; ++c) system.target(r, c) = w(g, c) > 0 ? std::sqrt(inv_p / w(g, c)) * p(g, c) : 0.0;
      }
      return system;
    };
    Report(progress, 0.7 + 0.25 * (it + 0.5) / iterations, BaselineMethodName(options.method));
    if (shared) {
      radiance = FitMap(transport, build(w_mean), ratio.cwiseSqrt(), prior_scale, {0, 1, 2}, options, &result);
    } else {  // a textured plane: one system per channel
      for (int c = 0; c < 3; ++c)
        radiance.col(c) =
            FitMap(transport, build(w.col(c)), Eigen::Vector3d::Ones(), prior_scale, {c}, options, &result).col(c);
    }
    if (options.estimate_albedo && it + 1 < iterations) {
      const std::vector<Eigen::Vector3d> e = group_irradiance(radiance);
      std::vector<Eigen::Vector3d> prediction(rows);
      for (size_t i = 0; i < rows; ++i) prediction[i] = transport.AlbedoOverPi(i).cwiseProduct(e[group[i]]);
      UpdateAlbedoGain(pixels, prediction, observed, &gain);
    }
  }

  const std::vector<Eigen::Vector3d> e = group_irradiance(radiance);
  result.render.resize(rows);
  for (size_t i = 0; i < rows; ++i)
    result.render[i] = (gain[i] * transport.AlbedoOverPi(i).cwiseProduct(e[group[i]])).cast<float>();
  if (options.estimate_albedo) result.albedo_gain.assign(gain.begin(), gain.end());
  result.envmap = transport.map().ToEnvMap(radiance);
  // Last guard (issue #10): a map with a non-finite texel is no lighting.
  for (float& v : result.envmap.data)
    if (!std::isfinite(v)) v = 0, ++result.invalid_texels;
  for (auto& r : result.render)
    if (!r.allFinite()) r.setZero();
  result.solve_seconds = seconds_since(start);
  Report(progress, 1.0, BaselineMethodName(options.method));
  return result;
}

}  // namespace shadowsg
