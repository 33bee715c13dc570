#include "solver/exact_visibility.h"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <exception>

#include "calib/error.h"
#include "solver/cosine_integral.h"
#include "solver/plane_pixels.h"

namespace shadowsg {
namespace {

// As light_transport.cc: rays start this far above the plane, relative to the
// distance to the casters' bounding sphere; bounds grow by this margin.
constexpr double kRayOffsetRelative = 1e-5;
constexpr double kBoundMargin = 1e-4;
// Directions where a lobe is below exp(-kCutoff) of its peak are skipped.
constexpr double kCutoff = 16.0;
// The centroid rule over cells of size h is good to ~1 % while lambda h^2 <= this.
constexpr double kCellResolution = 0.25;
// Codes: cell << 5 | k, k < fine^2 an occluded sub-cell of a silhouette cell,
// kSilhouetteCell a silhouette cell whose centre is occluded, kWholeCell a
// cell occluded with all its neighbours.
constexpr uint32_t kSilhouetteCell = 30;
constexpr uint32_t kWholeCell = 31;

// cos-weighted solid angle of the band [t0, t1] x a phi width dphi.
double CosWeight(double t0, double t1, double dphi) {
  const double s0 = std::sin(t0), s1 = std::sin(t1);
  return 0.5 * dphi * (s1 * s1 - s0 * s0);
}

}  // namespace

struct ExactVisibility::Scratch {
  std::vector<uint8_t> state;  // per cell: 0 not cast, 1 visible, 2 occluded
  std::vector<uint32_t> cand;
  std::vector<Eigen::Vector4d> agg[kAggregateLevels];  // per super-cell: sum W w (3), sum W
  std::vector<int> agg_touched[kAggregateLevels];
  std::vector<uint8_t> block;  // per block of cells: 0 not cast, 1 visible, 2 occluded
  std::vector<int> blocks;
};

ExactVisibility::ExactVisibility(std::shared_ptr<const RayCaster> casters,
                                 const std::vector<TriangleMesh>& caster_meshes, const Eigen::Vector3d& normal,
                                 const ExactVisibilityOptions& options)
    : casters_(std::move(casters)), o_(options), rays_(std::make_shared<std::atomic<size_t>>(0)) {
  SHADOWSG_CHECK(casters_ != nullptr);
  SHADOWSG_CHECK(o_.rows >= 4 && o_.fine >= 1 && o_.fine <= 5);
  n_ = normal.normalized();
  t_ = (std::abs(n_.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY()).cross(n_).normalized();
  b_ = n_.cross(t_);
  cols_ = 4 * o_.rows;
  delta_ = M_PI / (2 * o_.rows);
  for (const TriangleMesh& m : caster_meshes) {
    if (m.vertices.empty()) continue;
    Eigen::Vector3d lo, hi;
    MeshBounds(m, &lo, &hi);
    const Eigen::Vector3d c = 0.5 * (lo + hi);
    double r2 = 0;
    for (const auto& v : m.vertices) r2 = std::max(r2, (v - c).squaredNorm());
    bounds_.push_back({c, std::sqrt(r2) * (1 + kBoundMargin)});
  }
  const int F = o_.fine;
  cell_.resize(static_cast<size_t>(o_.rows) * cols_);
  sub_.resize(cell_.size() * F * F);
  for (int r = 0; r < o_.rows; ++r)
    for (int c = 0; c < cols_; ++c) {
      const size_t cell = static_cast<size_t>(r) * cols_ + c;
      const double t0 = r * delta_, p0 = c * delta_;
      cell_[cell] << Dir(t0 + 0.5 * delta_, p0 + 0.5 * delta_).cast<float>(),
          static_cast<float>(CosWeight(t0, t0 + delta_, delta_));
      const double d = delta_ / F;
      for (int i = 0; i < F; ++i)
        for (int j = 0; j < F; ++j)
          sub_[cell * F * F + i * F + j] << Dir(t0 + (i + 0.5) * d, p0 + (j + 0.5) * d).cast<float>(),
              static_cast<float>(CosWeight(t0 + i * d, t0 + (i + 1) * d, d));
    }
}

Eigen::Vector3d ExactVisibility::Dir(double theta, double phi) const {
  return std::sin(theta) * (std::cos(phi) * t_ + std::sin(phi) * b_) + std::cos(theta) * n_;
}

size_t ExactVisibility::RaysCast() const { return rays_->load(); }

double ExactVisibility::LevelSwitch(int i) const {
  const double h = delta_ * (1 << (kAggregateLevels - i));
  return kCellResolution / (h * h);
}

bool ExactVisibility::NeedsSubCells(uint32_t cell, const std::vector<Lobe>& sharp) const {
  const Eigen::Vector3d w = cell_[cell].head<3>().cast<double>();
  for (const Lobe& l : sharp)  // the test of Shade's whole-cell reject
    if (l.level >= kAggregateLevels && !(l.lambda * (w.dot(l.mu) - 1) < -kCutoff - l.lambda * delta_ * 1.5)) return true;
  return false;
}

void ExactVisibility::BuildPoint(const Eigen::Vector3d& p, Scratch* s, OccludedSet* out, size_t* rays,
                                 const std::vector<Lobe>* sharp) const {
  const int R = o_.rows, C = cols_, F = o_.fine;
  const size_t ncell = static_cast<size_t>(R) * C;
  if (s->state.size() != ncell) s->state.assign(ncell, 0);
  for (int l = 0; l < kAggregateLevels; ++l) {
    const int A = 2 << l;
    const size_t nagg = static_cast<size_t>((R + A - 1) / A) * ((C + A - 1) / A);
    if (s->agg[l].size() != nagg) s->agg[l].assign(nagg, Eigen::Vector4d::Zero());
    out->aggregates[l].clear();
  }
  std::vector<uint32_t>* codes = &out->codes;
  codes->clear();
  s->cand.clear();
  double offset = 0, cone = 0;  // cone: the widest caster cone's half-angle (radians)
  for (const Bound& b : bounds_) {
    const Eigen::Vector3d d = b.centre - p;
    const double dist = d.norm();
    offset = std::max(offset, kRayOffsetRelative * (dist + b.radius));
    int rlo = 0, rhi = R - 1;
    double cos_ext = -2;
    Eigen::Vector3d axis = n_;
    cone = std::max(cone, dist > b.radius ? std::asin(b.radius / dist) : M_PI / 2);
    if (dist > b.radius) {
      axis = d / dist;
      // Any cell reaching into the cone has its centre within alpha + delta.
      const double ext = std::asin(b.radius / dist) + delta_;
      const double ta = std::acos(std::clamp(axis.dot(n_), -1.0, 1.0));
      rlo = std::max(0, static_cast<int>(std::floor((ta - ext) / delta_)));
      rhi = std::min(R - 1, static_cast<int>(std::floor((ta + ext) / delta_)));
      cos_ext = ext < M_PI ? std::cos(ext) : -2;
    }
    for (int r = rlo; r <= rhi; ++r)
      for (int c = 0; c < C; ++c) {
        const uint32_t cell = static_cast<uint32_t>(r * C + c);
        if (s->state[cell]) continue;
        if (cell_[cell].head<3>().cast<double>().dot(axis) >= cos_ext) {
          s->state[cell] = 1;
          s->cand.push_back(cell);
        }
      }
  }
  std::sort(s->cand.begin(), s->cand.end());
  const Eigen::Vector3d origin = p + offset * n_;
  // Blocks of B x B cells, B about 1/16 of the caster's cone diameter (at
  // most 4 cells): one ray per block first; a block whose 3 x 3 block
  // neighbourhood agrees takes that state without casting its cells. (An
  // occluder thinner than a block, ~1/16 of the caster's size, could slip
  // between these rays.)
  const int B = cone >= 64 * delta_ ? 4 : cone >= 32 * delta_ ? 2 : 1;
  size_t cast = 0;
  if (B > 1) {
    const int BR = (R + B - 1) / B, BC = C / B;
    if (s->block.size() < static_cast<size_t>(BR) * BC) s->block.assign(static_cast<size_t>(BR) * BC, 0);
    s->blocks.clear();
    for (uint32_t cell : s->cand) {
      const int b = (static_cast<int>(cell) / C / B) * BC + (static_cast<int>(cell) % C) / B;
      if (!s->block[b]) {
        s->block[b] = 1;
        s->blocks.push_back(b);
      }
    }
    for (int b : s->blocks) {
      const Eigen::Vector3d d = Dir(std::min((b / BC * B + 0.5 * B) * delta_, M_PI / 2), (b % BC * B + 0.5 * B) * delta_);
      s->block[b] = casters_->Occluded(origin, d) ? 2 : 1;
    }
    cast += s->blocks.size();
    for (uint32_t cell : s->cand) {
      const int br = static_cast<int>(cell) / C / B, bc = (static_cast<int>(cell) % C) / B;
      const uint8_t bs = s->block[br * BC + bc];
      bool uniform = true;
      for (int dr = -1; dr <= 1 && uniform; ++dr) {
        const int rr = br + dr;
        if (rr < 0 || rr >= BR) continue;
        for (int dc = -1; dc <= 1 && uniform; ++dc) {
          const uint8_t ns = s->block[rr * BC + (bc + dc + BC) % BC];
          uniform = (ns == 0 ? 1 : ns) == bs;
        }
      }
      if (uniform) s->state[cell] = bs;
      else {
        s->state[cell] = casters_->Occluded(origin, cell_[cell].head<3>().cast<double>()) ? 2 : 1;
        ++cast;
      }
    }
    for (int b : s->blocks) s->block[b] = 0;
  } else {
    // Single rays: incoherent directions (see light_transport.cc).
    for (uint32_t cell : s->cand)
      s->state[cell] = casters_->Occluded(origin, cell_[cell].head<3>().cast<double>()) ? 2 : 1;
    cast += s->cand.size();
  }
  auto accumulate = [&](uint32_t cell, const Eigen::Vector4f& e) {
    const int r = static_cast<int>(cell) / C, c = static_cast<int>(cell) % C;
    for (int l = 0; l < kAggregateLevels; ++l) {
      const int A = 2 << l;
      const int g = (r / A) * ((C + A - 1) / A) + c / A;
      Eigen::Vector4d& acc = s->agg[l][g];
      if (acc[3] == 0) s->agg_touched[l].push_back(g);
      acc.head<3>() += static_cast<double>(e[3]) * e.head<3>().cast<double>();
      acc[3] += e[3];
    }
  };
  for (uint32_t cell : s->cand) {
    const int r = static_cast<int>(cell) / C, c = static_cast<int>(cell) % C;
    const uint8_t st = s->state[cell];
    bool boundary = false;
    for (int dr = -1; dr <= 1 && !boundary; ++dr) {
      const int rr = r + dr;
      if (rr < 0 || rr >= R) continue;  // across the pole / below the horizon: no neighbour
      for (int dc = -1; dc <= 1; ++dc) {
        const int cc = (c + dc + C) % C;
        const uint8_t ns = s->state[static_cast<size_t>(rr) * C + cc];
        if ((ns == 0 ? 1 : ns) != st) {
          boundary = true;
          break;
        }
      }
    }
    // Levels 0-3 see the centre rays only; sub-cell rays serve level 4
    // (sharp lobes), and only where one of `sharp` can reach when given.
    if (boundary && (!sharp || NeedsSubCells(cell, *sharp))) {
      for (int k = 0; k < F * F; ++k) {
        const Eigen::Vector4f& e = sub_[static_cast<size_t>(cell) * F * F + k];
        if (casters_->Occluded(origin, e.head<3>().cast<double>())) codes->push_back(cell << 5 | static_cast<uint32_t>(k));
      }
      cast += F * F;
    }
    if (st == 2) {
      codes->push_back(cell << 5 | (boundary ? kSilhouetteCell : kWholeCell));
      accumulate(cell, cell_[cell]);
    }
  }
  for (uint32_t cell : s->cand) s->state[cell] = 0;
  for (int l = 0; l < kAggregateLevels; ++l) {
    for (int g : s->agg_touched[l]) {
      const Eigen::Vector4d& acc = s->agg[l][g];
      const double norm = acc.head<3>().norm();
      if (norm > 0) {
        Eigen::Vector4f e;
        e << (acc.head<3>() / norm).cast<float>(), static_cast<float>(acc[3]);
        out->aggregates[l].push_back(e);
      }
      s->agg[l][g].setZero();
    }
    s->agg_touched[l].clear();
  }
  *rays += cast;
}

OccludedTable ExactVisibility::Tabulate(const std::vector<Eigen::Vector3d>& points, const ProgressFn& progress) const {
  const long np = static_cast<long>(points.size());
  std::vector<OccludedSet> sets(np);
  size_t rays = 0;
  std::exception_ptr error;
  std::atomic<bool> cancelled{false};
#pragma omp parallel reduction(+ : rays)
  {
    Scratch s;
#pragma omp for schedule(dynamic, 16)
    for (long k = 0; k < np; ++k) {
      if (cancelled.load(std::memory_order_relaxed)) continue;
      BuildPoint(points[k], &s, &sets[k], &rays);
      sets[k].codes.shrink_to_fit();
      for (auto& a : sets[k].aggregates) a.shrink_to_fit();
      if (omp_get_thread_num() == 0 && k % 512 == 0) {
        try {
          Report(progress, static_cast<double>(k) / std::max(1L, np), "exact visibility");
        } catch (...) {
#pragma omp critical(shadowsg_exact_visibility_error)
          if (!error) error = std::current_exception();
          cancelled = true;
        }
      }
    }
  }
  if (error) std::rethrow_exception(error);
  OccludedTable t;
  size_t nc = 0, na[kAggregateLevels] = {};
  for (long k = 0; k < np; ++k) {
    nc += sets[k].codes.size();
    for (int l = 0; l < kAggregateLevels; ++l) na[l] += sets[k].aggregates[l].size();
  }
  t.codes.reserve(nc);
  for (int l = 0; l < kAggregateLevels; ++l) t.aggregates[l].reserve(na[l]);
  for (long k = 0; k < np; ++k) {
    t.codes.insert(t.codes.end(), sets[k].codes.begin(), sets[k].codes.end());
    t.code_offset.push_back(t.codes.size());
    for (int l = 0; l < kAggregateLevels; ++l) {
      t.aggregates[l].insert(t.aggregates[l].end(), sets[k].aggregates[l].begin(), sets[k].aggregates[l].end());
      t.aggregate_offset[l].push_back(t.aggregates[l].size());
    }
    sets[k] = OccludedSet();
  }
  t.rays = rays;
  *rays_ += rays;
  return t;
}

ExactVisibility::Lobe ExactVisibility::Prepare(const Eigen::Vector3d& mu, double lambda) const {
  Lobe l;
  l.mu = mu;
  l.lambda = lambda;
  const double c = mu.dot(n_);
  l.closed = SgCosineIntegral(lambda, c);
  while (l.level < kAggregateLevels + 1 && lambda > LevelSwitch(l.level)) ++l.level;
  const int R = o_.rows, C = cols_;
  int rlo = 0, rhi = R - 1;
  if (kCutoff / lambda < 2) {  // rows within the cutoff of the axis
    const double d = std::acos(1 - kCutoff / lambda);
    const double tm = std::acos(std::clamp(c, -1.0, 1.0));
    rlo = std::max(0, static_cast<int>(std::floor((tm - d) / delta_)));
    rhi = std::min(R - 1, static_cast<int>(std::floor((tm + d) / delta_)));
  }
  if (rlo <= rhi) {
    l.lo = static_cast<uint32_t>(rlo * C) << 5;
    l.hi = static_cast<uint32_t>((rhi + 1) * C) << 5;
  }
  return l;
}

LobeShading ExactVisibility::Shade(const OccludedView& v, const Lobe& lobe, bool gradient) const {
  LobeShading out;
  out.sigma = 1;
  const Eigen::Vector3d& mu = lobe.mu;
  const double lambda = lobe.lambda;
  double occ = 0, docc_dl = 0;
  Eigen::Vector3d docc_dmu = Eigen::Vector3d::Zero();
  auto add = [&](const Eigen::Vector4f& e) {
    const Eigen::Vector3d w = e.head<3>().cast<double>();
    const double x = lambda * (w.dot(mu) - 1);
    if (x < -kCutoff) return;
    const double g = std::exp(x) * e[3];
    occ += g;
    if (gradient) {
      docc_dl += x / lambda * g;
      docc_dmu += lambda * g * w;
    }
  };
  if (lobe.level < kAggregateLevels) {
    // Super-cells: level 0 is the coarsest (8 x 8 cells), stored last.
    const int l = kAggregateLevels - 1 - lobe.level;
    for (size_t k = 0; k < v.n_aggregates[l]; ++k) add(v.aggregates[l][k]);
  } else if (lobe.lo < lobe.hi) {
    const int F = o_.fine;
    const uint32_t* begin = std::lower_bound(v.codes, v.codes + v.n_codes, lobe.lo);
    const uint32_t* end = std::lower_bound(begin, v.codes + v.n_codes, lobe.hi);
    const bool split = lobe.level > kAggregateLevels;  // lambda > LevelSwitch(3): sub-cells
    const double reject = -kCutoff - lambda * delta_ * 1.5;
    for (const uint32_t* it = begin; it != end; ++it) {
      const uint32_t cell = *it >> 5, sub = *it & 31u;
      if (!split) {
        // Cell centres, and the silhouette's sub-cells: a 1-degree step of the
        // silhouette would band the penumbra of a lobe a few degrees wide.
        if (sub == kWholeCell) add(cell_[cell]);
        else if (sub < kSilhouetteCell) add(sub_[static_cast<size_t>(cell) * F * F + sub]);
      } else if (sub < kSilhouetteCell) {
        add(sub_[static_cast<size_t>(cell) * F * F + sub]);
      } else if (sub == kWholeCell) {
        // Cheap reject: the whole cell is beyond the cutoff.
        const Eigen::Vector4f& e = cell_[cell];
        if (lambda * (e.head<3>().cast<double>().dot(mu) - 1) < reject) continue;
        for (int k = 0; k < F * F; ++k) add(sub_[static_cast<size_t>(cell) * F * F + k]);
      }
    }
  }
  out.value = lobe.closed.value - occ;
  if (gradient) {
    out.dvalue_dlambda = lobe.closed.dlambda - docc_dl;
    out.dvalue_dmu = lobe.closed.dc * n_ - docc_dmu;
  }
  return out;
}

std::vector<Eigen::Vector3f> ExactVisibility::Render(const std::vector<Eigen::Vector3d>& points,
                                                     const std::vector<Eigen::Vector3f>& albedo,
                                                     const SgLighting& lighting, bool upper_hemisphere_only,
                                                     const OccludedTable* table, const ProgressFn& progress) const {
  SHADOWSG_CHECK(albedo.size() == points.size());
  const bool use_table = table && table->size() == points.size();
  std::vector<const SgLobe*> active;
  std::vector<Lobe> prepared;
  for (const SgLobe& l : lighting.lobes)
    if (!upper_hemisphere_only || l.axis.dot(n_) > 0) {
      active.push_back(&l);
      prepared.push_back(Prepare(l.axis, l.sharpness));
    }
  const long np = static_cast<long>(points.size());
  std::vector<Eigen::Vector3f> out(points.size(), Eigen::Vector3f::Zero());
  size_t rays = 0;
  std::exception_ptr error;
  std::atomic<bool> cancelled{false};
#pragma omp parallel reduction(+ : rays)
  {
    Scratch s;
    OccludedSet set;
#pragma omp for schedule(dynamic, 64)
    for (long k = 0; k < np; ++k) {
      if (cancelled.load(std::memory_order_relaxed)) continue;
      OccludedView view;
      if (use_table) view = table->View(k);
      else {
        BuildPoint(points[k], &s, &set, &rays, &prepared);
        view = set.View();
      }
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      for (size_t j = 0; j < active.size(); ++j) sum += Shade(view, prepared[j], false).value * active[j]->amplitude;
      out[k] = (albedo[k].cast<double>().cwiseProduct(sum) / M_PI).cast<float>();
      if (!use_table && omp_get_thread_num() == 0 && k % 1024 == 0) {
        try {
          Report(progress, static_cast<double>(k) / std::max(1L, np), "exact render");
        } catch (...) {
#pragma omp critical(shadowsg_exact_visibility_error)
          if (!error) error = std::current_exception();
          cancelled = true;
        }
      }
    }
  }
  if (error) std::rethrow_exception(error);
  *rays_ += rays;
  return out;
}

std::shared_ptr<const ExactVisibility> MakeExactVisibility(const Scene& scene, const ExactVisibilityOptions& options) {
  const std::vector<const SceneObject*> casters = scene.Casters();
  std::vector<TriangleMesh> meshes;
  for (const SceneObject* o : casters) meshes.push_back(o->WorldMesh());
  auto rc = std::make_shared<RayCaster>(BuildRayCaster(casters));
  return std::make_shared<ExactVisibility>(rc, meshes, scene.plane.normal, options);
}

}  // namespace shadowsg
