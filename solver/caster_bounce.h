// The light the casters reflect onto the plane: one diffuse bounce,
// distant lights -> caster surface -> plane.
//
// ShadowSG's forward model (method-notes.md) has direct light only. A
// Lambertian caster lit from one side throws part of that light back onto the
// plane around it; on the development scenes (Blender Cycles, caster albedo
// 0.7) a path-traced render of the true lighting gains 6 dB over the same
// render without the bounce (pub_torus_sunrise 31.6 -> 37.8 dB), and a
// direct-only model can only absorb that glow into lobes that are not the
// lighting. This adds it, still linear in every lobe's amplitude:
//
//   L(x) = albedo/pi * sum_i a_i (S_i(x) + B_i(x)),
//   B_i(x) = sum_j K(x, j) rho_j/pi e_ij,
//
// over surface patches j of the casters (area A_j, normal n_j, albedo rho_j):
//   K(x, j) = cos_x cos_j A_j / (d^2 + A_j / pi)    (a disk's form factor:
//             finite where the caster meets the plane; 0 unless the patch is
//             above the plane and faces x),
//   e_ij    = C(lambda_i, mu_i . n_j) v_ij           (irradiance per unit amplitude;
//             C the exact cosine integral, solver/cosine_integral.h),
//   v_ij    = the lobe-weighted share of the patch's cosine lobe that reaches
//             the sky: directions below the plane are blocked by it, the
//             others by ray casts against the casters, on a Fibonacci sphere
//             of directions tabulated once per patch. The lobe is widened to
//             the table's resolution for this share only (a sun's terminator
//             on the caster is blurred by a few degrees; the bounce is a
//             smooth field on the plane, and it needs no finer).
//
// and, because a caster's underside is lit mostly by the plane beneath it, the
// second bounce distant lights -> plane -> caster -> plane: each patch also
// receives sum_p W(j, p) rho_p S_i(p) from ground samples p (a log-polar grid
// on the plane around the casters, with the lobe's direct shading S_i there,
// shadows included, which the caller computes: CasterBounce knows no shading
// model). W(j, p) gathers the patch's downward directions that reach the
// plane near p unblocked, cos-weighted.
//
// Not modelled: longer paths, and the caster hiding its own patches from x
// (patches are kept when they face x; a ray per point and patch for it was
// tried: median of three seeds 0.3 dB lower on pub_torus_sunrise, 0.5 on
// interior, and 2 s more a full render). Derivatives of B with respect to a
// lobe's axis and sharpness are not provided: B is linear in the amplitudes
// and a slow function of the rest (solver/sg_refine_cost.h differentiates it
// in sharpness numerically).
#pragma once

#include <Eigen/Dense>
#include <array>
#include <memory>
#include <vector>

#include "solver/mesh.h"
#include "solver/ray_caster.h"
#include "solver/row_parallel_product.h"
#include "solver/sg.h"

namespace shadowsg {

struct CasterBounceOptions {
  int patches = 256;           // surface patches over all casters together
  int directions = 512;        // sky directions per patch (whole sphere)
  int surface_points = 12000;  // surface grid the patches are clustered from
  int ground_rings = 24;       // log-polar ground grid: rings from 1 % to 30x the casters' size
  int ground_sectors = 32;
};

// A points x patches form-factor matrix K as left * basis, basis (rank x
// patches) the leading eigenvectors of K'K: the fewest that leave a residual
// whose Frobenius norm is at most `tolerance` times K's. A solver gathers the
// bounce at the same points many times, and at 0.3 % the plane pixels' K
// needs 89-112 of 256 (development scenes); basis stays empty (left = K)
// where the rank would save too little.
struct FactoredFormFactors {
  Eigen::MatrixXf left, basis;
  long rank() const { return basis.size() ? basis.rows() : left.cols(); }
  // K x (patches x n): what the patches' radiance gives at the points.
  Eigen::MatrixXf Times(const Eigen::MatrixXf& x) const { return Expand(Reduce(x)); }
  // Times in two halves: the radiance in the basis (rank x n), then at the
  // points. Sums of reduced columns expand to the sum of their products: a
  // caller that needs only a weighted sum of many lobes' bounce expands that.
  Eigen::MatrixXf Reduce(const Eigen::MatrixXf& x) const { return basis.size() ? RowParallelProduct(basis, x) : x; }
  Eigen::MatrixXf Expand(const Eigen::MatrixXf& y) const { return RowParallelProduct(left, y); }
};
FactoredFormFactors FactorFormFactors(Eigen::MatrixXf k, double tolerance);

class CasterBounce {
 public:
  struct Patch {
    Eigen::Vector3d centre, normal;
    double area = 0;
    Eigen::Vector3f albedo_over_pi = Eigen::Vector3f::Zero();
  };

  // world_meshes[i] has the Lambertian albedo albedo[i]; `casters` holds the
  // same meshes (BuildRayCaster). The plane passes through plane_point.
  CasterBounce(const std::vector<TriangleMesh>& world_meshes, const std::vector<Eigen::Vector3d>& albedo,
               const RayCaster& casters, const Eigen::Vector3d& plane_point, const Eigen::Vector3d& plane_normal,
               const CasterBounceOptions& options = {});

  const std::vector<Patch>& patches() const { return patches_; }
  size_t size() const { return patches_.size(); }
  // The plane points whose direct light reaches the patches (second bounce).
  const std::vector<Eigen::Vector3d>& ground() const { return ground_; }

  // Per channel, e_ij of every patch (rows) for every lobe (columns), per
  // unit amplitude. ground_radiance[c] (ground points x lobes), when given,
  // holds rho_p,c S_i(p): the plane's direct light at ground(), per unit
  // amplitude, times its albedo.
  std::array<Eigen::MatrixXf, 3> Irradiance(const std::vector<Eigen::Vector3d>& axes,
                                            const std::vector<double>& sharpness,
                                            const std::array<Eigen::MatrixXf, 3>* ground_radiance) const;

  // K(x, j) for the points (rows) and patches (columns).
  Eigen::MatrixXf FormFactors(const std::vector<Eigen::Vector3d>& points) const;

  // sum_j K(x, j) radiance(j, c) at every point (per unit plane albedo/pi),
  // with the form factors computed on the fly in chunks (memory stays flat).
  std::vector<Eigen::Vector3f> Gather(const std::vector<Eigen::Vector3d>& points,
                                      const Eigen::MatrixXf& patch_radiance) const;

 private:
  std::vector<Patch> patches_;
  Eigen::Vector3d normal_;
  std::vector<Eigen::Vector3d> dirs_;  // the sky directions
  double max_weight_sharpness_ = 0;    // widest-resolved lobe of the direction table
  // Per patch x direction above the plane: max(n_j . w, 0) where the casters
  // leave the sky open, and everywhere.
  Eigen::MatrixXf visible_cos_, upper_cos_;
  std::vector<Eigen::Vector3d> ground_;
  Eigen::MatrixXf ground_weight_;  // patches x ground points: W(j, p)
};

}  // namespace shadowsg
