// The refinement's Levenberg-Marquardt (solver/sg_refine_lm.h): from a
// perturbed start it returns to the lobes that made the targets, keeps the
// bounds, and reports its steps and trust radius.
#include "solver/sg_refine_lm.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "sg_test_scene.h"

namespace shadowsg {
namespace {

// The solver's test plane (tests/sg_solver_test.cc).
ShadowPlaneModel TestModel(int grid) {
  ShadowPlaneModel model = testing::TestPlaneModel(grid, CosineModel::kExact);
  model.upper_hemisphere_only = false;
  return model;
}

std::vector<SgLobe> TrueLobes() {
  return {{Eigen::Vector3d(0.4, 0.3, 0.87).normalized(), 40.0, Eigen::Vector3d(30, 28, 25)},
          {Eigen::Vector3d(-0.2, 0.1, 0.97).normalized(), 3.0, Eigen::Vector3d(0.5, 0.6, 0.8)}};
}

// The model's shading of `lobes` at every point (residuals against zero targets, weight 1).
std::vector<Eigen::Vector3f> Render(const ShadowPlaneModel& model, const std::vector<SgLobe>& lobes) {
  const std::vector<Eigen::Vector3f> zero(model.points.size(), Eigen::Vector3f::Zero());
  const std::vector<double> weight(model.points.size(), 1.0);
  const RefineCost cost(model, weight, zero, static_cast<int>(lobes.size()), false);
  Eigen::MatrixX3d r;
  cost.Evaluate(lobes, &r, nullptr);
  std::vector<Eigen::Vector3f> out(model.points.size());
  for (long k = 0; k < r.rows(); ++k) out[k] = r.row(k).transpose().cast<float>();
  return out;
}

// The test plane, targets rendered from `truth`, unit weights (RefineCost
// keeps references to all three).
struct Problem {
  Problem(int grid, const std::vector<SgLobe>& truth)
      : model(TestModel(grid)), targets(Render(model, truth)), weight(model.points.size(), 1.0) {}
  ShadowPlaneModel model;
  std::vector<Eigen::Vector3f> targets;
  std::vector<double> weight;
};

double AngleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::clamp(a.dot(b), -1.0, 1.0)) * 180 / M_PI;
}

// LM brings the error of a start half a degree off back to rounding. (On
// this plane a lobe's axis, sharpness and amplitude trade off to within
// 1e-12 of the error over a tenth of a degree, so the lobes themselves are
// compared loosely.)
TEST(RefineByLm, ReturnsToTheLobesThatMadeTheTargets) {
  const std::vector<SgLobe> truth = TrueLobes();
  const Problem p(64, truth);
  const RefineCost cost(p.model, p.weight, p.targets, 2, false);
  std::vector<SgLobe> lobes = truth;
  lobes[0].axis = (truth[0].axis + std::tan(0.5 * M_PI / 180) * TangentBasis(truth[0].axis)[0]).normalized();
  RefineLmOptions o;
  o.max_iterations = 60;
  int reported = 0;
  const RefineLmSummary s = RefineByLm(cost, &lobes, o, [&](int it, double) { reported = it; });
  std::printf("%d steps (%d taken), cost %.3e -> %.3e, radius %.3g, sun %.4f deg off, lambda %.2f\n", s.iterations,
              s.accepted, s.initial_cost, s.final_cost, s.radius, AngleDeg(lobes[0].axis, truth[0].axis),
              lobes[0].sharpness);
  EXPECT_EQ(reported, s.iterations);
  EXPECT_LE(s.iterations, o.max_iterations);
  EXPECT_GT(s.accepted, 0);
  EXPECT_GT(s.radius, 0);
  EXPECT_LT(s.final_cost, 1e-9 * s.initial_cost);
  EXPECT_LT(AngleDeg(lobes[0].axis, truth[0].axis), 0.25);
  EXPECT_NEAR(lobes[0].sharpness / truth[0].sharpness, 1, 0.01);
  for (int i = 0; i < 2; ++i) {
    EXPECT_NEAR(lobes[i].axis.norm(), 1, 1e-12);
    EXPECT_LT((lobes[i].amplitude - truth[i].amplitude).norm(), 0.01 * truth[i].amplitude.norm()) << "lobe " << i;
  }
}

