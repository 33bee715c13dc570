#include "solver/caster_bounce.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>

#include "calib/error.h"
#include "solver/cosine_integral.h"
#include "solver/surface_samples.h"

namespace shadowsg {
namespace {

// A piece of surface: area, centroid and unit normal.
struct Element {
  Eigen::Vector3d centre, normal;
  double area;
};

std::vector<Element> MicroTriangles(const TriangleMesh& mesh, int target_points) {
  const SurfaceGrid grid = SampleSurfaceGrid(mesh, target_points);
  std::vector<Element> out;
  out.reserve(grid.micro_triangles.size());
  for (const Eigen::Vector3i& t : grid.micro_triangles) {
    const Eigen::Vector3d &a = grid.points[t[0]], &b = grid.points[t[1]], &c = grid.points[t[2]];
    const Eigen::Vector3d cross = (b - a).cross(c - a);
    const double area = 0.5 * cross.norm();
    if (!(area > 0)) continue;
    out.push_back({(a + b + c) / 3, cross.normalized(), area});
  }
  return out;
}

// `count` patches of one mesh's surface: k-means of its micro-triangles on
// position and normal (the normal keeps the two sides of a thin part apart),
// seeded by farthest-point sampling; deterministic. A mesh finer than its
// grid (a scan: every face is a micro-triangle) is clustered on every
// stride-th one, about `sample` of them, and all are assigned once at the
// end, so the patches still hold the whole surface: on 1.1M faces the
// seeding and 12 rounds over all of them took 4.5 s (solver/EXPERIMENTS.md,
// "Stop 59").
std::vector<Element> Cluster(const std::vector<Element>& all, int count, size_t sample) {
  double total = 0;
  for (const Element& e : all) total += e.area;
  const double radius = std::sqrt(total / (count * M_PI));
  const size_t stride = all.size() > 2 * sample ? (all.size() + sample - 1) / sample : 1;
  std::vector<Element> sampled;
  if (stride > 1)
    for (size_t i = 0; i < all.size(); i += stride) sampled.push_back(all[i]);
  const std::vector<Element>& el = stride > 1 ? sampled : all;
  auto distance2 = [&](const Element& e, const Eigen::Vector3d& c, const Eigen::Vector3d& n) {
    return (e.centre - c).squaredNorm() + radius * radius * (e.normal - n).squaredNorm();
  };
  std::vector<Eigen::Vector3d> centre, normal;
  std::vector<double> nearest(el.size(), std::numeric_limits<double>::infinity());
  size_t next = 0;
  for (int k = 0; k < count && k < static_cast<int>(el.size()); ++k) {
    centre.push_back(el[next].centre);
    normal.push_back(el[next].normal);
    double far = -1;
    for (size_t i = 0; i < el.size(); ++i) {
      nearest[i] = std::min(nearest[i], distance2(el[i], centre.back(), normal.back()));
      if (nearest[i] > far) far = nearest[i], next = i;
    }
  }
  const int m = static_cast<int>(centre.size());
  // owner[i]: the patch whose centre is nearest to elements[i].
  auto assign = [&](const std::vector<Element>& elements, std::vector<int>* owner) {
    owner->assign(elements.size(), 0);
#pragma omp parallel for schedule(static)
    for (long i = 0; i < static_cast<long>(elements.size()); ++i) {
      double best = std::numeric_limits<double>::infinity();
      for (int k = 0; k < m; ++k) {
        const double d = distance2(elements[i], centre[k], normal[k]);
        if (d < best) best = d, (*owner)[i] = k;
      }
    }
  };
  std::vector<int> owner;
  for (int iteration = 0; iteration < 12; ++iteration) {
    assign(el, &owner);
    std::vector<Eigen::Vector3d> sum_c(m, Eigen::Vector3d::Zero()), sum_n(m, Eigen::Vector3d::Zero());
    std::vector<double> sum_a(m, 0.0);
    for (size_t i = 0; i < el.size(); ++i) {
      sum_c[owner[i]] += el[i].area * el[i].centre;
      sum_n[owner[i]] += el[i].area * el[i].normal;
      sum_a[owner[i]] += el[i].area;
    }
    for (int k = 0; k < m; ++k)
      if (sum_a[k] > 0 && sum_n[k].norm() > 0) centre[k] = sum_c[k] / sum_a[k], normal[k] = sum_n[k].normalized();
  }
  if (stride > 1) assign(all, &owner);
  // A patch's effective area is its vector area |sum a n|: the flux through a
  // curved patch towards a direction it faces.
  std::vector<Element> out(m, Element{Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), 0.0});
  std::vector<Eigen::Vector3d> vector_area(m, Eigen::Vector3d::Zero());
  std::vector<double> area(m, 0.0);
  for (size_t i = 0; i < all.size(); ++i) {
    out[owner[i]].centre += all[i].area * all[i].centre;
    vector_area[owner[i]] += all[i].area * all[i].normal;
    area[owner[i]] += all[i].area;
  }
  std::vector<Element> kept;
  for (int k = 0; k < m; ++k) {
    if (!(area[k] > 0 && vector_area[k].norm() > 0)) continue;
    kept.push_back({out[k].centre / area[k], vector_area[k].normalized(), vector_area[k].norm()});
  }
  return kept;
}

std::vector<Eigen::Vector3d> FibonacciSphere(int count) {
  std::vector<Eigen::Vector3d> dirs;
  const double golden = M_PI * (3 - std::sqrt(5.0));
  for (int i = 0; i < count; ++i) {
    const double z = 1 - (2.0 * i + 1) / count;
    const double r = std::sqrt(std::max(0.0, 1 - z * z));
    dirs.emplace_back(r * std::cos(golden * i), r * std::sin(golden * i), z);
  }
  return dirs;
}

// e^{-x} I0(x) by Abramowitz & Stegun 9.8.1-9.8.2 (relative error < 2e-7):
// std::cyl_bessel_i made UpperShare 130 us a lobe, a third of the bounce
// dictionary's time.
double ScaledBesselI0(double x) {
  x = std::abs(x);
  if (x < 3.75) {
    const double t = (x / 3.75) * (x / 3.75);
    return std::exp(-x) *
           (1 + t * (3.5156229 + t * (3.0899424 + t * (1.2067492 + t * (0.2659732 + t * (0.0360768 + t * 0.0045813))))));
  }
  const double t = 3.75 / x;
  return (0.39894228 +
          t * (0.01328592 +
               t * (0.00225319 +
                    t * (-0.00157565 +
                         t * (0.00916281 + t * (-0.02057706 + t * (0.02635537 + t * (-0.01647633 + t * 0.00392377)))))))) /
         std::sqrt(x);
}

// Share of a unit SG's power above the plane, s = mu.n: exact for broad
// lobes (the power in z = w.n > 0 is 2 pi int_0^1 e^{lambda (z s - 1)}
// I0(lambda sqrt(1 - z^2) sqrt(1 - s^2)) dz), and the normal approximation of
// the lobe's elevation beyond lambda = 50, where it is good to ~1e-3.
double UpperShare(double lambda, double s) {
  s = std::clamp(s, -1.0, 1.0);
  if (lambda > 50) return 0.5 * std::erfc(-std::asin(s) * std::sqrt(lambda) / std::sqrt(2.0));
  constexpr int kSteps = 256;  // Simpson on z in [0, 1]
  const double rs = std::sqrt(1 - s * s);
  double sum = 0;
  for (int q = 0; q <= kSteps; ++q) {
    const double z = static_cast<double>(q) / kSteps;
    const double x = lambda * std::sqrt(std::max(0.0, 1 - z * z)) * rs;
    const double f = std::exp(lambda * (z * s - 1) + x) * ScaledBesselI0(x);
    sum += (q == 0 || q == kSteps ? 1 : q % 2 ? 4 : 2) * f;
  }
  const double upper = 2 * M_PI * sum / (3 * kSteps);
  return std::clamp(upper * lambda / (2 * M_PI * -std::expm1(-2 * lambda)), 0.0, 1.0);
}

}  // namespace

