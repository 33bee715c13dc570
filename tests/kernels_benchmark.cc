// Google Benchmark of the solver's inner kernels (speed targets are checked
// here and by `shadowsg bench`, never by timed unit tests):
//   build/tests/shadowsg_kernels_benchmark --benchmark_min_time=0.5
#include <benchmark/benchmark.h>

#include <memory>
#include <random>

#include "solver/caster_bounce.h"
#include "solver/cosine_integral.h"
#include "solver/eigen_blocking.h"
#include "solver/primitives.h"
#include "solver/shadow_plane.h"
#include "solver/sg_lobe_system.h"
#include "solver/sg_refine_lm.h"
#include "solver/sphere_tree_build.h"
#include "solver/ssdf.h"

namespace shadowsg {
namespace {

const SphereTree& TorusTree() {
  static const SphereTree tree = BuildSphereTree(MakeTorus(0.2, 0.06, 64, 32), SphereTreeBuildOptions{});
  return tree;
}

std::vector<Eigen::Vector3d> PlanePoints(int n) {
  std::mt19937 rng(1);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<Eigen::Vector3d> p;
  for (int i = 0; i < n; ++i) p.emplace_back(u(rng), u(rng), -0.3);
  return p;
}

std::vector<Eigen::Vector3d> Axes(int n) {
  std::mt19937 rng(2);
  std::normal_distribution<double> g;
  std::vector<Eigen::Vector3d> a;
  for (int i = 0; i < n; ++i) {
    Eigen::Vector3d v(g(rng), g(rng), std::abs(g(rng)) + 0.2);
    a.push_back(v.normalized());
  }
  return a;
}

// theta for every (point, axis) pair, as the dictionary fit needs it.
void BM_SignedAngles(benchmark::State& state) {
  const std::vector<SphereTree> trees = {TorusTree()};
  const auto points = PlanePoints(static_cast<int>(state.range(0)));
  const auto axes = Axes(static_cast<int>(state.range(1)));
  Eigen::MatrixXf theta;
  for (auto _ : state) SignedAngles(trees, points, axes, &theta);
  state.SetItemsProcessed(state.iterations() * points.size() * axes.size());
}
BENCHMARK(BM_SignedAngles)->Args({4096, 300})->Args({4096, 8})->Unit(benchmark::kMillisecond);

// The same with cone tables prepared once (the fit's repeated evaluations).
// From 24 axes a call tables each point's leaf cones (a dictionary's 160
// axes at 6000 fit pixels): 23 and 24 axes show what that changes.
void BM_PreparedCones(benchmark::State& state) {
  const OccluderCones cones({TorusTree()}, PlanePoints(static_cast<int>(state.range(0))));
  const auto axes = Axes(static_cast<int>(state.range(1)));
  Eigen::MatrixXf theta;
  std::vector<Eigen::Vector3f> witness;
  for (auto _ : state) cones.Angles(axes, &theta, &witness);
  state.SetItemsProcessed(state.iterations() * cones.size() * axes.size());
}
BENCHMARK(BM_PreparedCones)
    ->Args({16384, 8})
    ->Args({6000, 23})
    ->Args({6000, 24})
    ->Args({6000, 160})
    ->Unit(benchmark::kMillisecond);

// Levenberg-Marquardt's searches: the same 8 axes turned by 0.01 rad per
// evaluation, theta capped where a lobe of sharpness ~100 saturates, without
// (hints = 0) and with (1) the last evaluation's hints (OccluderCones::AngleHints),
// capped above only (sides = 0) or both ways (1: CapSides::kBoth, the solver's).
void BM_PreparedConesLm(benchmark::State& state) {
  const OccluderCones cones({TorusTree()}, PlanePoints(static_cast<int>(state.range(0))));
  std::vector<Eigen::Vector3d> axes = Axes(8);
  const std::vector<float> caps(axes.size(), 0.1f);
  const Eigen::AngleAxisd turn(0.01, Eigen::Vector3d(1, 2, 0.5).normalized());
  OccluderCones::AngleHints hints;
  Eigen::MatrixXf theta;
  std::vector<Eigen::Vector3f> witness;
  for (auto _ : state) {
    cones.Angles(axes, &theta, &witness, &caps, state.range(1) ? &hints : nullptr,
                 state.range(2) ? CapSides::kBoth : CapSides::kAbove);
    for (auto& a : axes) a = turn * a;
  }
  state.SetItemsProcessed(state.iterations() * cones.size() * axes.size());
}
BENCHMARK(BM_PreparedConesLm)
    ->Args({16384, 0, 0})
    ->Args({16384, 1, 0})
    ->Args({16384, 1, 1})
    ->Unit(benchmark::kMillisecond);

// Closed-form render of plane points under an SG lighting (sg model).
void BM_RenderShadowPlane(benchmark::State& state) {
  ShadowPlaneModel model;
  model.points = PlanePoints(static_cast<int>(state.range(0)));
  model.albedo.assign(model.points.size(), Eigen::Vector3f::Constant(0.8f));
  model.occluders = {TorusTree()};
  model.cosine = CosineModel::kExact;
  model.cap_occlusion = true;
  model.max_steepness = kSgMaxVisibilitySteepness;
  model.occluder_cos = OccluderConeCosines(model.occluders, model.points);
  SgLighting l;
  for (const auto& a : Axes(static_cast<int>(state.range(1)))) l.lobes.push_back({a, 30.0, Eigen::Vector3d::Ones()});
  for (auto _ : state) benchmark::DoNotOptimize(RenderShadowPlane(model, l));
  state.SetItemsProcessed(state.iterations() * model.points.size() * l.lobes.size());
}
BENCHMARK(BM_RenderShadowPlane)->Args({65536, 8})->Args({65536, 64})->Unit(benchmark::kMillisecond);

const CasterBounce& TorusBounce();

// The torus over n plane points as `sg` models it: exact cosine, cone
// tables prepared, the occlusion cap and the sigmoid's steepness capped.
ShadowPlaneModel TorusPlaneModel(int n) {
  ShadowPlaneModel model;
  model.points = PlanePoints(n);
  model.albedo.assign(model.points.size(), Eigen::Vector3f::Constant(0.8f));
  model.occluders = {TorusTree()};
  model.PrepareCones();
  model.cosine = CosineModel::kExact;
  model.cap_occlusion = true;
  model.max_steepness = kSgMaxVisibilitySteepness;
  model.occluder_cos = OccluderConeCosines(model.occluders, model.points);
  return model;
}

// One path solve of the refinement: 8 Levenberg-Marquardt steps of L lobes
// over the fit pixels (6000 in the presets), from lobes turned 0.02 rad and
// dimmed 10 % off those that made the targets; cone tables prepared once;
// with the third argument 1, the torus's bounce too, its form factors
// factored as the fit pixels' are (tolerance 0.003).
void BM_RefineByLm(benchmark::State& state) {
  ShadowPlaneModel model = TorusPlaneModel(static_cast<int>(state.range(0)));
  if (state.range(2)) {
    model.normal = Eigen::Vector3d::UnitZ();
    model.bounce = std::shared_ptr<const CasterBounce>(&TorusBounce(), [](const CasterBounce*) {});
    model.PrepareBounceForm(0.003);
  }
  SgLighting truth;
  for (const auto& a : Axes(static_cast<int>(state.range(1)))) truth.lobes.push_back({a, 60.0, Eigen::Vector3d::Ones()});
  const std::vector<Eigen::Vector3f> targets = RenderShadowPlane(model, truth);
  const std::vector<double> weight(model.points.size(), 1.0);
  const Eigen::AngleAxisd turn(0.02, Eigen::Vector3d(1, 2, 0.5).normalized());
  std::vector<SgLobe> start = truth.lobes;
  for (SgLobe& l : start) l.axis = turn * l.axis, l.amplitude *= 0.9;
  RefineLmOptions o;
  o.max_iterations = 8;
  int steps = 0;
  for (auto _ : state) {
    const RefineCost cost(model, weight, targets, static_cast<int>(start.size()), false);
    std::vector<SgLobe> lobes = start;
    steps += RefineByLm(cost, &lobes, o).iterations;
  }
  state.counters["steps"] = benchmark::Counter(steps, benchmark::Counter::kAvgIterations);
}
BENCHMARK(BM_RefineByLm)
    ->Args({6000, 8, 0})
    ->Args({6000, 16, 0})
    ->Args({6000, 8, 1})
    ->Args({6000, 16, 1})
    ->Unit(benchmark::kMillisecond);

// The pool's backward elimination: a torus lit by 40 lobes of random
// colours, the candidates those lobes a little off their axes at three
// sharpnesses and as many elsewhere (240 in all, as three restarts' pool);
// the system built once, the order alone timed.
void BM_EliminationOrder(benchmark::State& state) {
  const ShadowPlaneModel model = TorusPlaneModel(4096);
  const int n = static_cast<int>(state.range(0)) / 6;
  const std::vector<Eigen::Vector3d> axes = Axes(2 * n);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0.2, 1.0);
  SgLighting truth;
  for (int i = 0; i < n; ++i) truth.lobes.push_back({axes[i], 30.0, Eigen::Vector3d(u(rng), u(rng), u(rng))});
  const std::vector<Eigen::Vector3f> targets = RenderShadowPlane(model, truth);
  const Eigen::AngleAxisd turn(0.05, Eigen::Vector3d(1, 2, 0.5).normalized());
  std::vector<SgLobe> candidates;
  for (int i = 0; i < 2 * n; ++i)
    for (double sharpness : {15.0, 30.0, 120.0})
      candidates.push_back({i < n ? Eigen::Vector3d(turn * axes[i]) : axes[i], sharpness, Eigen::Vector3d::Ones()});
  const LobeNormalEquations eq =
      BuildLobeNormalEquations(model, std::vector<double>(model.points.size(), 1.0), targets, candidates);
  for (auto _ : state) benchmark::DoNotOptimize(EliminationOrder(eq));
}
BENCHMARK(BM_EliminationOrder)->Arg(120)->Arg(240)->Unit(benchmark::kMillisecond);

// The exact quadrature and the bounce's table, over a sweep of sharpness.
template <class Integral>
void BM_CosineIntegral(benchmark::State& state, Integral integral) {
  double lambda = 1, c = 0.3;
  for (auto _ : state) {
    benchmark::DoNotOptimize(integral(lambda, c));
    lambda = lambda < 1000 ? lambda * 1.1 : 1;
  }
}
BENCHMARK_CAPTURE(BM_CosineIntegral, exact, [](double l, double c) { return SgCosineIntegral(l, c).value; });
BENCHMARK_CAPTURE(BM_CosineIntegral, tabulated, SgCosineIntegralTabulated);

// The casters' bounce of a torus above the plane z = -0.3 (256 patches).
const CasterBounce& TorusBounce() {
  static const CasterBounce bounce = [] {
    const TriangleMesh torus = MakeTorus(0.2, 0.06, 64, 32);
    RayCaster casters;
    casters.AddMesh(torus);
    casters.Commit();
    return CasterBounce({torus}, {Eigen::Vector3d::Constant(0.7)}, casters, Eigen::Vector3d(0, 0, -0.3),
                        Eigen::Vector3d::UnitZ());
  }();
  return bounce;
}

// Patch irradiance of a lighting's lobes (every LM evaluation with the bounce).
void BM_BounceIrradiance(benchmark::State& state) {
  const auto axes = Axes(static_cast<int>(state.range(0)));
  const std::vector<double> sharpness(axes.size(), 30.0);
  for (auto _ : state) benchmark::DoNotOptimize(TorusBounce().Irradiance(axes, sharpness, nullptr));
  state.SetItemsProcessed(state.iterations() * axes.size());
}
BENCHMARK(BM_BounceIrradiance)->Arg(16)->Unit(benchmark::kMillisecond);

// Form factors of the fit pixels (once per fit set).
void BM_BounceFormFactors(benchmark::State& state) {
  const auto points = PlanePoints(static_cast<int>(state.range(0)));
  for (auto _ : state) benchmark::DoNotOptimize(TorusBounce().FormFactors(points));
  state.SetItemsProcessed(state.iterations() * points.size());
}
BENCHMARK(BM_BounceFormFactors)->Arg(6000)->Unit(benchmark::kMillisecond);

// Their factoring to the fit's tolerance (once per fit set).
void BM_FactorFormFactors(benchmark::State& state) {
  const Eigen::MatrixXf k = TorusBounce().FormFactors(PlanePoints(static_cast<int>(state.range(0))));
  for (auto _ : state) benchmark::DoNotOptimize(FactorFormFactors(k, 0.003));
  state.counters["rank"] = static_cast<double>(FactorFormFactors(k, 0.003).rank());
}
BENCHMARK(BM_FactorFormFactors)->Arg(6000)->Unit(benchmark::kMillisecond);

// The gather of 16 lobes' bounce, 3 channels, to 6000 fit pixels (every LM
// evaluation): K itself (tolerance 0) or factored (0.003).
void BM_GatherBounce(benchmark::State& state) {
  const FactoredFormFactors f = FactorFormFactors(TorusBounce().FormFactors(PlanePoints(6000)),
                                                  static_cast<double>(state.range(0)) / 1000);
  const Eigen::MatrixXf radiance = Eigen::MatrixXf::Random(static_cast<long>(TorusBounce().size()), 48).cwiseAbs();
  for (auto _ : state) benchmark::DoNotOptimize(f.Times(radiance));
  state.counters["rank"] = static_cast<double>(f.rank());
}
BENCHMARK(BM_GatherBounce)->Arg(0)->Arg(3)->Unit(benchmark::kMillisecond);

// The per-mesh set-up on a coarse mesh and on a scan-sized one: a torus of
// range(0) x range(0)/2 quads (64: 4096 faces; 1024: 1048576 faces, about a
// scan's). The tree is built once per mesh and cached; its aim is <= 5 s.
void BM_SphereTreeBuild(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const TriangleMesh torus = MakeTorus(0.2, 0.06, n, n / 2);
  for (auto _ : state) benchmark::DoNotOptimize(BuildSphereTree(torus, SphereTreeBuildOptions{}));
  state.counters["faces"] = static_cast<double>(torus.faces.size());
}
BENCHMARK(BM_SphereTreeBuild)->Arg(64)->Arg(1024)->Unit(benchmark::kSecond)->Iterations(1);

// The bounce's patches (every `sg` solve with the bounce, before its clock).
void BM_CasterBounceBuild(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const TriangleMesh torus = MakeTorus(0.2, 0.06, n, n / 2);
  RayCaster casters;
  casters.AddMesh(torus);
  casters.Commit();
  for (auto _ : state)
    benchmark::DoNotOptimize(CasterBounce({torus}, {Eigen::Vector3d::Constant(0.7)}, casters,
                                          Eigen::Vector3d(0, 0, -0.3), Eigen::Vector3d::UnitZ()));
  state.counters["faces"] = static_cast<double>(torus.faces.size());
}
BENCHMARK(BM_CasterBounceBuild)->Arg(64)->Arg(1024)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace shadowsg

// Eigen's blocking pinned as the CLI pins it, so the kernels run the products the solver runs.
int main(int argc, char** argv) {
  shadowsg::PinEigenBlocking();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