// Far steps refused on a sample of the points (RefineLmOptions::probe_radius)
// are the steps a full evaluation refuses: from a start far off, with and
// without the sample, the same steps are tried, taken and refused, to the
// same lobes; with it, some are refused on the sample alone.
TEST(RefineByLm, StepsRefusedOnASampleAreTheSameSteps) {
  const std::vector<SgLobe> truth = TrueLobes();
  Problem p(64, truth);
  p.model.PrepareCones();
  std::vector<SgLobe> start = truth;
  start[0].axis = (truth[0].axis + std::tan(8 * M_PI / 180) * TangentBasis(truth[0].axis)[1]).normalized();
  start[0].sharpness = 10;
  start[1].amplitude *= 3;
  RefineLmOptions o;
  o.max_iterations = 25;
  std::vector<SgLobe> probed = start, plain = start;
  const RefineLmSummary a = RefineByLm(RefineCost(p.model, p.weight, p.targets, 2, false), &probed, o);
  o.probe_radius = std::numeric_limits<double>::infinity();
  const RefineLmSummary b = RefineByLm(RefineCost(p.model, p.weight, p.targets, 2, false), &plain, o);
  std::printf("%d steps (%d taken, %d refused on the sample), cost %.3e -> %.3e\n", a.iterations, a.accepted,
              a.probe_refusals, a.initial_cost, a.final_cost);
  EXPECT_GT(a.probe_refusals, 0);
  EXPECT_EQ(b.probe_refusals, 0);
  EXPECT_EQ(a.iterations, b.iterations);
  EXPECT_EQ(a.accepted, b.accepted);
  EXPECT_NEAR(a.final_cost, b.final_cost, 1e-6 * b.final_cost);
  EXPECT_LT(a.final_cost, 1e-3 * a.initial_cost);
  for (int i = 0; i < 2; ++i) {
    EXPECT_LT(AngleDeg(probed[i].axis, plain[i].axis), 1e-4) << "lobe " << i;
    EXPECT_NEAR(probed[i].sharpness, plain[i].sharpness, 1e-6 * plain[i].sharpness) << "lobe " << i;
    EXPECT_LT((probed[i].amplitude - plain[i].amplitude).norm(), 1e-6 * plain[i].amplitude.norm()) << "lobe " << i;
  }
}

// The residuals are linear in the amplitudes: from the right geometry and
// every channel's amplitudes off, a few steps bring the error to rounding
// (a wrong channel mapping of the amplitude columns cannot).
TEST(RefineByLm, SolvesAmplitudesPerChannel) {
  const std::vector<SgLobe> truth = TrueLobes();
  const Problem p(30, truth);
  const RefineCost cost(p.model, p.weight, p.targets, 2, false);
  std::vector<SgLobe> lobes = truth;
  lobes[0].amplitude = lobes[0].amplitude.cwiseProduct(Eigen::Vector3d(0.6, 1.3, 0.9));
  lobes[1].amplitude = lobes[1].amplitude.cwiseProduct(Eigen::Vector3d(1.5, 0.7, 1.2));
  RefineLmOptions o;
  o.max_iterations = 5;
  const RefineLmSummary s = RefineByLm(cost, &lobes, o);
  std::printf("%d steps (%d taken), cost %.3e -> %.3e\n", s.iterations, s.accepted, s.initial_cost, s.final_cost);
  EXPECT_LT(s.final_cost, 1e-10 * s.initial_cost);
  EXPECT_LE(s.iterations, 5);
  for (int i = 0; i < 2; ++i) {
    EXPECT_LT(AngleDeg(lobes[i].axis, truth[i].axis), 0.05) << "lobe " << i;
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(lobes[i].amplitude[c], truth[i].amplitude[c], 0.01 * truth[i].amplitude[c]) << i << " " << c;
  }
}

// A lobe the targets do not have is driven to zero amplitude, not below;
// sharpness stays inside a bound below the sun's.
TEST(RefineByLm, KeepsAmplitudesAndSharpnessInTheirBounds) {
  const std::vector<SgLobe> truth = {TrueLobes()[0]};
  const Problem p(30, truth);
  std::vector<SgLobe> lobes = {truth[0], {Eigen::Vector3d(-0.3, 0.3, 0.9).normalized(), 1.0, Eigen::Vector3d(2, 2, 2)}};
  const RefineCost cost(p.model, p.weight, p.targets, 2, false);
  RefineLmOptions o;
  o.max_iterations = 40;
  o.max_sharpness = 30;  // below the sun's 40
  lobes[0].sharpness = 20;
  const RefineLmSummary s = RefineByLm(cost, &lobes, o);
  std::printf("cost %.3e -> %.3e, extra lobe amplitude %.3g %.3g %.3g, sun lambda %.2f\n", s.initial_cost,
              s.final_cost, lobes[1].amplitude[0], lobes[1].amplitude[1], lobes[1].amplitude[2], lobes[0].sharpness);
  EXPECT_LT(s.final_cost, 0.01 * s.initial_cost);
  for (const SgLobe& l : lobes) {
    EXPECT_GE(l.amplitude.minCoeff(), 0.0);
    EXPECT_GE(l.sharpness, o.min_sharpness);
    EXPECT_LE(l.sharpness, o.max_sharpness * (1 + 1e-12));
  }
  EXPECT_LT(lobes[1].amplitude.maxCoeff(), 0.05 * lobes[0].amplitude.maxCoeff());
}

// No steps asked: the lobes are returned as given.
TEST(RefineByLm, NoIterationsLeavesTheLobes) {
  const ShadowPlaneModel model = TestModel(10);
  const std::vector<SgLobe> truth = TrueLobes();
  const std::vector<Eigen::Vector3f> targets(model.points.size(), Eigen::Vector3f::Constant(0.3f));
  const std::vector<double> weight(model.points.size(), 1.0);
  const RefineCost cost(model, weight, targets, 2, false);
  std::vector<SgLobe> lobes = truth;
  RefineLmOptions o;
  o.max_iterations = 0;
  const RefineLmSummary s = RefineByLm(cost, &lobes, o);
  EXPECT_EQ(s.iterations, 0);
  for (int i = 0; i < 2; ++i) EXPECT_EQ(lobes[i].axis, truth[i].axis);
}

}  // namespace
}  // namespace shadowsg