CasterBounce::CasterBounce(const std::vector<TriangleMesh>& world_meshes, const std::vector<Eigen::Vector3d>& albedo,
                           const RayCaster& casters, const Eigen::Vector3d& plane_point,
                           const Eigen::Vector3d& plane_normal, const CasterBounceOptions& o)
    : normal_(plane_normal.normalized()) {
  SHADOWSG_CHECK(world_meshes.size() == albedo.size());
  SHADOWSG_CHECK(o.patches >= 1 && o.directions >= 16 && o.surface_points >= 16);
  std::vector<double> areas;
  double total = 0;
  for (const TriangleMesh& m : world_meshes) total += areas.emplace_back(MeshArea(m));
  for (size_t i = 0; i < world_meshes.size(); ++i) {
    if (!(areas[i] > 0)) continue;
    const double share = areas[i] / total;
    const int count = std::max(1, static_cast<int>(std::lround(o.patches * share)));
    const int points = std::max(count * 8, static_cast<int>(o.surface_points * share));
    const std::vector<Element> el = MicroTriangles(world_meshes[i], points);
    // A grid of n points has about 2n micro-triangles.
    for (const Element& e : Cluster(el, count, 2 * static_cast<size_t>(points)))
      patches_.push_back({e.centre, e.normal, e.area, (albedo[i] / M_PI).cast<float>()});
  }
  dirs_ = FibonacciSphere(o.directions);
  // Lobes sharper than one direction cell are widened to it for v_ij.
  max_weight_sharpness_ = o.directions / (4 * M_PI);
  const long m = static_cast<long>(patches_.size()), nd = static_cast<long>(dirs_.size());

  // The ground grid: log-polar about the casters' foot on the plane.
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo, foot = Eigen::Vector3d::Zero();
  double area = 0;
  for (const Patch& p : patches_) {
    lo = lo.cwiseMin(p.centre), hi = hi.cwiseMax(p.centre);
    foot += p.area * p.centre, area += p.area;
  }
  foot /= std::max(area, 1e-300);
  foot -= normal_.dot(foot - plane_point) * normal_;
  const double size = std::max((hi - lo).norm(), 1e-9);
  const double r_min = 0.01 * size, ratio = std::pow(3000.0, 1.0 / std::max(1, o.ground_rings - 1));
  Eigen::Vector3d t, b;
  t = normal_.unitOrthogonal(), b = normal_.cross(t);
  ground_.push_back(foot);
  for (int r = 0; r < o.ground_rings; ++r)
    for (int a = 0; a < o.ground_sectors; ++a) {
      const double radius = r_min * std::pow(ratio, r), phi = 2 * M_PI * a / o.ground_sectors;
      ground_.push_back(foot + radius * (std::cos(phi) * t + std::sin(phi) * b));
    }
  auto ground_node = [&](const Eigen::Vector3d& x) {
    const Eigen::Vector3d d = x - foot;
    const double radius = d.norm();
    if (radius < r_min / std::sqrt(ratio)) return 0;
    const int ring = std::clamp(static_cast<int>(std::lround(std::log(radius / r_min) / std::log(ratio))), 0,
                                o.ground_rings - 1);
    const double phi = std::atan2(d.dot(b), d.dot(t));
    const int sector = static_cast<int>(std::lround(phi / (2 * M_PI) * o.ground_sectors + o.ground_sectors)) %
                       o.ground_sectors;
    return 1 + ring * o.ground_sectors + sector;
  };

  visible_cos_ = Eigen::MatrixXf::Zero(m, nd);
  upper_cos_ = Eigen::MatrixXf::Zero(m, nd);
  ground_weight_ = Eigen::MatrixXf::Zero(m, static_cast<long>(ground_.size()));
  const double cell = 4 * M_PI / nd;  // solid angle of one direction
#pragma omp parallel for schedule(dynamic, 4)
  for (long j = 0; j < m; ++j) {
    const Patch& p = patches_[j];
    // Off the surface by a quarter of the patch's radius: a curved patch's
    // centroid lies inside a convex surface by its sagitta.
    const Eigen::Vector3d origin = p.centre + 0.25 * std::sqrt(p.area / M_PI) * p.normal;
    std::vector<Eigen::Vector3d> facing;
    std::vector<long> index;
    for (long k = 0; k < nd; ++k)
      if (p.normal.dot(dirs_[k]) > 0) facing.push_back(dirs_[k]), index.push_back(k);
    std::vector<char> visible;
    casters.Visible(origin, facing, 0, &visible);
    for (size_t q = 0; q < facing.size(); ++q) {
      const long k = index[q];
      const double c = p.normal.dot(dirs_[k]), up = dirs_[k].dot(normal_);
      if (up > 0) {
        upper_cos_(j, k) = static_cast<float>(c);
        if (visible[q]) visible_cos_(j, k) = static_cast<float>(c);
      } else if (visible[q] && up < 0) {  // reaches the plane: the second bounce
        const double hit = normal_.dot(plane_point - origin) / up;
        if (hit > 0) ground_weight_(j, ground_node(origin + hit * dirs_[k])) += static_cast<float>(c * cell / M_PI);
      }
    }
  }
}

