#include "solver/sg_refine_cost.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "solver/sg_shading.h"

namespace shadowsg {

RefineCost::RefineCost(const ShadowPlaneModel& model, const std::vector<double>& weight,
                       const std::vector<Eigen::Vector3f>& targets, int lobes, bool bounce_sharpness)
    : model_(model), targets_(targets), lobes_(lobes), bounce_sharpness_(bounce_sharpness) {
  sqrt_w_.resize(weight.size());
  for (size_t k = 0; k < weight.size(); ++k) sqrt_w_[k] = std::sqrt(weight[k]);
  set_num_residuals(static_cast<int>(3 * model.points.size()));
  for (int i = 0; i < lobes; ++i) {
    mutable_parameter_block_sizes()->push_back(3);
    mutable_parameter_block_sizes()->push_back(1);
    mutable_parameter_block_sizes()->push_back(3);
  }
  cache_.resize(lobes);
}

void RefineCost::SetHints(int lobe, OccluderCones::AngleHints hints) { cache_.at(lobe).hints = std::move(hints); }

const OccluderCones::AngleHints& RefineCost::Hints(int lobe) const { return cache_.at(lobe).hints; }

void RefineCost::Update(const std::vector<Eigen::Vector3d>& axes, const std::vector<double>& lambda,
                        bool derivatives, bool need_dbounce) const {
  std::vector<int> stale, no_dbounce, need_product;
  for (int i = 0; i < lobes_; ++i) {
    LobeCache& c = cache_[i];
    if (c.axis != axes[i] || c.lambda != lambda[i]) {
      stale.push_back(i);
      c.axis = axes[i];
      c.lambda = lambda[i];
      if (model_.exact) c.exact = model_.exact->Prepare(axes[i], lambda[i]);
      c.dbounce = {};
      need_product.push_back(i);
    } else if (derivatives && !c.product_derivatives) {
      need_product.push_back(i);
    }
    if (need_dbounce && c.dbounce[0].size() == 0) no_dbounce.push_back(i);
  }
  // The exact cosine integral costs ~20 us a lobe (~90 with derivatives).
#pragma omp parallel for schedule(static) if (need_product.size() > 1)
  for (size_t q = 0; q < need_product.size(); ++q) {
    const int i = need_product[q];
    cache_[i].product = EvalProductLobe(axes[i], lambda[i], model_.normal, model_.cosine, derivatives);
    cache_[i].product_derivatives = derivatives;
  }
  auto pick = [&](const std::vector<int>& which, double log_step) {
    std::vector<Eigen::Vector3d> a;
    std::vector<double> l;
    for (int i : which) a.push_back(axes[i]), l.push_back(lambda[i] * std::exp(log_step));
    return std::make_pair(a, l);
  };
  if (!stale.empty() && !model_.exact) {
    const auto [a, l] = pick(stale, 0);
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
      for (long k = 0; k < np; ++k) c.witness[k] = witness[k * ns + s];
    }
  }
  if (!model_.bounce) return;
  // The casters' bounce, and its log-sharpness derivative by a forward
  // difference (see the header).
  constexpr double kStep = 0.02;
  if (!stale.empty()) {
    const auto [a, l] = pick(stale, 0);
    const std::array<Eigen::MatrixXf, 3> b = BounceLobeShadingRgb(model_, BounceIrradiance(model_, a, l));
    for (size_t s = 0; s < stale.size(); ++s)
      for (int ch = 0; ch < 3; ++ch) cache_[stale[s]].bounce[ch] = b[ch].col(static_cast<long>(s));
  }
  if (!no_dbounce.empty()) {
    const auto [a, l] = pick(no_dbounce, kStep);
    const std::array<Eigen::MatrixXf, 3> b = BounceLobeShadingRgb(model_, BounceIrradiance(model_, a, l));
    for (size_t s = 0; s < no_dbounce.size(); ++s) {
      LobeCache& c = cache_[no_dbounce[s]];
      for (int ch = 0; ch < 3; ++ch)
        c.dbounce[ch] = (b[ch].col(static_cast<long>(s)) - c.bounce[ch]) / static_cast<float>(kStep);
    }
  }
}

bool RefineCost::Evaluate(double const* const* params, double* residuals, double** jacobians) const {
  std::vector<Eigen::Vector3d> axes(lobes_);
  std::vector<double> lambda(lobes_);
  std::vector<Eigen::Vector3d> amp(lobes_);
  for (int i = 0; i < lobes_; ++i) {
    axes[i] = Eigen::Vector3d(params[3 * i][0], params[3 * i][1], params[3 * i][2]).normalized();
    lambda[i] = std::exp(params[3 * i + 1][0]);
    amp[i] = Eigen::Vector3d(params[3 * i + 2][0], params[3 * i + 2][1], params[3 * i + 2][2]);
  }
  const bool need_dbounce = jacobians && bounce_sharpness_ && model_.bounce;
  Update(axes, lambda, jacobians != nullptr, need_dbounce);
  const long np = static_cast<long>(model_.points.size());
#pragma omp parallel for schedule(static)
  for (long k = 0; k < np; ++k) {
    const Eigen::Vector3d rho = model_.albedo[k].cast<double>() / M_PI * sqrt_w_[k];
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (int j = 0; j < lobes_; ++j) {
      const LobeCache& lc = cache_[j];
      auto sphere_shade = [&] {
        const Eigen::Vector3d u = lc.witness[k].cast<double>();
        Eigen::Vector3d dtheta = Eigen::Vector3d::Zero();
        if (jacobians && !u.isZero()) {
          const double c = std::clamp(u.dot(axes[j]), -1.0, 1.0);
          dtheta = -u / std::max(std::sqrt(1 - c * c), 1e-9);
        }
        return ShadeLobe(lc.product, lc.theta[k], dtheta,
                         model_.cap_occlusion ? model_.occluder_cos[k] : kNoOcclusionCap);
      };
      const LobeShading s =
          model_.exact ? model_.exact->Shade(model_.exact_table->View(k), lc.exact, jacobians != nullptr)
                       : sphere_shade();
      const Eigen::Vector3d b = model_.bounce ? Eigen::Vector3d(lc.bounce[0][k], lc.bounce[1][k], lc.bounce[2][k])
                                              : Eigen::Vector3d::Zero();
      sum += (s.value + b.array()).matrix().cwiseProduct(amp[j]);
      if (!jacobians) continue;
      for (int c = 0; c < 3; ++c) {
        const long row = 3 * k + c;
        if (double* J = jacobians[3 * j]) {
          // Ceres passes the ambient 3-vector; our axis is its normalisation.
          const Eigen::Vector3d v(params[3 * j][0], params[3 * j][1], params[3 * j][2]);
          const Eigen::Vector3d g = (Eigen::Matrix3d::Identity() - axes[j] * axes[j].transpose()) *
                                    (rho[c] * amp[j][c] * s.dvalue_dmu) / v.norm();
          for (int d = 0; d < 3; ++d) J[row * 3 + d] = g[d];
        }
        if (double* J = jacobians[3 * j + 1])
          J[row] = rho[c] * amp[j][c] * (s.dvalue_dlambda * lambda[j] + (need_dbounce ? lc.dbounce[c][k] : 0.0f));
        if (double* J = jacobians[3 * j + 2])
          for (int d = 0; d < 3; ++d) J[row * 3 + d] = d == c ? rho[c] * (s.value + b[c]) : 0.0;
      }
    }
    for (int c = 0; c < 3; ++c)
      residuals[3 * k + c] = rho[c] * sum[c] - sqrt_w_[k] * targets_[k][c];
  }
  return true;
}

}  // namespace shadowsg
