#include "solver/baselines.h"

#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <random>

#include "calib/error.h"
#include "solver/light_transport.h"
#include "solver/nnls.h"
#include "solver/plane_pixels.h"
#include "solver/primitives.h"

namespace shadowsg {
namespace {

constexpr int kImageSize = 96;

// A camera 6 units above the plane z = 0 looking straight down (OpenCV axes:
// image x = world x, image y = world -y), seeing about [-4, 4]^2 of the plane,
// with a floating icosphere and a box resting on the plane as casters.
Scene MakeScene(const Eigen::Vector3d& diffuse) {
  Scene scene;
  scene.name = "synthetic";
  Camera& cam = scene.camera;
  cam.width = cam.height = kImageSize;
  cam.cx = cam.cy = (kImageSize - 1) / 2.0;
  cam.fx = cam.fy = cam.cx / (4.0 / 6.0);
  cam.c2w.setIdentity();
  cam.c2w.block<3, 3>(0, 0) << 1, 0, 0, 0, -1, 0, 0, 0, -1;
  cam.c2w.block<3, 1>(0, 3) = Eigen::Vector3d(0, 0, 6);
  scene.plane.scale = Eigen::Vector3d(10, 10, 1);
  scene.plane.diffuse = diffuse;
  SceneObject sphere;
  sphere.mesh = MakeIcosphere(0.35, 2);
  sphere.o2w.block<3, 1>(0, 3) = Eigen::Vector3d(0.4, -0.3, 0.7);
  scene.objects.push_back(sphere);
  SceneObject box;
  box.mesh = MakeBox(Eigen::Vector3d(0.2, 0.45, 0.3));
  box.o2w.block<3, 1>(0, 3) = Eigen::Vector3d(-1.2, 1.0, 0.3);
  scene.objects.push_back(box);
  scene.image = Image(kImageSize, kImageSize, 3, 0.0f);
  return scene;
}

// A positive map with a smooth sky and two bright texels, different per channel.
Eigen::MatrixX3d KnownMap(const HemisphereMap& map) {
  Eigen::MatrixX3d l(map.texels(), 3);
  for (int j = 0; j < map.texels(); ++j) {
    const Eigen::Vector3d d = map.Direction(j);
    l.row(j) << 0.5 + 0.3 * d.x(), 0.6 + 0.2 * d.y(), 0.8 - 0.3 * d.z();
  }
  l.row(map.texels() / 3) *= 40;
  l.row(map.texels() - 5) *= 25;
  return l;
}

struct Fixture {
  Scene scene;
  RayCaster casters;
  PlanePixels pixels;
};

// Renders `radiance` into the scene's image with the baselines' own transport.
Fixture MakeFixture(const Eigen::Vector3d& diffuse, int map_rows, const Eigen::MatrixX3d& radiance) {
  Fixture f{MakeScene(diffuse), {}, {}};
  f.casters = BuildRayCaster(f.scene.Casters());
  f.pixels = FindPlanePixels(f.scene, f.casters);
  const LightTransport transport(f.scene, f.pixels.point, f.casters, map_rows);
  const std::vector<Eigen::Vector3f> b = transport.RenderAll(radiance);
  for (size_t i = 0; i < f.pixels.size(); ++i) f.scene.image.set_rgb(f.pixels.pixel[i], b[i]);
  return f;
}

std::vector<size_t> AllRows(size_t n) {
  std::vector<size_t> rows(n);
  for (size_t i = 0; i < n; ++i) rows[i] = i;
  return rows;
}

Eigen::VectorXd Observed(const Fixture& f, int channel) {
  Eigen::VectorXd b(f.pixels.size());
  for (size_t i = 0; i < f.pixels.size(); ++i) b[i] = f.scene.image.rgb(f.pixels.pixel[i])[channel];
  return b;
}

Eigen::VectorXd MapChannel(const BaselineResult& r, int channel) {
  const HemisphereMap map{r.envmap.height / 2};
  return map.FromEnvMap(r.envmap).col(channel);
}

double RelativeError(const Eigen::MatrixXd& estimate, const Eigen::MatrixXd& truth) {
  return (estimate - truth).norm() / truth.norm();
}

TEST(HemisphereMap, MatchesTheEnvMapConvention) {
  const HemisphereMap map{16};
  EXPECT_EQ(map.texels(), 1024);
  double total = 0;
  for (int j = 0; j < map.texels(); ++j) {
    EXPECT_GT(map.Direction(j).z(), 0);
    total += map.SolidAngle(j);
  }
  EXPECT_NEAR(total, 2 * M_PI, 1e-9);
  // Texel (u, v) of the hemisphere map is texel (u, v) of the full 32 x 64 map.
  const Image env = map.ToEnvMap(KnownMap(map));
  EXPECT_EQ(env.width, 64);
  EXPECT_EQ(env.height, 32);
  EXPECT_EQ(env.at(3, 20, 1), 0.0f);
  EXPECT_NEAR((map.FromEnvMap(env) - KnownMap(map)).norm(), 0, 1e-3);
}

TEST(LightTransport, UnoccludedRowIntegratesTheCosine) {
  Scene scene = MakeScene(Eigen::Vector3d(0.5, 0.5, 0.5));
  const RayCaster casters = BuildRayCaster(scene.Casters());
  // A point far from the casters sees the whole hemisphere: a constant map
  // of radiance 1 gives irradiance ~pi (midpoint rule) and radiance albedo.
  const LightTransport t(scene, {Eigen::Vector3d(9, 9, 0), Eigen::Vector3d(0.4, -0.3, 0)}, casters, 16);
  const Eigen::MatrixX3d ones = Eigen::MatrixX3d::Ones(t.cols(), 3);
  EXPECT_NEAR(t.Irradiance(0, ones).x(), M_PI, 2e-3 * M_PI);
  EXPECT_NEAR(t.Render(0, ones).x(), 0.5, 1e-3);
  // Right under the floating sphere the zenith is blocked.
  EXPECT_FALSE(t.Visible(1, 0));
  EXPECT_TRUE(t.Visible(0, 0));
  EXPECT_LT(t.RayFraction(), 0.5);
}

TEST(LightTransport, CulledRaysAgreeWithBruteForce) {
  Scene scene = MakeScene(Eigen::Vector3d(0.5, 0.5, 0.5));
  const RayCaster casters = BuildRayCaster(scene.Casters());
  const PlanePixels pixels = FindPlanePixels(scene, casters);
  std::vector<Eigen::Vector3d> points;
  for (size_t i = 0; i < pixels.size(); i += 37) points.push_back(pixels.point[i]);
  const LightTransport t(scene, points, casters, 8);
  int mismatches = 0;
  for (size_t i = 0; i < points.size(); ++i)
    for (int j = 0; j < t.cols(); ++j) {
      const Eigen::Vector3d d = t.map().Direction(j);
      mismatches += t.Visible(i, j) == casters.Occluded(points[i] + 1e-6 * Eigen::Vector3d::UnitZ(), d);
    }
  EXPECT_EQ(mismatches, 0);
}

TEST(LightTransport, GramAndCrossProductMatchDenseProducts) {
  Scene scene = MakeScene(Eigen::Vector3d(0.8, 0.6, 0.5));
  const RayCaster casters = BuildRayCaster(scene.Casters());
  const PlanePixels pixels = FindPlanePixels(scene, casters);
  const LightTransport t(scene, pixels.point, casters, 6);
  std::vector<size_t> rows;
  for (size_t i = 0; i < pixels.size(); i += 5) rows.push_back(i);
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> uniform(0.1, 2.0);
  Eigen::VectorXd w(rows.size());
  Eigen::MatrixX3d coefficients(rows.size(), 3);
  for (size_t r = 0; r < rows.size(); ++r) {
    w[r] = uniform(rng);
    coefficients.row(r) << uniform(rng), uniform(rng), -uniform(rng);
  }
  Eigen::MatrixXd dense(rows.size(), t.cols());
  for (size_t r = 0; r < rows.size(); ++r) {
    Eigen::VectorXd row(t.cols());
    t.GeometricRow(rows[r], row.data());
    dense.row(r) = row.transpose();
  }
  const Eigen::MatrixXd gram = dense.transpose() * w.asDiagonal() * dense;
  EXPECT_LT((t.Gram(rows, w) - gram).norm(), 1e-12 * gram.norm());
  const Eigen::MatrixX3d cross = dense.transpose() * coefficients;
  EXPECT_LT((t.CrossProduct(rows, coefficients) - cross).norm(), 1e-12 * cross.norm());
  // The same sums on any number of threads, run after run.
  const int saved = omp_get_max_threads();
  omp_set_num_threads(1);
  const Eigen::MatrixXd one = t.Gram(rows, w);
  for (int threads : {2, 3, 3}) {
    omp_set_num_threads(threads);
    EXPECT_EQ((t.Gram(rows, w) - one).cwiseAbs().maxCoeff(), 0.0) << threads << " threads, " << rows.size() << " rows";
  }
  omp_set_num_threads(saved);
}

TEST(Baselines, SS03RecoversAKnownMapWithoutNoise) {
  // 4 rows (64 texels): this 96 x 96 view sees the shadows of every texel
  // direction, so A has full column rank (at 16 rows it does not: horizon
  // texels cast their shadows out of view).
  const int rows = 4;
  const HemisphereMap map{rows};
  const Eigen::MatrixX3d truth = KnownMap(map);
  const Fixture f = MakeFixture(Eigen::Vector3d(0.8, 0.6, 0.5), rows, truth);
  BaselineOptions options;
  options.map_rows = rows;
  const BaselineResult r = SolveBaseline(f.scene, f.pixels, f.casters, options);
  EXPECT_EQ(r.rank, map.texels());
  EXPECT_EQ(r.n_params, 3 * map.texels());
  EXPECT_LT(r.distinct_rows, f.pixels.size());  // identical rows were merged
  EXPECT_LT(RelativeError(map.FromEnvMap(r.envmap), truth), 1e-3);
  ASSERT_EQ(r.render.size(), f.pixels.size());
  for (size_t i = 0; i < f.pixels.size(); ++i)
    ASSERT_LT((r.render[i] - f.scene.image.rgb(f.pixels.pixel[i])).norm(),
              1e-4 * f.scene.image.rgb(f.pixels.pixel[i]).norm() + 1e-7);
}

TEST(Baselines, SS03RecoversAKnownMapOnATexturedPlane) {
  // A textured albedo gives each channel its own matrix (no shared decomposition).
  const int rows = 4;
  const HemisphereMap map{rows};
  const Eigen::MatrixX3d truth = KnownMap(map);
  Fixture f{MakeScene(Eigen::Vector3d(0.8, 0.6, 0.5)), {}, {}};
  Image texture(4, 4, 3);
  for (size_t i = 0; i < texture.data.size(); ++i) texture.data[i] = 0.3f + 0.05f * static_cast<float>(i % 13);
  f.scene.plane.albedo_texture = texture;
  f.casters = BuildRayCaster(f.scene.Casters());
  f.pixels = FindPlanePixels(f.scene, f.casters);
  const LightTransport t(f.scene, f.pixels.point, f.casters, rows);
  const std::vector<Eigen::Vector3f> b = t.RenderAll(truth);
  for (size_t i = 0; i < f.pixels.size(); ++i) f.scene.image.set_rgb(f.pixels.pixel[i], b[i]);
  BaselineOptions options;
  options.map_rows = rows;
  const BaselineResult r = SolveBaseline(f.scene, f.pixels, f.casters, options);
  EXPECT_LT(RelativeError(map.FromEnvMap(r.envmap), truth), 1e-3);
}

// A map with negative texels rendered with a little noise: the least-squares
// optimum is not non-negative, so NNLS must hold some texels at zero.
Fixture NoisyFixture(int rows) {
  const HemisphereMap map{rows};
  Eigen::MatrixX3d l = KnownMap(map);
  for (int j = 0; j < map.texels(); j += 7) l.row(j) *= -1.5;
  Fixture f = MakeFixture(Eigen::Vector3d(0.8, 0.6, 0.5), rows, l);
  std::mt19937 rng(7);
  std::normal_distribution<float> noise(0.0f, 0.01f);
  for (int p : f.pixels.pixel)
    for (int c = 0; c < 3; ++c) f.scene.image.data[3 * p + c] += noise(rng);
  return f;
}

TEST(Baselines, SS03PlusIsNonNegativeAndSatisfiesKkt) {
  const int rows = 8;
  const Fixture f = NoisyFixture(rows);
  BaselineOptions options;
  options.method = BaselineMethod::kSS03Plus;
  options.map_rows = rows;
  const BaselineResult r = SolveBaseline(f.scene, f.pixels, f.casters, options);
  EXPECT_TRUE(r.converged);
  const LightTransport t(f.scene, f.pixels.point, f.casters, rows);
  const std::vector<size_t> all = AllRows(f.pixels.size());
  int at_zero = 0;
  for (int c = 0; c < 3; ++c) {
    const Eigen::MatrixXd a = t.Matrix(all, c);
    const Eigen::VectorXd b = Observed(f, c);
    const Eigen::VectorXd l = MapChannel(r, c);
    const Eigen::VectorXd gradient = a.transpose() * (a * l - b);
    const double tol = 1e-6 * (a.transpose() * b).cwiseAbs().maxCoeff();
    for (int j = 0; j < l.size(); ++j) {
      ASSERT_GE(l[j], 0) << "texel " << j;
      if (l[j] > 0) {
        EXPECT_NEAR(gradient[j], 0, tol) << "passive texel " << j << " channel " << c;
      } else {
        EXPECT_GE(gradient[j], -tol) << "texel at zero " << j << " channel " << c;
        ++at_zero;
      }
    }
    // The re-render is the fitted model.
    const Eigen::VectorXd render = a * l;
    for (size_t i = 0; i < f.pixels.size(); ++i) ASSERT_NEAR(r.render[i][c], render[i], 1e-5 * (1 + std::abs(render[i])));
  }
  EXPECT_GT(at_zero, 0);
}

TEST(Baselines, SH21SolvesItsNormalEquations) {
  const int rows = 8;
  const Fixture f = NoisyFixture(rows);
  BaselineOptions options;
  options.method = BaselineMethod::kSH21;
  options.map_rows = rows;
  const BaselineResult r = SolveBaseline(f.scene, f.pixels, f.casters, options);
  const LightTransport t(f.scene, f.pixels.point, f.casters, rows);
  const Eigen::MatrixXd d = Eigen::MatrixXd(HemisphereLaplacian(rows));
  for (int c = 0; c < 3; ++c) {
    const Eigen::MatrixXd a = t.Matrix(AllRows(f.pixels.size()), c);
    const Eigen::VectorXd b = Observed(f, c);
    const Eigen::VectorXd l = MapChannel(r, c);
    // Weights in the reference's units: on our radiance map they act as
    // 0.1 (albedo/pi)^2.
    const double k2 = std::pow(t.AlbedoOverPi(0)[c], 2);
    const Eigen::MatrixXd m = a.transpose() * a + 0.1 * k2 * d.transpose() * d +
                              0.1 * k2 * Eigen::MatrixXd::Identity(t.cols(), t.cols());
    const Eigen::VectorXd atb = a.transpose() * b;
    // The map is stored as float: compare at that precision.
    EXPECT_LT((m * l - atb).norm(), 1e-5 * atb.norm()) << "channel " << c;
    const Eigen::VectorXd render = a * l;
    for (size_t i = 0; i < f.pixels.size(); ++i) ASSERT_NEAR(r.render[i][c], render[i], 1e-5 * (1 + std::abs(render[i])));
  }
}

TEST(Baselines, DefaultResolutionGivesTheFullMap) {
  const HemisphereMap map{16};
  const Fixture f = MakeFixture(Eigen::Vector3d(0.8, 0.6, 0.5), 16, KnownMap(map));
  BaselineOptions options;
  options.method = BaselineMethod::kSH21;
  const BaselineResult r = SolveBaseline(f.scene, f.pixels, f.casters, options);
  EXPECT_EQ(r.n_params, 3072);
  EXPECT_EQ(r.envmap.width, 64);
  EXPECT_EQ(r.envmap.height, 32);
  for (int v = 16; v < 32; ++v)
    for (int u = 0; u < 64; ++u) ASSERT_EQ(r.envmap.rgb(r.envmap.index(u, v)).norm(), 0.0f);
  EXPECT_EQ(r.render.size(), f.pixels.size());
}

TEST(Baselines, RankDeficientSS03ReproducesTheObservation) {
  // At 8 rows this view cannot tell every texel apart (horizon texels cast
  // their shadows out of view), but the system is consistent: the
  // minimum-norm solution reproduces the observation.
  const int rows = 8;
  const HemisphereMap map{rows};
  const Fixture f = MakeFixture(Eigen::Vector3d(0.8, 0.6, 0.5), rows, KnownMap(map));
  BaselineOptions options;
  options.map_rows = rows;
  const BaselineResult r = SolveBaseline(f.scene, f.pixels, f.casters, options);
  EXPECT_LT(r.rank, map.texels());
  for (size_t i = 0; i < f.pixels.size(); ++i)
    ASSERT_LT((r.render[i] - f.scene.image.rgb(f.pixels.pixel[i])).norm(),
              1e-3 * f.scene.image.rgb(f.pixels.pixel[i]).norm());
}

TEST(Baselines, SubsampledFitIsDeterministicAndClose) {
  const int rows = 6;
  const Fixture f = NoisyFixture(rows);
  BaselineOptions options;
  options.method = BaselineMethod::kSH21;
  options.map_rows = rows;
  const BaselineResult full = SolveBaseline(f.scene, f.pixels, f.casters, options);
  options.max_fit_pixels = 400;
  const BaselineResult a = SolveBaseline(f.scene, f.pixels, f.casters, options);
  const BaselineResult b = SolveBaseline(f.scene, f.pixels, f.casters, options);
  EXPECT_GT(full.fit_rows, 400);
  EXPECT_NEAR(a.fit_rows, 400, 1);
  EXPECT_EQ(a.envmap.data, b.envmap.data);
  // The sample's weighted Gram estimates the full one: the re-render stays close.
  double err = 0, ref = 0;
  for (size_t i = 0; i < f.pixels.size(); ++i) {
    err += (a.render[i] - full.render[i]).squaredNorm();
    ref += full.render[i].squaredNorm();
  }
  EXPECT_LT(std::sqrt(err / ref), 0.05);
}

TEST(Baselines, AlbedoGainRecoversASmoothAlbedoVariation) {
  // Observation rendered with a smooth albedo ramp; the scene given to the
  // solver claims a uniform albedo.
  const int rows = 6;
  const HemisphereMap map{rows};
  Fixture f{MakeScene(Eigen::Vector3d(0.7, 0.7, 0.7)), {}, {}};
  f.casters = BuildRayCaster(f.scene.Casters());
  f.pixels = FindPlanePixels(f.scene, f.casters);
  const LightTransport t(f.scene, f.pixels.point, f.casters, rows);
  const std::vector<Eigen::Vector3f> b = t.RenderAll(KnownMap(map));
  std::vector<double> ramp(f.pixels.size());
  double mean = 0;
  for (size_t i = 0; i < f.pixels.size(); ++i) mean += ramp[i] = 0.7 + 0.6 * (f.pixels.pixel[i] % kImageSize) / kImageSize;
  mean /= f.pixels.size();
  for (size_t i = 0; i < f.pixels.size(); ++i) f.scene.image.set_rgb(f.pixels.pixel[i], b[i] * ramp[i]);
  BaselineOptions options;
  options.method = BaselineMethod::kSH21;
  options.map_rows = rows;
  const BaselineResult plain = SolveBaseline(f.scene, f.pixels, f.casters, options);
  options.estimate_albedo = true;
  const BaselineResult joint = SolveBaseline(f.scene, f.pixels, f.casters, options);
  ASSERT_EQ(joint.albedo_gain.size(), f.pixels.size());
  EXPECT_TRUE(plain.albedo_gain.empty());
  EXPECT_EQ(joint.albedo_scale, 1.0);
  double gain_mean = 0, gain_error = 0, plain_se = 0, joint_se = 0;
  for (size_t i = 0; i < f.pixels.size(); ++i) {
    gain_mean += joint.albedo_gain[i];
    gain_error = std::max(gain_error, std::abs(joint.albedo_gain[i] - ramp[i] / mean));
    const Eigen::Vector3f obs = f.scene.image.rgb(f.pixels.pixel[i]);
    plain_se += (plain.render[i] - obs).squaredNorm();
    joint_se += (joint.render[i] - obs).squaredNorm();
  }
  EXPECT_NEAR(gain_mean / f.pixels.size(), 1.0, 1e-6);
  EXPECT_LT(gain_error, 0.05);
  EXPECT_LT(joint_se, 0.5 * plain_se);
}

TEST(Baselines, LaplacianIsTheGridGraphLaplacian) {
  const Eigen::MatrixXd d = Eigen::MatrixXd(HemisphereLaplacian(4));
  ASSERT_EQ(d.rows(), 64);
  EXPECT_LT((d - d.transpose()).norm(), 1e-15);
  EXPECT_LT((d * Eigen::VectorXd::Ones(64)).norm(), 1e-15);
  EXPECT_EQ(d(0, 0), 3);        // pole row: two azimuth neighbours and one below
  EXPECT_EQ(d(20, 20), 4);      // interior
  EXPECT_EQ(d(0, 15), -1);      // azimuth wraps
  EXPECT_EQ(d(0, 48), 0);       // no wrap from the pole row to the horizon row
}

TEST(Baselines, RejectsBadOptionsAndInput) {
  BaselineOptions options;
  std::string error;
  EXPECT_TRUE(options.IsValid(&error));
  options.map_rows = 0;
  EXPECT_FALSE(options.IsValid(&error));
  EXPECT_NE(error.find("map_rows"), std::string::npos);
  options = {};
  options.method = BaselineMethod::kSH21;
  options.laplacian_weight = options.identity_weight = 0;
  EXPECT_FALSE(options.IsValid(&error));
  options = {};
  options.laplacian_weight = -1;
  EXPECT_FALSE(options.IsValid(&error));
  BaselineMethod method;
  EXPECT_TRUE(ParseBaselineMethod("ss03+", &method));
  EXPECT_EQ(method, BaselineMethod::kSS03Plus);
  EXPECT_FALSE(ParseBaselineMethod("ss04", &method));

  Fixture f = MakeFixture(Eigen::Vector3d(0.8, 0.6, 0.5), 4, KnownMap(HemisphereMap{4}));
  options = {};
  options.map_rows = 99;
  EXPECT_THROW(SolveBaseline(f.scene, f.pixels, f.casters, options), InputError);
  EXPECT_THROW(SolveBaseline(f.scene, PlanePixels{kImageSize, kImageSize, {}, {}}, f.casters, {}), InputError);
  f.scene.plane.diffuse = Eigen::Vector3d(0.5, 0, 0.5);
  EXPECT_THROW(SolveBaseline(f.scene, f.pixels, f.casters, {}), InputError);
}

// A least-squares problem of m rows and n columns, entries drawn from
// `normal` (b's entry, then a's row, row by row).
void RandomLeastSquares(std::mt19937& rng, int m, int n, Eigen::MatrixXd* a, Eigen::VectorXd* b) {
  std::normal_distribution<double> normal;
  a->resize(m, n);
  b->resize(m);
  for (int i = 0; i < m; ++i) {
    (*b)[i] = normal(rng);
    for (int j = 0; j < n; ++j) (*a)(i, j) = normal(rng);
  }
}

TEST(Nnls, MatchesExhaustiveSearchAndKkt) {
  std::mt19937 rng(11);
  for (int trial = 0; trial < 20; ++trial) {
    const int m = 12, n = 6;
    Eigen::MatrixXd a;
    Eigen::VectorXd b;
    RandomLeastSquares(rng, m, n, &a, &b);
    const Eigen::MatrixXd h = a.transpose() * a;
    const Eigen::VectorXd f = a.transpose() * b;
    NnlsSummary summary;
    const Eigen::VectorXd x = SolveNnls(h, f, {}, &summary);
    EXPECT_TRUE(summary.converged);
    // Exhaustive: the best unconstrained LS over every support that is >= 0.
    double best = (a * Eigen::VectorXd::Zero(n) - b).squaredNorm();
    for (int mask = 1; mask < (1 << n); ++mask) {
      std::vector<int> cols;
      for (int j = 0; j < n; ++j)
        if (mask >> j & 1) cols.push_back(j);
      Eigen::MatrixXd sub(m, cols.size());
      for (size_t k = 0; k < cols.size(); ++k) sub.col(k) = a.col(cols[k]);
      const Eigen::VectorXd z = sub.colPivHouseholderQr().solve(b);
      if (z.minCoeff() >= 0) best = std::min(best, (sub * z - b).squaredNorm());
    }
    EXPECT_NEAR((a * x - b).squaredNorm(), best, 1e-9 * (1 + best));
    const Eigen::VectorXd gradient = h * x - f;
    for (int j = 0; j < n; ++j) {
      EXPECT_GE(x[j], 0);
      if (x[j] > 0) EXPECT_NEAR(gradient[j], 0, 1e-9);
      else EXPECT_GE(gradient[j], -1e-9);
    }
  }
}

// From any guess of the passive set (empty, all, the answer, a random
// half, indices repeated): the optimum of the cold start.
TEST(Nnls, WarmStartReachesTheColdOptimum) {
  std::mt19937 rng(9);
  std::uniform_int_distribution<int> coin(0, 1);
  for (int trial = 0; trial < 20; ++trial) {
    const int n = 15;
    Eigen::MatrixXd a;
    Eigen::VectorXd b;
    RandomLeastSquares(rng, 40, n, &a, &b);
    const Eigen::MatrixXd h = a.transpose() * a;
    const Eigen::VectorXd f = a.transpose() * b;
    const Eigen::VectorXd cold = SolveNnls(h, f);
    std::vector<int> all(n), answer, half;
    for (int j = 0; j < n; ++j) {
      all[j] = n - 1 - j;
      if (cold[j] > 0) answer.push_back(j);
      if (coin(rng)) half.push_back(j);
    }
    std::vector<int> twice = half;
    twice.insert(twice.end(), half.begin(), half.end());
    for (const std::vector<int>& start : {std::vector<int>{}, all, answer, half, twice}) {
      NnlsSummary summary;
      const Eigen::VectorXd warm = SolveNnls(h, f, start, {}, &summary);
      EXPECT_TRUE(summary.converged);
      EXPECT_LT((warm - cold).cwiseAbs().maxCoeff(), 1e-9 * (1 + cold.cwiseAbs().maxCoeff())) << trial;
      if (start == answer) {
        EXPECT_EQ(summary.iterations, 0) << trial;
      }
    }
  }
}

TEST(Nnls, LargeSemidefiniteProblem) {
  // More columns than rows (rank deficient Gram), as for a map whose texels
  // cannot all be told apart: still converges and satisfies KKT.
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> uniform(0, 1);
  const int m = 150, n = 300;
  Eigen::MatrixXd a(m, n);
  Eigen::VectorXd b(m);
  for (int i = 0; i < m; ++i) {
    b[i] = uniform(rng) - 0.3;
    for (int j = 0; j < n; ++j) a(i, j) = uniform(rng) < 0.8 ? uniform(rng) : 0.0;
  }
  const Eigen::MatrixXd h = a.transpose() * a;
  const Eigen::VectorXd f = a.transpose() * b;
  NnlsSummary summary;
  const Eigen::VectorXd x = SolveNnls(h, f, {}, &summary);
  EXPECT_TRUE(summary.converged);
  EXPECT_LE(summary.passive, m);
  const Eigen::VectorXd gradient = h * x - f;
  const double tol = 1e-8 * f.cwiseAbs().maxCoeff();
  for (int j = 0; j < n; ++j) {
    ASSERT_GE(x[j], 0);
    if (x[j] > 0) EXPECT_NEAR(gradient[j], 0, tol);
    else EXPECT_GE(gradient[j], -tol);
  }
}

}  // namespace
}  // namespace shadowsg
