#include "solver/light_transport.h"

#include <omp.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <exception>
#include <unordered_map>

#include "calib/conventions.h"
#include "calib/error.h"

namespace shadowsg {

namespace {

// Rays start this far above the plane, relative to the distance between the
// point and the casters' bounding sphere (float rays: keep well above 1e-7).
constexpr double kRayOffsetRelative = 1e-5;
// Bounding spheres are grown by this relative margin before culling rays, so
// that float round-off in the caster never lets a blocked ray go uncast.
constexpr double kBoundMargin = 1e-4;
// Memory for the per-thread accumulators of Gram().
constexpr double kGramScratchBytes = 512.0 * 1024 * 1024;

struct BoundingSphere {
  Eigen::Vector3d centre;
  double radius;
};

BoundingSphere MeshBoundingSphere(const TriangleMesh& mesh) {
  Eigen::Vector3d lo, hi;
  MeshBounds(mesh, &lo, &hi);
  const Eigen::Vector3d c = 0.5 * (lo + hi);
  double r2 = 0;
  for (const auto& v : mesh.vertices) r2 = std::max(r2, (v - c).squaredNorm());
  return {c, std::sqrt(r2) * (1 + kBoundMargin)};
}

}  // namespace

Eigen::Vector3d HemisphereMap::Direction(int texel) const {
  return EnvTexelDirection(texel % width(), texel / width(), width(), full_height());
}

double HemisphereMap::SolidAngle(int texel) const {
  return EnvTexelSolidAngle(texel / width(), width(), full_height());
}

Image HemisphereMap::ToEnvMap(const Eigen::MatrixX3d& radiance) const {
  SHADOWSG_CHECK(radiance.rows() == texels());
  Image env(width(), full_height(), 3, 0.0f);
  for (int j = 0; j < texels(); ++j)
    env.set_rgb(env.index(j % width(), j / width()), radiance.row(j).transpose().cast<float>());
  return env;
}

Eigen::MatrixX3d HemisphereMap::FromEnvMap(const Image& env) const {
  SHADOWSG_CHECK(env.width == width() && env.height == full_height());
  Eigen::MatrixX3d radiance(texels(), 3);
  for (int j = 0; j < texels(); ++j)
    radiance.row(j) = env.rgb(env.index(j % width(), j / width())).cast<double>().transpose();
  return radiance;
}

LightTransport::LightTransport(const Scene& scene, const std::vector<Eigen::Vector3d>& points,
                               const RayCaster& casters, int map_rows, const ProgressFn& progress) {
  SHADOWSG_CHECK(map_rows > 0);
  map_.rows = map_rows;
  rows_ = points.size();
  const int n = map_.texels();
  words_ = (n + 63) / 64;
  albedo_over_pi_.resize(rows_);
  for (size_t i = 0; i < rows_; ++i) albedo_over_pi_[i] = PlaneAlbedo(scene.plane, points[i]) / M_PI;

  const Eigen::Vector3d normal = scene.plane.normal.normalized();
  std::vector<Eigen::Vector3d> dirs(n);
  cosine_solid_angle_.resize(n);
  lit_.assign(words_, 0);
  for (int j = 0; j < n; ++j) {
    dirs[j] = map_.Direction(j);
    cosine_solid_angle_[j] = std::max(normal.dot(dirs[j]), 0.0) * map_.SolidAngle(j);
    if (cosine_solid_angle_[j] > 0) lit_[j / 64] |= uint64_t{1} << (j % 64);
  }

  std::vector<BoundingSphere> bounds;
  for (const SceneObject* o : scene.Casters()) {
    const TriangleMesh world = o->WorldMesh();
    if (!world.vertices.empty()) bounds.push_back(MeshBoundingSphere(world));
  }

  visible_.assign(rows_ * words_, 0);
  std::atomic<size_t> done{0};
  std::atomic<size_t> cast{0};
  std::atomic<bool> cancelled{false};
  std::exception_ptr error;
#pragma omp parallel
  {
    std::vector<int> ray_texels;
    size_t local_cast = 0;
#pragma omp for schedule(dynamic, 256)
    for (size_t i = 0; i < rows_; ++i) {
      if (cancelled.load(std::memory_order_relaxed)) continue;
      uint64_t* row = &visible_[i * words_];
      std::copy(lit_.begin(), lit_.end(), row);
      ray_texels.clear();
      double offset = 0;
      for (const BoundingSphere& b : bounds) {
        const Eigen::Vector3d d = b.centre - points[i];
        const double dist = d.norm();
        offset = std::max(offset, kRayOffsetRelative * (dist + b.radius));
        // Directions within the cone that the sphere subtends may be blocked.
        const double cos_cone = dist > b.radius ? std::sqrt(1 - (b.radius / dist) * (b.radius / dist)) : -2.0;
        const Eigen::Vector3d axis = dist > 0 ? Eigen::Vector3d(d / dist) : Eigen::Vector3d::UnitZ();
        for (int j = 0; j < n; ++j)
          if (cosine_solid_angle_[j] > 0 && dirs[j].dot(axis) >= cos_cone) {
            // Mark once (several spheres may claim the same texel).
            if ((row[j / 64] >> (j % 64)) & 1u) {
              row[j / 64] &= ~(uint64_t{1} << (j % 64));
              ray_texels.push_back(j);
            }
          }
      }
      // Single rays: these directions are incoherent, and Embree's 16-wide
      // packets (RayCaster::Visible) measured ~1.7x slower on them.
      const Eigen::Vector3d origin = points[i] + offset * normal;
      for (int j : ray_texels)
        if (!casters.Occluded(origin, dirs[j])) row[j / 64] |= uint64_t{1} << (j % 64);
      local_cast += ray_texels.size();
      const size_t d = ++done;
      if (omp_get_thread_num() == 0 && d % 4096 == 0) {
        try {
          Report(progress, static_cast<double>(d) / rows_, "visibility");
        } catch (...) {
#pragma omp critical(shadowsg_light_transport_error)
          if (!error) error = std::current_exception();
          cancelled = true;
        }
      }
    }
    cast += local_cast;
  }
  if (error) std::rethrow_exception(error);
  ray_fraction_ = rows_ > 0 ? static_cast<double>(cast) / (static_cast<double>(rows_) * n) : 0.0;
  Report(progress, 1.0, "visibility");
}

void LightTransport::GeometricRow(size_t row, double* out) const {
  SHADOWSG_CHECK(row < rows_);
  for (int j = 0; j < cols(); ++j) out[j] = Visible(row, j) ? cosine_solid_angle_[j] : 0.0;
}

Eigen::MatrixXd LightTransport::Matrix(const std::vector<size_t>& rows, int channel) const {
  SHADOWSG_CHECK(channel >= 0 && channel < 3);
  Eigen::MatrixXd a(rows.size(), cols());
  Eigen::VectorXd r(cols());
  for (size_t i = 0; i < rows.size(); ++i) {
    GeometricRow(rows[i], r.data());
    a.row(i) = albedo_over_pi_[rows[i]][channel] * r.transpose();
  }
  return a;
}

Eigen::Vector3d LightTransport::Irradiance(size_t row, const Eigen::MatrixX3d& radiance) const {
  SHADOWSG_CHECK(row < rows_ && radiance.rows() == cols());
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  const uint64_t* bits = &visible_[row * words_];
  for (int w = 0; w < words_; ++w) {
    uint64_t word = bits[w];
    while (word) {
      const int j = 64 * w + __builtin_ctzll(word);
      word &= word - 1;
      sum += cosine_solid_angle_[j] * radiance.row(j).transpose();
    }
  }
  return sum;
}

Eigen::Vector3d LightTransport::Render(size_t row, const Eigen::MatrixX3d& radiance) const {
  return albedo_over_pi_[row].cwiseProduct(Irradiance(row, radiance));
}

std::vector<Eigen::Vector3f> LightTransport::RenderAll(const Eigen::MatrixX3d& radiance) const {
  std::vector<Eigen::Vector3f> out(rows_);
#pragma omp parallel for schedule(static)
  for (size_t i = 0; i < rows_; ++i) out[i] = Render(i, radiance).cast<float>();
  return out;
}

namespace {

// Appends the indices of the set bits of the words to *out.
void SetBits(const uint64_t* words, int count, std::vector<int>* out) {
  out->clear();
  for (int w = 0; w < count; ++w)
    for (uint64_t word = words[w]; word; word &= word - 1) out->push_back(64 * w + __builtin_ctzll(word));
}

}  // namespace

Eigen::MatrixXd LightTransport::Gram(const std::vector<size_t>& rows, const Eigen::VectorXd& weights) const {
  SHADOWSG_CHECK(weights.size() == static_cast<Eigen::Index>(rows.size()));
  const int n = cols();
  // G = sum_r w_r v_r v_r^T for binary v_r = lit - o_r (o_r: occluded texels)
  //   = W lit lit^T - lit s^T - s lit^T + sum_r w_r o_r o_r^T,  s = sum_r w_r o_r,
  // used for rows with fewer occluded than visible texels; the others add
  // v_r v_r^T directly. Only the lower triangle is accumulated.
  Eigen::MatrixXd g = Eigen::MatrixXd::Zero(n, n);
  Eigen::VectorXd occluded_sum = Eigen::VectorXd::Zero(n);
  double lit_weight = 0;
  // The rows are cut into a fixed number of pieces, each summed into its own
  // n x n matrix and the pieces added in order: the same sums on any number
  // of threads (a matrix per thread, added as the threads finished, rounded
  // differently from run to run on three). At most 8 pieces, fewer where
  // their matrices would pass the memory bound.
  const long pieces = static_cast<long>(
      std::clamp<double>(std::floor(kGramScratchBytes / (sizeof(double) * n * static_cast<double>(n))), 1, 8));
  std::vector<Eigen::MatrixXd> piece_g(pieces);
  std::vector<Eigen::VectorXd> piece_s(pieces);
  std::vector<double> piece_w(pieces, 0.0);
  const long nrows = static_cast<long>(rows.size());
#pragma omp parallel
  {
    std::vector<uint64_t> words(words_);
    std::vector<int> index;
#pragma omp for schedule(dynamic, 1)
    for (long p = 0; p < pieces; ++p) {
      Eigen::MatrixXd& g_local = piece_g[p];
      Eigen::VectorXd& s_local = piece_s[p];
      g_local.setZero(n, n);
      s_local.setZero(n);
      for (long r = nrows * p / pieces; r < nrows * (p + 1) / pieces; ++r) {
        const uint64_t* bits = &visible_[rows[r] * words_];
        const double w = weights[r];
        int visible = 0, lit = 0;
        for (int k = 0; k < words_; ++k) {
          visible += __builtin_popcountll(bits[k]);
          lit += __builtin_popcountll(lit_[k]);
        }
        if (lit - visible <= visible) {
          for (int k = 0; k < words_; ++k) words[k] = lit_[k] & ~bits[k];
          piece_w[p] += w;
          SetBits(words.data(), words_, &index);
          for (int a : index) s_local[a] += w;
        } else {
          SetBits(bits, words_, &index);
        }
        for (size_t b = 0; b < index.size(); ++b) {
          double* column = &g_local(0, index[b]);
          for (size_t a = b; a < index.size(); ++a) column[index[a]] += w;
        }
      }
    }
  }
  for (long p = 0; p < pieces; ++p) {
    g += piece_g[p];
    occluded_sum += piece_s[p];
    lit_weight += piece_w[p];
    piece_g[p] = Eigen::MatrixXd();
  }
  Eigen::VectorXd lit(n);
  for (int j = 0; j < n; ++j) lit[j] = (lit_[j / 64] >> (j % 64)) & 1u;
  g.triangularView<Eigen::Lower>() += lit_weight * lit * lit.transpose() - lit * occluded_sum.transpose() -
                                      occluded_sum * lit.transpose();
  g.triangularView<Eigen::StrictlyUpper>() = g.transpose();
  return cosine_solid_angle_.asDiagonal() * g * cosine_solid_angle_.asDiagonal();
}

Eigen::MatrixX3d LightTransport::CrossProduct(const std::vector<size_t>& rows,
                                              const Eigen::MatrixX3d& coefficients) const {
  SHADOWSG_CHECK(coefficients.rows() == static_cast<Eigen::Index>(rows.size()));
  // sum_r v_r f_r^T = lit (sum_r f_r)^T - sum_r o_r f_r^T.
  Eigen::MatrixX3d occluded = Eigen::MatrixX3d::Zero(cols(), 3);
  std::vector<uint64_t> words(words_);
  std::vector<int> index;
  for (size_t r = 0; r < rows.size(); ++r) {
    const uint64_t* bits = &visible_[rows[r] * words_];
    for (int k = 0; k < words_; ++k) words[k] = lit_[k] & ~bits[k];
    SetBits(words.data(), words_, &index);
    for (int a : index) occluded.row(a) += coefficients.row(r);
  }
  const Eigen::RowVector3d total = coefficients.colwise().sum();
  Eigen::MatrixX3d f(cols(), 3);
  for (int j = 0; j < cols(); ++j) {
    const bool lit = (lit_[j / 64] >> (j % 64)) & 1u;
    f.row(j) = cosine_solid_angle_[j] * ((lit ? total : Eigen::RowVector3d::Zero()) - occluded.row(j));
  }
  return f;
}

std::vector<int> LightTransport::GroupIdenticalRows(std::vector<size_t>* first_row) const {
  auto row_hash = [this](size_t row) {
    uint64_t h = 0x9e3779b97f4a7c15ull;
    const uint64_t* bits = &visible_[row * words_];
    for (int w = 0; w < words_; ++w) {
      h ^= bits[w] + 0x9e3779b97f4a7c15ull + (h << 6) + (h >> 2);
      h *= 0xbf58476d1ce4e5b9ull;
    }
    return static_cast<size_t>(h ^ (h >> 31));
  };
  auto row_equal = [this](size_t a, size_t b) {
    return std::equal(&visible_[a * words_], &visible_[a * words_] + words_, &visible_[b * words_]);
  };
  std::unordered_map<size_t, int, decltype(row_hash), decltype(row_equal)> groups(rows_ / 4 + 16, row_hash,
                                                                                  row_equal);
  std::vector<int> group(rows_);
  first_row->clear();
  for (size_t i = 0; i < rows_; ++i) {
    const auto [it, inserted] = groups.try_emplace(i, static_cast<int>(first_row->size()));
    if (inserted) first_row->push_back(i);
    group[i] = it->second;
  }
  return group;
}

}  // namespace shadowsg
