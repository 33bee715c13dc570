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
}

bool RefineCost::Evaluate(double const* const* params, double* residuals, double** jacobians) const {
  std::vector<Eigen::Vector3d> axes(lobes_);
  std::vector<double> lambda(lobes_);
  std::vector<Eigen::Vector3d> amp(lobes_);
  std::vector<ProductLobe> products(lobes_);
  for (int i = 0; i < lobes_; ++i) {
    axes[i] = Eigen::Vector3d(params[3 * i][0], params[3 * i][1], params[3 * i][2]).normalized();
    lambda[i] = std::exp(params[3 * i + 1][0]);
    amp[i] = Eigen::Vector3d(params[3 * i + 2][0], params[3 * i + 2][1], params[3 * i + 2][2]);
    products[i] = EvalProductLobe(axes[i], lambda[i], model_.normal, model_.cosine);
  }
  Eigen::MatrixXf theta;
  std::vector<Eigen::Vector3f> witness;
  std::vector<float> caps;
  for (const ProductLobe& p : products) caps.push_back(VisibilityCap(p));
  if (!model_.exact) PlaneAngles(model_, axes, caps, &theta, &witness);
  std::vector<ExactVisibility::Lobe> exact_lobes;
  if (model_.exact)
    for (int i = 0; i < lobes_; ++i) exact_lobes.push_back(model_.exact->Prepare(axes[i], lambda[i]));
  const long np = static_cast<long>(model_.points.size());
  // The casters' bounce of each lobe per channel, and its log-sharpness
  // derivative by a forward difference (see the header).
  std::array<Eigen::MatrixXf, 3> bounce, dbounce;
  if (model_.bounce) {
    bounce = BounceLobeShadingRgb(model_, BounceIrradiance(model_, axes, lambda));
    if (jacobians && bounce_sharpness_) {
      constexpr double kStep = 0.02;
      std::vector<double> lambda2(lambda);
      for (double& l : lambda2) l *= std::exp(kStep);
      dbounce = BounceLobeShadingRgb(model_, BounceIrradiance(model_, axes, lambda2));
      for (int c = 0; c < 3; ++c) dbounce[c] = (dbounce[c] - bounce[c]) / static_cast<float>(kStep);
    }
  }
#pragma omp parallel for schedule(static)
  for (long k = 0; k < np; ++k) {
    const Eigen::Vector3d rho = model_.albedo[k].cast<double>() / M_PI * sqrt_w_[k];
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (int j = 0; j < lobes_; ++j) {
      auto sphere_shade = [&] {
        const Eigen::Vector3d u = witness[k * lobes_ + j].cast<double>();
        Eigen::Vector3d dtheta = Eigen::Vector3d::Zero();
        if (jacobians && !u.isZero()) {
          const double c = std::clamp(u.dot(axes[j]), -1.0, 1.0);
          dtheta = -u / std::max(std::sqrt(1 - c * c), 1e-9);
        }
        return ShadeLobe(products[j], theta(k, j), dtheta,
                         model_.cap_occlusion ? model_.occluder_cos[k] : kNoOcclusionCap);
      };
      const LobeShading s =
          model_.exact ? model_.exact->Shade(model_.exact_table->View(k), exact_lobes[j], jacobians != nullptr)
                       : sphere_shade();
      const Eigen::Vector3d b = model_.bounce ? Eigen::Vector3d(bounce[0](k, j), bounce[1](k, j), bounce[2](k, j))
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
          J[row] = rho[c] * amp[j][c] * (s.dvalue_dlambda * lambda[j] + (dbounce[c].size() ? dbounce[c](k, j) : 0.0));
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
