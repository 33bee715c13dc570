// `--visibility exact` (issue #4): the shading of an SG lobe at a plane point
// with the visibility of the casters' REAL meshes, found by ray casting
// (solver/ray_caster.h, the project's one caster), instead of the sphere
// tree's sigmoid:
//
//   S(x; mu, lambda) = integral over the hemisphere of G(w) V(x, w) max(n.w, 0) dw
//                    = C(lambda, mu.n) - sum over occluded cells j of G(w_j) W_j
//
// with G(w) = exp(lambda (w.mu - 1)) per unit amplitude, C the closed-form
// unoccluded integral (solver/cosine_integral.h) and W_j = integral of
// cos(theta) over cell j. Only the OCCLUDED directions are stored, per point:
//
//  - a lat-long grid of the hemisphere about the plane normal, `rows` rows of
//    90/rows degrees (default 1 degree); a ray is cast through the centre of
//    every cell that a caster's bounding sphere could cover (the same culling
//    as light_transport.h);
//  - the occluded cell centres (one code each), and the same summed into
//    super-cells of 2 x 2, 4 x 4 and 8 x 8 cells (weight and mean direction),
//    for broader lobes;
//  - a cell whose 8 neighbours disagree with it is on the silhouette: it is
//    split into fine x fine sub-cells (default 4 x 4: 0.25 degree), each with
//    its own ray, for lobes sharper than ~50 (level 3 and 4 below); a wholly
//    occluded cell counts as its centre (level 3) or all its sub-cells (4). The full-image render (streaming) casts sub-cell rays only
//    where a sharp lobe of the lighting reaches, with the same result.
//
// A lobe is integrated on the coarsest level whose cell size h keeps
// lambda h^2 <= 1/4 (the centroid rule is then good to ~1 %): levels 0-2,
// 8-, 4- and 2-degree super-cells, up to lambda ~ 13, 51 and 205; level 3,
// 1-degree cell centres plus the silhouette's sub-cells, up to 821; level 4,
// every occluded cell split into its sub-cells (a 1-degree cell would alias
// a sun of 0.8 degrees); see LevelSwitch. Only directions within
// lambda (1 - w.mu) < 16 of the axis are summed (sharp lobes visit only the
// grid rows there). The derivatives with respect to mu (a free 3-vector at
// |mu| = 1) and lambda are exact for this quadrature.
//
// Rays: one per block of up to 4 x 4 cells first (blocks ~1/16 of the
// caster's cone), cells only in blocks whose neighbourhood disagrees, sub-cells
// only on the silhouette.
//
// Limits: an occluder thinner than one block (up to 4 degrees, about 1/16 of
// the caster's size, seen from the point) can fall between the block rays
// and be missed; the silhouette is resolved to the sub-cell (0.25 degree) for
// lobes sharper than ~200 and to the cell (1 degree) below, where the lobe is
// 4+ degrees wide.
#pragma once

#include <Eigen/Dense>
#include <atomic>
#include <cstdint>
#include <memory>
#include <vector>

#include "solver/cosine_integral.h"
#include "solver/progress.h"
#include "solver/ray_caster.h"
#include "solver/scene.h"
#include "solver/sg.h"
#include "solver/sg_shading.h"

namespace shadowsg {

struct ExactVisibilityOptions {
  int rows = 90;       // grid rows over the hemisphere (cells of 90/rows degrees)
  int fine = 4;        // silhouette cells split into fine x fine sub-cells (1..5)
};

// Super-cell levels: level l sums (2^(l+1))^2 cells.
inline constexpr int kAggregateLevels = 3;

// The occluded set of one point (a view into a table or a scratch buffer).
struct OccludedView {
  const uint32_t* codes = nullptr;  // cell << 5 | sub (sub 31: the whole cell), ascending
  size_t n_codes = 0;
  // Per level: (mean direction, cos-weighted solid angle) of occluded super-cells.
  const Eigen::Vector4f* aggregates[kAggregateLevels] = {};
  size_t n_aggregates[kAggregateLevels] = {};
};

// The occluded sets of a list of points, computed once (the fit's pixels).
struct OccludedTable {
  std::vector<size_t> code_offset{0};  // per point + 1
  std::vector<uint32_t> codes;
  std::vector<size_t> aggregate_offset[kAggregateLevels] = {{0}, {0}, {0}};
  std::vector<Eigen::Vector4f> aggregates[kAggregateLevels];
  size_t rays = 0;  // rays cast to build it

