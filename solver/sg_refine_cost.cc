#include "solver/sg_refine_cost.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <vector>

#include "calib/error.h"
#include "solver/row_parallel_product.h"
#include "solver/sg_shading.h"

namespace shadowsg {

RefineCost::RefineCost(const ShadowPlaneModel& model, const std::vector<double>& weight,
                       const std::vector<Eigen::Vector3f>& targets, int lobes, bool bounce_sharpness)
    : model_(model), targets_(targets), lobes_(lobes), bounce_sharpness_(bounce_sharpness) {
  SHADOWSG_CHECK(weight.size() == model.points.size() && targets.size() == model.points.size());
  sqrt_w_.resize(weight.size());
  for (size_t k = 0; k < weight.size(); ++k) sqrt_w_[k] = std::sqrt(weight[k]);
  cache_.resize(lobes);
}

std::array<Eigen::Vector3d, 2> TangentBasis(const Eigen::Vector3d& a) {
  // The Householder reflection H with H e_z = a, as Ceres' SphereManifold
  // builds it (ceres/internal/householder_vector.h); its first two columns.
  const double sigma = a.head<2>().squaredNorm(), pivot = a.z();
  Eigen::Vector3d v(a.x(), a.y(), 1.0);
  double beta = 0;
  if (sigma <= std::numeric_limits<double>::epsilon()) {
    if (pivot < 0) beta = 2;
  } else {
    const double mu = std::sqrt(pivot * pivot + sigma);
    const double v_pivot = pivot <= 0 ? pivot - mu : -sigma / (pivot + mu);
    beta = 2 * v_pivot * v_pivot / (sigma + v_pivot * v_pivot);
    v.head<2>() /= v_pivot;
  }
  return {Eigen::Vector3d::UnitX() - beta * v.x() * v, Eigen::Vector3d::UnitY() - beta * v.y() * v};
}

Eigen::Vector3d TurnAxis(const Eigen::Vector3d& a, double d1, double d2) {
  const auto t = TangentBasis(a);
  const Eigen::Vector3d d = d1 * t[0] + d2 * t[1];
  const double length = d.norm();
  if (!(length > 0)) return a;
  return (std::cos(length / 2) * a + std::sin(length / 2) / length * d).normalized();
}

void RefineCost::SetHints(int lobe, OccluderCones::AngleHints hints) { cache_.at(lobe).hints = std::move(hints); }

const OccluderCones::AngleHints& RefineCost::Hints(int lobe) const { return cache_.at(lobe).hints; }

namespace {

// The axes and sharpness (times exp(log_step)) of the lobes `which`.
std::pair<std::vector<Eigen::Vector3d>, std::vector<double>> Pick(const std::vector<Eigen::Vector3d>& axes,
                                                                  const std::vector<double>& lambda,
                                                                  const std::vector<int>& which, double log_step) {
  std::vector<Eigen::Vector3d> a;
  std::vector<double> l;
  for (int i : which) a.push_back(axes[i]), l.push_back(lambda[i] * std::exp(log_step));
  return {a, l};
}

}  // namespace

void RefineCost::Update(const std::vector<Eigen::Vector3d>& axes, const std::vector<double>& lambda,
                        bool derivatives, bool need_dbounce) const {
  std::vector<int> stale, need_product;
  for (int i = 0; i < lobes_; ++i) {
    LobeCache& c = cache_[i];
    if (c.axis != axes[i] || c.lambda != lambda[i]) {
      stale.push_back(i);
      c.axis = axes[i];
      c.lambda = lambda[i];
      if (model_.exact) c.exact = model_.exact->Prepare(axes[i], lambda[i]);
      need_product.push_back(i);
    } else if (derivatives && !c.product_derivatives) {
      need_product.push_back(i);
    }
  }
  // The exact cosine integral costs ~20 us a lobe (~90 with derivatives).
#pragma omp parallel for schedule(static) if (need_product.size() > 1)
  for (size_t q = 0; q < need_product.size(); ++q) {
    const int i = need_product[q];
    cache_[i].product =
        EvalProductLobe(axes[i], lambda[i], model_.normal, model_.cosine, derivatives, model_.max_steepness);
    cache_[i].product_derivatives = derivatives;
  }
  if (!stale.empty() && !model_.exact) {
    const auto [a, l] = Pick(axes, lambda, stale, 0);
    std::vector<float> caps;
    for (int i : stale) caps.push_back(VisibilityCap(cache_[i].product));
    Eigen::MatrixXf theta;
    std::vector<Eigen::Vector3f> witness;
    // A step moves an axis a little: what its last search learnt skips the
    // points it left far from every occluder and bounds the others' search
    // from the start (same theta, fewer nodes visited).
    std::vector<OccluderCones::AngleHints*> lobe_hints;
    for (int i : stale) lobe_hints.push_back(&cache_[i].hints);
    PlaneAngles(model_, a, caps, &theta, &witness, lobe_hints);
    const long np = theta.rows(), ns = static_cast<long>(stale.size());
    for (long s = 0; s < ns; ++s) {
      LobeCache& c = cache_[stale[s]];
      c.theta = theta.col(s);
      c.witness.resize(np);
    }
    // Points x lobes to per lobe, a block of points per thread.
#pragma omp parallel for schedule(static) if (np * ns > 16384)
    for (long k = 0; k < np; ++k)
      for (long s = 0; s < ns; ++s) cache_[stale[s]].witness[k] = witness[k * ns + s];
  }
  if (model_.bounce) UpdateBounce(axes, lambda, derivatives, need_dbounce);
}

void RefineCost::UpdateBounce(const std::vector<Eigen::Vector3d>& axes, const std::vector<double>& lambda,
                              bool derivatives, bool need_dbounce) const {
  std::vector<int> stale, no_dbounce;
  for (int i = 0; i < lobes_; ++i) {
    LobeCache& c = cache_[i];
    if (c.bounce_axis != axes[i] || c.bounce_lambda != lambda[i]) {
      stale.push_back(i);
      c.bounce_axis = axes[i];
      c.bounce_lambda = lambda[i];
      c.dbounce = {};
    }
    if (need_dbounce && c.dbounce[0].size() == 0) no_dbounce.push_back(i);
  }
  // The casters' bounce, and its log-sharpness derivative by a forward
  // difference (see the header).
  constexpr double kStep = 0.02;
  const bool lazy = model_.HasBounceForm();
  if (!stale.empty()) {
    const auto [a, l] = Pick(axes, lambda, stale, 0);
    std::vector<OccluderCones::AngleHints> ground_hints;
    for (int i : stale) ground_hints.push_back(std::move(cache_[i].ground_hints));
    const std::array<Eigen::MatrixXf, 3> irradiance = BounceIrradiance(model_, a, l, &ground_hints);
    const long ns = static_cast<long>(stale.size());
    if (lazy) {
      const Eigen::MatrixXf y = model_.bounce_form.Reduce(BouncePatchRadianceRgb(model_, irradiance));
      for (long s = 0; s < ns; ++s) {
        LobeCache& c = cache_[stale[s]];
        for (int ch = 0; ch < 3; ++ch) {
          c.reduced[ch] = y.col(ch * ns + s);
          c.bounce[ch].resize(0);
        }
      }
    } else {
      const Eigen::MatrixXf b = BounceLobeShadingRgb(model_, irradiance);
      for (long s = 0; s < ns; ++s)
        for (int ch = 0; ch < 3; ++ch) cache_[stale[s]].bounce[ch] = b.col(ch * ns + s);
    }
    for (long s = 0; s < ns; ++s) cache_[stale[s]].ground_hints = std::move(ground_hints[s]);
  }
  if (lazy && derivatives) {
    // Each lobe's bounce at the points, for the Jacobian: one product.
    std::vector<int> todo;
    for (int i = 0; i < lobes_; ++i)
      if (cache_[i].bounce[0].size() == 0) todo.push_back(i);
    const long nt = static_cast<long>(todo.size());
    if (nt > 0) {
      Eigen::MatrixXf y(model_.bounce_form.rank(), 3 * nt);
      for (long t = 0; t < nt; ++t)
        for (int ch = 0; ch < 3; ++ch) y.col(ch * nt + t) = cache_[todo[t]].reduced[ch];
      const Eigen::MatrixXf b = model_.bounce_form.Expand(y);
      for (long t = 0; t < nt; ++t)
        for (int ch = 0; ch < 3; ++ch) cache_[todo[t]].bounce[ch] = b.col(ch * nt + t);
    }
  }
  if (!no_dbounce.empty()) {
    const auto [a, l] = Pick(axes, lambda, no_dbounce, kStep);
    const Eigen::MatrixXf b = BounceLobeShadingRgb(model_, BounceIrradiance(model_, a, l));
    const long nd = static_cast<long>(no_dbounce.size());
    for (long s = 0; s < nd; ++s) {
      LobeCache& c = cache_[no_dbounce[static_cast<size_t>(s)]];
      for (int ch = 0; ch < 3; ++ch) c.dbounce[ch] = (b.col(ch * nd + s) - c.bounce[ch]) / static_cast<float>(kStep);
    }
  }
}

bool RefineCost::CostExceeds(const std::vector<SgLobe>& lobes, double limit) const {
  SHADOWSG_CHECK(static_cast<int>(lobes.size()) == lobes_);
  if (model_.exact || !model_.HasCones()) return false;
  const long np = points();
  // The fit sets' points come in random order (solver/sg_solver.cc), so a
  // prefix is a sample: 16 chunks would cover them all.
  const long chunk = std::max<long>(64, np / 16), stop = np / 4;
  std::vector<ProductLobe> products(lobes_);
  std::vector<Eigen::Vector3d> axes(lobes_);
  std::vector<float> caps(lobes_);
  for (int j = 0; j < lobes_; ++j) {
    axes[j] = lobes[j].axis;
    products[j] =
        EvalProductLobe(axes[j], lobes[j].sharpness, model_.normal, model_.cosine, false, model_.max_steepness);
    caps[j] = VisibilityCap(products[j]);
  }
  // The lobes' bounce at the points, summed (as Evaluate's residuals have it).
  Eigen::MatrixXf bounce;
  if (model_.bounce) {
    std::vector<double> lambda(lobes_);
    for (int j = 0; j < lobes_; ++j) lambda[j] = lobes[j].sharpness;
    UpdateBounce(axes, lambda, false, false);
    if (model_.HasBounceForm()) {
      Eigen::MatrixXf y = Eigen::MatrixXf::Zero(model_.bounce_form.rank(), 3);
      for (int j = 0; j < lobes_; ++j)
        for (int c = 0; c < 3; ++c) y.col(c) += static_cast<float>(lobes[j].amplitude[c]) * cache_[j].reduced[c];
      bounce = RowParallelProduct(model_.bounce_form.left.topRows(stop), y);
    } else {
      bounce = Eigen::MatrixXf::Zero(stop, 3);
      for (int j = 0; j < lobes_; ++j)
        for (int c = 0; c < 3; ++c)
          bounce.col(c) += static_cast<float>(lobes[j].amplitude[c]) * cache_[j].bounce[c].head(stop);
    }
  }
  double cost = 0;
  for (long begin = 0; begin < stop; begin += chunk) {
    const long end = std::min(begin + chunk, stop);
    Eigen::MatrixXf theta;
    model_.cones.AnglesOfRange(axes, static_cast<size_t>(begin), static_cast<size_t>(end), &theta, &caps,
                               CapSides::kBoth);
    // Summed in fixed blocks, in order: the same rounding on any number of
    // threads (an OpenMP reduction adds the threads' partial sums).
    constexpr long kBlock = 64;
    const long blocks = (end - begin + kBlock - 1) / kBlock;
    std::vector<double> block_sum(static_cast<size_t>(blocks), 0.0);
#pragma omp parallel for schedule(static)
    for (long b = 0; b < blocks; ++b) {
      const long first = begin + b * kBlock, last = std::min(end, first + kBlock);
      double sum = 0;
      for (long k = first; k < last; ++k) {
        Eigen::Vector3d direct = Eigen::Vector3d::Zero();
        for (int j = 0; j < lobes_; ++j)
          direct += ShadeLobe(products[j], theta(k - begin, j), Eigen::Vector3d::Zero(),
                              model_.cap_occlusion ? model_.occluder_cos[k] : kNoOcclusionCap)
                        .value *
                    lobes[j].amplitude;
        if (bounce.size()) direct += bounce.row(k).transpose().cast<double>();
        for (int c = 0; c < 3; ++c) {
          const double r = model_.albedo[k][c] / M_PI * sqrt_w_[k] * direct[c] - sqrt_w_[k] * targets_[k][c];
          sum += r * r;
        }
      }
      block_sum[b] = sum;
    }
    double sum_sq = 0;
    for (double part : block_sum) sum_sq += part;
    cost += 0.5 * sum_sq;
    if (cost > limit) return true;
    // The quarter would not get there at this rate: no proof to wait for.
    if (cost * static_cast<double>(stop) / static_cast<double>(end) < 0.5 * limit) return false;
  }
  return false;
}

void RefineCost::Evaluate(const std::vector<SgLobe>& lobes, Eigen::MatrixX3d* residuals,
                          RefineJacobian* jacobian) const {
  SHADOWSG_CHECK(static_cast<int>(lobes.size()) == lobes_);
  std::vector<Eigen::Vector3d> axes(lobes_);
  std::vector<double> lambda(lobes_);
  std::vector<std::array<Eigen::Vector3d, 2>> tangent(lobes_);
  for (int i = 0; i < lobes_; ++i) {
    axes[i] = lobes[i].axis;
    lambda[i] = lobes[i].sharpness;
    if (jacobian) tangent[i] = TangentBasis(axes[i]);
  }
  const bool need_dbounce = jacobian && bounce_sharpness_ && model_.bounce;
  Update(axes, lambda, jacobian != nullptr, need_dbounce);
  const long np = points();
  residuals->resize(np, 3);
  if (jacobian)
    for (Eigen::MatrixXd& J : jacobian->channel) J.resize(np, 4 * lobes_);
  // Form factors prepared: the lobes' bounce summed in the basis and carried
  // to the points once (see the header), for every evaluation's residuals,
  // with or without the Jacobian, so that LM compares costs rounded one way.
  const bool summed = model_.bounce && model_.HasBounceForm();
  Eigen::MatrixXf bounce_sum;
  if (summed) {
    Eigen::MatrixXf y = Eigen::MatrixXf::Zero(model_.bounce_form.rank(), 3);
    for (int j = 0; j < lobes_; ++j)
      for (int c = 0; c < 3; ++c) y.col(c) += static_cast<float>(lobes[j].amplitude[c]) * cache_[j].reduced[c];
    bounce_sum = model_.bounce_form.Expand(y);
  }
#pragma omp parallel for schedule(static)
  for (long k = 0; k < np; ++k) {
    const Eigen::Vector3d rho = model_.albedo[k].cast<double>() / M_PI * sqrt_w_[k];
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (int j = 0; j < lobes_; ++j) {
      const LobeCache& lc = cache_[j];
      auto sphere_shade = [&] {
        const Eigen::Vector3d u = lc.witness[k].cast<double>();
        Eigen::Vector3d dtheta = Eigen::Vector3d::Zero();
        if (jacobian && !u.isZero()) {
          const double c = std::clamp(u.dot(axes[j]), -1.0, 1.0);
          dtheta = -u / std::max(std::sqrt(1 - c * c), 1e-9);
        }
        return ShadeLobe(lc.product, lc.theta[k], dtheta,
                         model_.cap_occlusion ? model_.occluder_cos[k] : kNoOcclusionCap);
      };
      const LobeShading s =
          model_.exact ? model_.exact->Shade(model_.exact_table->View(k), lc.exact, jacobian != nullptr)
                       : sphere_shade();
      // Each lobe's own bounce: in the residual unless summed, in the Jacobian.
      const Eigen::Vector3d b = model_.bounce && (!summed || jacobian)
                                    ? Eigen::Vector3d(lc.bounce[0][k], lc.bounce[1][k], lc.bounce[2][k])
                                    : Eigen::Vector3d::Zero();
      const Eigen::Vector3d& a = lobes[j].amplitude;
      sum += (s.value + (summed ? Eigen::Vector3d::Zero() : b).array()).matrix().cwiseProduct(a);
      if (!jacobian) continue;
      // The shading's gradient in mu along the tangent basis, halved: a
      // tangent step turns the axis by half its length (TurnAxis).
      const double d_t1 = 0.5 * tangent[j][0].dot(s.dvalue_dmu), d_t2 = 0.5 * tangent[j][1].dot(s.dvalue_dmu);
      for (int c = 0; c < 3; ++c) {
        Eigen::MatrixXd& J = jacobian->channel[c];
        const double ra = rho[c] * a[c];
        J(k, 3 * j) = ra * d_t1;
        J(k, 3 * j + 1) = ra * d_t2;
        J(k, 3 * j + 2) = ra * (s.dvalue_dlambda * lambda[j] + (need_dbounce ? lc.dbounce[c][k] : 0.0f));
        J(k, 3 * lobes_ + j) = rho[c] * (s.value + b[c]);
      }
    }
    if (summed) sum += bounce_sum.row(k).transpose().cast<double>();
    for (int c = 0; c < 3; ++c) (*residuals)(k, c) = rho[c] * sum[c] - sqrt_w_[k] * targets_[k][c];
  }
}

std::vector<OccluderCones::AngleHints> NearestAxisHints(const std::vector<SgLobe>& lobes,
                                                        const std::vector<SgLobe>& from,
                                                        const std::vector<OccluderCones::AngleHints>& from_hints) {
  std::vector<OccluderCones::AngleHints> hints(lobes.size());
  if (from_hints.size() != from.size()) return hints;
  for (size_t i = 0; i < lobes.size() && !from.empty(); ++i) {
    const Eigen::Vector3d axis = lobes[i].axis.normalized();
    size_t nearest = 0;
    for (size_t j = 1; j < from.size(); ++j)
      if (axis.dot(from[j].axis.normalized()) > axis.dot(from[nearest].axis.normalized())) nearest = j;
    hints[i] = from_hints[nearest];  // one copy: a lobe's hints are 12 bytes a point
  }
  return hints;
}

}  // namespace shadowsg
