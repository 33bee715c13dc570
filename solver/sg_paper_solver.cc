#include "solver/sg_paper_solver.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <random>

#include "calib/conventions.h"

namespace shadowsg {

bool SgPaperOptions::IsValid(std::string* error) const {
  auto fail = [&](const std::string& e) {
    if (error) *error = e;
    return false;
  };
  if (lobes < 1 || lobes > 100000) return fail("lobes must be in 1..100000");
  if (steps < 0) return fail("steps must be >= 0");
  if (batch < 1) return fail("batch must be >= 1");
  if (!(learning_rate > 0)) return fail("learning rate must be positive");
  if (lr_decay_every < 1 || prune_every < 1) return fail("schedules must be >= 1");
  return true;
}

std::vector<Eigen::Vector3d> FibonacciHemisphereAxes(int count, const Eigen::Vector3d& normal) {
  // Fibonacci sphere in the plane's frame (z = normal), mirrored to z >= 0.
  const Eigen::Matrix3d to_world = MinimalRotationToZ(normal).transpose();
  const double golden = M_PI * (3 - std::sqrt(5.0));
  std::vector<Eigen::Vector3d> axes;
  for (int i = 0; i < count; ++i) {
    const double z = count > 1 ? 1 - 2.0 * i / (count - 1) : 1.0;
    const double r = std::sqrt(std::max(0.0, 1 - z * z));
    Eigen::Vector3d a(r * std::cos(golden * i), r * std::sin(golden * i), std::abs(z));
    axes.push_back(to_world * a);
  }
  return axes;
}

namespace {

// Parameters exactly as the reference stores them: raw axis v (mu = v/|v|),
// s (lambda = exp(-s)), signed amplitude b in the reference's units (it folds
// the Lambertian 1/pi into the albedo, so radiance a = pi |b|).
struct Params {
  std::vector<Eigen::Vector3d> v;
  std::vector<double> s;
  std::vector<Eigen::Vector3d> b;
  size_t size() const { return v.size(); }
};

constexpr int kParamsPerLobe = 7;
constexpr double kAdamBeta1 = 0.9, kAdamBeta2 = 0.999, kAdamEps = 1e-8;  // PyTorch defaults

SgLighting ToLighting(const Params& p, const Eigen::Vector3d& up) {
  SgLighting l;
  l.up = up;
  for (size_t i = 0; i < p.size(); ++i)
    l.lobes.push_back({p.v[i].normalized(), std::exp(-p.s[i]), M_PI * p.b[i].cwiseAbs()});
  return l;
}

}  // namespace

SgLighting SolveSgPaper(const ShadowPlaneModel& model, const std::vector<Eigen::Vector3f>& targets,
                        const SgPaperOptions& opt, SgSolveSummary* summary, const ProgressFn& progress) {
  const auto start = std::chrono::steady_clock::now();
  std::mt19937_64 rng(opt.seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  Params p;
  for (const auto& axis : FibonacciHemisphereAxes(opt.lobes, model.normal)) {
    p.v.push_back(axis);
    p.s.push_back(-3.0 * unit(rng));  // s ~ -U(0, 3): lambda in [1, e^3]
    p.b.push_back(Eigen::Vector3d::Constant(unit(rng)));
  }
  // Adam state, 7 values per lobe: v(3) s(1) b(3).
  std::vector<Eigen::Matrix<double, kParamsPerLobe, 1>> m1(p.size(), Eigen::Matrix<double, kParamsPerLobe, 1>::Zero());
  std::vector<Eigen::Matrix<double, kParamsPerLobe, 1>> m2 = m1;
  std::vector<int> adam_t(p.size(), 0);  // per-lobe step counts survive pruning as in PyTorch
  SgSolveSummary local;
  local.lobes_initial = static_cast<int>(p.size());
  std::uniform_int_distribution<size_t> pick(0, model.points.size() - 1);
  std::vector<size_t> batch(opt.batch);

  for (int step = 0; step < opt.steps; ++step) {
    for (auto& i : batch) i = pick(rng);
    const SgLighting lighting = ToLighting(p, model.normal);
    const size_t n = p.size();
    // Gradient of the batch MSE (mean over pixels and channels) w.r.t. each
    // lobe's (mu, lambda, a) in radiance units.
    Eigen::MatrixXd grad;
    const double loss = MseAndGradient(model, lighting, batch, targets, &grad);

    // Chain rule to the stored parameters.
    const double lr = opt.learning_rate * std::pow(opt.lr_decay, step / opt.lr_decay_every);
    std::vector<Eigen::Vector3d> grad_b(n);
    for (size_t i = 0; i < n; ++i) {
      const Eigen::Vector3d mu = p.v[i].normalized();
      const Eigen::Vector3d dmu = grad.row(i).segment<3>(0).transpose();
      const double vnorm = p.v[i].norm();
      // A collapsed or non-finite axis parameter has no gradient direction: leave it (the last guard drops it).
      const Eigen::Vector3d dv = vnorm > 1e-12 && std::isfinite(vnorm)
                                     ? Eigen::Vector3d((Eigen::Matrix3d::Identity() - mu * mu.transpose()) * dmu / vnorm)
                                     : Eigen::Vector3d::Zero();
      const double lambda = std::exp(-p.s[i]);
      const double ds = -lambda * grad(i, 3);
      Eigen::Vector3d db;
      for (int ch = 0; ch < 3; ++ch) {
        const double sign = p.b[i][ch] > 0 ? 1.0 : (p.b[i][ch] < 0 ? -1.0 : 0.0);  // d|b|/db as torch.abs
        db[ch] = M_PI * sign * grad(i, 4 + ch);
      }
      grad_b[i] = db;
      // Fixed-size segments, not the comma initializer: with AVX, GCC 12
      // warns (falsely) that its packet path reads past db.
      Eigen::Matrix<double, kParamsPerLobe, 1> g;
      g.segment<3>(0) = dv;
      g[3] = ds;
      g.segment<3>(4) = db;
      ++adam_t[i];
      m1[i] = kAdamBeta1 * m1[i] + (1 - kAdamBeta1) * g;
      m2[i] = kAdamBeta2 * m2[i] + (1 - kAdamBeta2) * g.cwiseProduct(g);
      const double bc1 = 1 - std::pow(kAdamBeta1, adam_t[i]), bc2 = 1 - std::pow(kAdamBeta2, adam_t[i]);
      const Eigen::Matrix<double, kParamsPerLobe, 1> update =
          lr * (m1[i] / bc1).cwiseQuotient(((m2[i] / bc2).cwiseSqrt().array() + kAdamEps).matrix());
      p.v[i] -= update.segment<3>(0);
      p.s[i] -= update[3];
      p.b[i] -= update.segment<3>(4);
    }

    const int done = step + 1;
    if (done % opt.prune_every == 0 && done >= opt.prune_from && done <= opt.prune_until) {
      Params kept;
      std::vector<Eigen::Matrix<double, kParamsPerLobe, 1>> k1, k2;
      std::vector<int> kt;
      for (size_t i = 0; i < n; ++i) {
        if (p.b[i].cwiseAbs().maxCoeff() < opt.prune_amplitude &&
            grad_b[i].cwiseAbs().maxCoeff() < opt.prune_amplitude_grad)
          continue;
        kept.v.push_back(p.v[i]);
        kept.s.push_back(p.s[i]);
        kept.b.push_back(p.b[i]);
        k1.push_back(m1[i]);
        k2.push_back(m2[i]);
        kt.push_back(adam_t[i]);
      }
      p = std::move(kept);
      m1 = std::move(k1);
      m2 = std::move(k2);
      adam_t = std::move(kt);
    }
    local.iterations = done;
    local.final_loss = loss;
    if (done % 100 == 0 || done == opt.steps) {
      local.loss_history.emplace_back(done, loss);
      char status[96];
      std::snprintf(status, sizeof(status), "step %d loss %.3e lobes %zu", done, loss, p.size());
      Report(progress, static_cast<double>(done) / opt.steps, status);
    }
  }
  SgLighting result = ToLighting(p, model.normal);
  if (model.upper_hemisphere_only) {
    // Lobes below the plane contribute nothing in the model: drop them.
    std::erase_if(result.lobes, [&](const SgLobe& l) { return l.axis.dot(model.normal) <= 0; });
  }
  local.invalid_lobes_removed = RemoveInvalidLobes(&result);
  local.lobes_kept = static_cast<int>(result.lobes.size());
  local.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (summary) *summary = local;
  return result;
}

}  // namespace shadowsg