std::array<Eigen::MatrixXf, 3> CasterBounce::Irradiance(const std::vector<Eigen::Vector3d>& axes,
                                                        const std::vector<double>& sharpness,
                                                        const std::array<Eigen::MatrixXf, 3>* ground_radiance) const {
  SHADOWSG_CHECK(axes.size() == sharpness.size());
  const long nl = static_cast<long>(axes.size()), nd = static_cast<long>(dirs_.size());
  Eigen::MatrixXf weight(nd, nl);
  for (long i = 0; i < nl; ++i) {
    const double lw = std::min(sharpness[i], max_weight_sharpness_);
    const Eigen::Vector3d mu = axes[i].normalized();
    for (long k = 0; k < nd; ++k) weight(k, i) = static_cast<float>(std::exp(lw * (dirs_[k].dot(mu) - 1)));
  }
  // v = (share of the widened lobe the casters leave open, among the
  // directions above the plane) x (share of the true lobe above the plane):
  // widening a low sun would otherwise push half of it below the horizon.
  const Eigen::MatrixXf num = RowParallelProduct(visible_cos_, weight), den = RowParallelProduct(upper_cos_, weight);
  std::vector<double> upper(nl);
#pragma omp parallel for schedule(static) if (nl > 16)
  for (long i = 0; i < nl; ++i) upper[i] = UpperShare(sharpness[i], axes[i].normalized().dot(normal_));
  Eigen::MatrixXf e(static_cast<long>(patches_.size()), nl);
#pragma omp parallel for schedule(static) if (nl > 16)
  for (long j = 0; j < e.rows(); ++j)
    for (long i = 0; i < nl; ++i) {
      const double v = den(j, i) > 0 ? upper[i] * num(j, i) / den(j, i) : 0.0;
      e(j, i) = static_cast<float>(v * SgCosineIntegralTabulated(sharpness[i], axes[i].normalized().dot(patches_[j].normal)));
    }
  std::array<Eigen::MatrixXf, 3> out = {e, e, e};
  if (ground_radiance)
    for (int c = 0; c < 3; ++c) out[c] += RowParallelProduct(ground_weight_, (*ground_radiance)[c]);
  return out;
}

