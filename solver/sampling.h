// Monte Carlo building blocks for the renderers: a counter-based random
// stream (the same numbers for a pixel whatever the thread count), piecewise-
// constant distributions, and direction sampling with matching densities.
// Densities are per unit solid angle unless the name says otherwise.
#pragma once

#include <Eigen/Dense>
#include <cstdint>
#include <vector>

namespace shadowsg {

// SplitMix64 finaliser (Steele, Lea, Flood, "Fast splittable pseudorandom
// number generators", OOPSLA 2014): a bijective 64-bit mix.
uint64_t Mix64(uint64_t x);

// A stream of uniform numbers in [0, 1) determined only by (seed, pixel,
// sample): the i-th draw is Mix64 of the stream key and i. No state is shared
// between streams, so results do not depend on scheduling.
class RandomStream {
 public:
  RandomStream(uint64_t seed, uint64_t pixel, uint64_t sample);
  double Uniform();
  Eigen::Vector2d Uniform2() { return {Uniform(), Uniform()}; }

 private:
  uint64_t key_;
  uint64_t counter_ = 0;
};

// Piecewise-constant density on [0, 1) over n equal cells, proportional to
// non-negative weights (all-zero weights give the uniform density).
class Distribution1D {
 public:
  Distribution1D() = default;
  explicit Distribution1D(const std::vector<double>& weights);
  // Continuous sample in [0, 1); *pdf is the density there, *cell its cell.
  double Sample(double u, double* pdf, int* cell) const;
  // Discrete choice of a cell with probability weight / total.
  int SampleDiscrete(double u, double* probability) const;
  double CellProbability(int cell) const;
  double Density(int cell) const { return CellProbability(cell) * size(); }
  int size() const { return static_cast<int>(cdf_.size()) - 1; }
  double total() const { return total_; }

 private:
  std::vector<double> weights_;
  std::vector<double> cdf_;  // size n + 1, cdf_[0] = 0, cdf_[n] = 1
  double total_ = 0;
};

// Piecewise-constant density on [0, 1)^2 over a rows x cols grid (row-major
// weights): a marginal over rows and one conditional per row.
class Distribution2D {
 public:
  Distribution2D() = default;
  Distribution2D(const std::vector<double>& weights, int cols, int rows);
  // Returns (x, y) in [0, 1)^2 (x along columns) and the density there.
  Eigen::Vector2d Sample(const Eigen::Vector2d& u, double* pdf) const;
  double Density(const Eigen::Vector2d& xy) const;
  bool empty() const { return rows_ == 0; }
  double total() const { return marginal_.total(); }

 private:
  int cols_ = 0, rows_ = 0;
  std::vector<Distribution1D> conditional_;
  Distribution1D marginal_;
};

// An orthonormal frame (t, b, n) around unit n (Duff et al., "Building an
// orthonormal basis, revisited", JCGT 6(1) 2017).
void OrthonormalBasis(const Eigen::Vector3d& n, Eigen::Vector3d* t, Eigen::Vector3d* b);

// Cosine-weighted direction around unit n; density cos / pi.
Eigen::Vector3d SampleCosineHemisphere(const Eigen::Vector3d& n, const Eigen::Vector2d& u);

// Uniform direction in the cone of half-angle `angle` around unit axis;
// density 1 / (2 pi (1 - cos angle)).
Eigen::Vector3d SampleUniformCone(const Eigen::Vector3d& axis, double angle, const Eigen::Vector2d& u);
double UniformConePdf(double angle);

// Von Mises-Fisher direction (density proportional to exp(k (w.axis - 1)),
// the shape of an SG lobe of sharpness k); Jakob, "Numerically stable sampling
// of the von Mises-Fisher distribution on S^2", 2012.
Eigen::Vector3d SampleVmf(const Eigen::Vector3d& axis, double kappa, const Eigen::Vector2d& u);
double VmfPdf(const Eigen::Vector3d& axis, double kappa, const Eigen::Vector3d& dir);

// Veach's power heuristic (beta = 2) for one sample of each of two strategies.
inline double PowerHeuristic(double pdf_a, double pdf_b) {
  const double a = pdf_a * pdf_a, b = pdf_b * pdf_b;
  return a + b > 0 ? a / (a + b) : 0.0;
}

}  // namespace shadowsg
