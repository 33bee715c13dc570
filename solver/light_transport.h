// The light transport of the map baselines (method-notes.md "Baselines"):
// rows are shadow-plane points, columns are the texels of the upper half of an
// equirectangular map (calib/conventions.h), and channel c of the matrix is
//
//   A_c[x, j] = (albedo_c / pi) * V(x, w_j) * max(n . w_j, 0) * dOmega_j
//
// with w_j the texel-centre direction, dOmega_j the texel's exact solid angle,
// V the binary visibility found by casting a ray against the casters' real
// meshes and albedo the plane's at x (PlaneAlbedo: diffuse, times the texture
// if any). The map holds radiance, so albedo/pi is the Lambertian factor
// (method-notes.md, physical scale); it lives in AlbedoOverPi() and nowhere else.
//
// Memory: a 512x512 scene has ~250k plane pixels; the dense matrix would be
// 250k x 1024 doubles = 2 GB. We store V only, one bit per entry (32 MB for
// 250k x 1024), and expand a row when it is needed (the fit copies the rows it
// uses into a dense matrix; re-rendering streams every row against the map).
// Rays are cast once per (point, texel) and only where a caster's bounding
// sphere could block the texel-centre direction; every other entry is visible.
#pragma once

#include <Eigen/Dense>
#include <cstdint>
#include <vector>

#include "calib/image.h"
#include "solver/progress.h"
#include "solver/ray_caster.h"
#include "solver/scene.h"

namespace shadowsg {

// The texel grid of the baselines' map: the upper `rows` rows of a full
// equirectangular map of height 2 * rows and width 4 * rows, so that it covers
// theta in [0, pi/2] (the hemisphere above a plane with normal +z). Texel
// j = v * width() + u, v counted from the pole.
struct HemisphereMap {
  int rows = 16;

  int width() const { return 4 * rows; }
  int full_height() const { return 2 * rows; }
  int texels() const { return rows * width(); }
  Eigen::Vector3d Direction(int texel) const;  // texel-centre direction
  double SolidAngle(int texel) const;          // exact

  // The full map (height 2 * rows, width 4 * rows, lower half zero) from
  // texels() x 3 radiance values.
  Image ToEnvMap(const Eigen::MatrixX3d& radiance) const;
  // The texels of a full map of exactly this resolution (its upper half).
  Eigen::MatrixX3d FromEnvMap(const Image& env) const;
};

class LightTransport {
 public:
  // Casts the visibility rays from every point (offset slightly along the
  // plane normal), multithreaded with OpenMP. `casters` must hold the meshes
  // of scene.Casters() (BuildRayCaster(scene.Casters())): their bounding
  // spheres decide which rays need casting. `progress` may throw to cancel.
  LightTransport(const Scene& scene, const std::vector<Eigen::Vector3d>& points,
                 const RayCaster& casters, int map_rows, const ProgressFn& progress = {});

  const HemisphereMap& map() const { return map_; }
  size_t rows() const { return rows_; }
  int cols() const { return map_.texels(); }

  // The Lambertian factor albedo(x)/pi of a row's plane point, per channel.
  const Eigen::Vector3d& AlbedoOverPi(size_t row) const { return albedo_over_pi_[row]; }
  // max(n . w_j, 0) * dOmega_j per texel (the unoccluded geometric row).
  const Eigen::VectorXd& CosineSolidAngle() const { return cosine_solid_angle_; }

  bool Visible(size_t row, int texel) const {
    return (visible_[row * words_ + texel / 64] >> (texel % 64)) & 1u;
  }
  // Fraction of the (point, texel) pairs for which a ray was cast.
  double RayFraction() const { return ray_fraction_; }

  // The geometric row V * max(n.w, 0) * dOmega (no albedo) of `row` into out,
  // which holds cols() values.
  void GeometricRow(size_t row, double* out) const;
  // Dense channel-c matrix A_c of the listed rows (for tests and small problems).
  Eigen::MatrixXd Matrix(const std::vector<size_t>& rows, int channel) const;
  // Geometric row . radiance_c for each channel: the irradiance at the point.
  Eigen::Vector3d Irradiance(size_t row, const Eigen::MatrixX3d& radiance) const;
  // A_c row . radiance_c for each channel: the rendered plane radiance
  // (AlbedoOverPi(row) * Irradiance(row, radiance)).
  Eigen::Vector3d Render(size_t row, const Eigen::MatrixX3d& radiance) const;
  // Render() of every row, multithreaded, streaming (no dense matrix).
  std::vector<Eigen::Vector3f> RenderAll(const Eigen::MatrixX3d& radiance) const;

  // sum_r w_r T_r T_r^T over the listed rows (T = geometric rows), without
  // forming them: a row is the unoccluded row minus a few occluded texels, so
  // the cost is sum_r min(#occluded, #visible)^2 rather than rows x cols^2.
  Eigen::MatrixXd Gram(const std::vector<size_t>& rows, const Eigen::VectorXd& weights) const;
  // sum_r T_r coefficients_r^T (coefficients: one row of 3 per listed row).
  Eigen::MatrixX3d CrossProduct(const std::vector<size_t>& rows, const Eigen::MatrixX3d& coefficients) const;

  // Groups the rows with identical visibility (hence identical matrix rows):
  // returns the group of every row, groups numbered in order of their first
  // row, and that first row of each group in *first_row.
  std::vector<int> GroupIdenticalRows(std::vector<size_t>* first_row) const;

 private:
  HemisphereMap map_;
  size_t rows_ = 0;
  int words_ = 0;                   // 64-bit words per row
  std::vector<uint64_t> visible_;   // rows_ x words_, bit j of a row = V(x, w_j)
  std::vector<uint64_t> lit_;       // words_: texels above the plane's horizon
  std::vector<Eigen::Vector3d> albedo_over_pi_;  // per row
  Eigen::VectorXd cosine_solid_angle_;
  double ray_fraction_ = 0;
};

}  // namespace shadowsg