Eigen::MatrixXf CasterBounce::FormFactors(const std::vector<Eigen::Vector3d>& points) const {
  const long n = static_cast<long>(points.size()), m = static_cast<long>(patches_.size());
  Eigen::MatrixXf k(n, m);
  // Column by column (k is column-major) over the points' coordinates laid
  // out apart, so each patch's pass is contiguous and vectorises; row by row
  // it wrote one float per column, n floats apart.
  Eigen::Matrix<double, Eigen::Dynamic, 3> xyz(n, 3);
  for (long r = 0; r < n; ++r) xyz.row(r) = points[r].transpose();
  const double* px = xyz.col(0).data();
  const double* py = xyz.col(1).data();
  const double* pz = xyz.col(2).data();
  const double ux = normal_.x(), uy = normal_.y(), uz = normal_.z();
#pragma omp parallel for schedule(static)
  for (long j = 0; j < m; ++j) {
    const Patch& p = patches_[j];
    const double cx = p.centre.x(), cy = p.centre.y(), cz = p.centre.z();
    const double nx = p.normal.x(), ny = p.normal.y(), nz = p.normal.z();
    const double area = p.area, disk = p.area / M_PI;
    float* col = k.col(j).data();
    for (long r = 0; r < n; ++r) {
      const double vx = cx - px[r], vy = cy - py[r], vz = cz - pz[r];
      // A point at a patch's centre: 0 / 0 there, 0 as the test gave before.
      const double d2 = std::max(vx * vx + vy * vy + vz * vz, std::numeric_limits<double>::min());
      const double up = ux * vx + uy * vy + uz * vz, facing = -(nx * vx + ny * vy + nz * vz);
      // cos_x cos_j / d^2 = up facing / d^4, with the disk's area term; zero
      // where the patch faces away or lies below the plane. (Clamped by max,
      // not selected by a test: GCC keeps a comparison that may trap out of a
      // vectorised loop.)
      col[r] = static_cast<float>(std::max(up, 0.0) * std::max(facing, 0.0) / d2 * area / (d2 + disk));
    }
  }
  return k;
}