  size_t size() const { return code_offset.size() - 1; }
  OccludedView View(size_t k) const {
    OccludedView v;
    v.codes = codes.data() + code_offset[k];
    v.n_codes = code_offset[k + 1] - code_offset[k];
    for (int l = 0; l < kAggregateLevels; ++l) {
      v.aggregates[l] = aggregates[l].data() + aggregate_offset[l][k];
      v.n_aggregates[l] = aggregate_offset[l][k + 1] - aggregate_offset[l][k];
    }
    return v;
  }
  size_t Bytes() const {
    size_t b = code_offset.size() * sizeof(size_t) + codes.size() * 4;
    for (int l = 0; l < kAggregateLevels; ++l)
      b += aggregate_offset[l].size() * sizeof(size_t) + aggregates[l].size() * sizeof(Eigen::Vector4f);
    return b;
  }
};

// Per point while building: the codes and every level's super-cells.
struct OccludedSet {
  std::vector<uint32_t> codes;
  std::vector<Eigen::Vector4f> aggregates[kAggregateLevels];
  OccludedView View() const {
    OccludedView v{codes.data(), codes.size()};
    for (int l = 0; l < kAggregateLevels; ++l) v.aggregates[l] = aggregates[l].data(), v.n_aggregates[l] = aggregates[l].size();
    return v;
  }
};

class ExactVisibility {
 public:
  // `casters` holds the world meshes of `caster_meshes` (BuildRayCaster of
  // scene.Casters()); the meshes' bounding spheres decide which rays need casting.
  ExactVisibility(std::shared_ptr<const RayCaster> casters, const std::vector<TriangleMesh>& caster_meshes,
                  const Eigen::Vector3d& normal, const ExactVisibilityOptions& options = {});

  const Eigen::Vector3d& normal() const { return n_; }
  const ExactVisibilityOptions& options() const { return o_; }
  // The sharpness above which level i (0: 8-degree super-cells, 1: 4, 2: 2,
  // 3: 1-degree cell centres) is too coarse and the next finer level is used.
  double LevelSwitch(int i) const;

  // Occluded sets of the points, multithreaded. `progress` may throw to cancel.
  OccludedTable Tabulate(const std::vector<Eigen::Vector3d>& points, const ProgressFn& progress = {}) const;

  // What a lobe's shading shares over all points (the closed form C costs
  // ~1000 times one point's sum): prepare once per lobe.
  struct Lobe {
    Eigen::Vector3d mu;
    double lambda = 1;
    CosineIntegral closed;
    int level = 0;        // 0-2: super-cells (coarsest first), 3: cell centres, 4: sub-cells
    uint32_t lo = 0, hi = 0;  // code range of the grid rows within the cutoff
  };
  Lobe Prepare(const Eigen::Vector3d& mu, double lambda) const;

  // Shading of a unit-amplitude lobe (per unit albedo/pi) over an occluded set,
  // with its derivatives when `gradient` (LobeShading::sigma is unused).
  LobeShading Shade(const OccludedView& view, const Lobe& lobe, bool gradient) const;
  LobeShading Shade(const OccludedView& view, const Eigen::Vector3d& mu, double lambda, bool gradient) const {
    return Shade(view, Prepare(mu, lambda), gradient);
  }

  // Radiance albedo/pi * sum_i a_i S_i at every point. With a table of the
  // same points it is used; otherwise each point's set is built, used and
  // dropped (streaming: memory stays flat for a full image). Lobes whose axis
  // is below the plane are skipped when upper_hemisphere_only.
  std::vector<Eigen::Vector3f> Render(const std::vector<Eigen::Vector3d>& points,
                                      const std::vector<Eigen::Vector3f>& albedo, const SgLighting& lighting,
                                      bool upper_hemisphere_only, const OccludedTable* table = nullptr,
                                      const ProgressFn& progress = {}) const;

  // Rays cast so far by Render/Tabulate of this object (statistics).
  size_t RaysCast() const;

 private:
  struct Scratch;
  // The occluded set of p; with `sharp`, sub-cell rays are cast only where
  // one of these lobes can use them (Shade gives the same values for them).
  void BuildPoint(const Eigen::Vector3d& p, Scratch* s, OccludedSet* out, size_t* rays,
                  const std::vector<Lobe>* sharp = nullptr) const;
  bool NeedsSubCells(uint32_t cell, const std::vector<Lobe>& sharp) const;
  Eigen::Vector3d Dir(double theta, double phi) const;

  std::shared_ptr<const RayCaster> casters_;
  struct Bound {
    Eigen::Vector3d centre;
    double radius;
  };
  std::vector<Bound> bounds_;
  ExactVisibilityOptions o_;
  Eigen::Vector3d n_, t_, b_;
  int cols_ = 0;
  double delta_ = 0;
  // Per cell (row-major, rows x cols) and per sub-cell (cell * fine^2 + sub):
  // centre direction and cos-weighted solid angle.
  std::vector<Eigen::Vector4f> cell_, sub_;
  mutable std::shared_ptr<std::atomic<size_t>> rays_;
};

// The exact visibility of a scene's casters (builds its own ray caster).
std::shared_ptr<const ExactVisibility> MakeExactVisibility(const Scene& scene,
                                                           const ExactVisibilityOptions& options = {});

}  // namespace shadowsg