FactoredFormFactors FactorFormFactors(Eigen::MatrixXf k, double tolerance) {
  SHADOWSG_CHECK(tolerance >= 0);
  FactoredFormFactors f;
  const long m = k.cols();
  if (k.rows() <= m || m == 0) {
    f.left = std::move(k);
    return f;
  }
  const Eigen::MatrixXd gram = ColumnParallelTransposeProduct<float>(k, k).cast<double>();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(gram);
  // Eigenvalues ascending: the residual of a rank-r basis holds the smallest m - r.
  const Eigen::VectorXd ev = eig.eigenvalues().cwiseMax(0.0);
  const double budget = tolerance * tolerance * ev.sum();
  long dropped = 0;
  for (double tail = 0; dropped < m && tail + ev[dropped] <= budget; ++dropped) tail += ev[dropped];
  const long rank = m - dropped;
  if (rank > m / 2) {  // two products of rank r cost as much as one of m at r = m / 2
    f.left = std::move(k);
    return f;
  }
  f.basis = eig.eigenvectors().rightCols(rank).transpose().cast<float>();
  f.left = RowParallelProduct(k, f.basis.transpose());
  return f;
}

std::vector<Eigen::Vector3f> CasterBounce::Gather(const std::vector<Eigen::Vector3d>& points,
                                                  const Eigen::MatrixXf& patch_radiance) const {
  constexpr size_t kChunk = 4096;
  std::vector<Eigen::Vector3f> out(points.size());
  for (size_t begin = 0; begin < points.size(); begin += kChunk) {
    const size_t end = std::min(points.size(), begin + kChunk);
    const Eigen::MatrixXf k = FormFactors(std::vector<Eigen::Vector3d>(points.begin() + begin, points.begin() + end));
    const Eigen::MatrixXf b = RowParallelProduct(k, patch_radiance);
    for (size_t r = begin; r < end; ++r) out[r] = b.row(static_cast<long>(r - begin)).transpose();
  }
  return out;
}

}  // namespace shadowsg
