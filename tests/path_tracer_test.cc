#include "solver/path_tracer.h"

#include <gtest/gtest.h>
#include <omp.h>

#include <cmath>
#include <random>

#include "calib/camera.h"
#include "calib/conventions.h"
#include "solver/envmap.h"
#include "solver/light_envmap.h"
#include "solver/metrics.h"
#include "solver/plane_pixels.h"
#include "solver/primitives.h"
#include "solver/sg.h"

namespace shadowsg {
namespace {

// OpenCV-axes camera at `from` looking at `at`.
Eigen::Matrix4d LookAtC2w(const Eigen::Vector3d& from, const Eigen::Vector3d& at, const Eigen::Vector3d& up) {
  const Eigen::Vector3d z = (at - from).normalized();
  const Eigen::Vector3d x = z.cross(up).normalized();
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.block<3, 1>(0, 0) = x;
  m.block<3, 1>(0, 1) = z.cross(x);
  m.block<3, 1>(0, 2) = z;
  m.block<3, 1>(0, 3) = from;
  return m;
}

// A plane (albedo 0.5/0.6/0.7, normal +z) seen obliquely; every pixel hits it.
Scene PlaneScene(int size) {
  Scene s;
  s.camera.width = size;
  s.camera.height = size;
  s.camera.fx = s.camera.fy = size;
  s.camera.cx = s.camera.cy = (size - 1) / 2.0;
  s.camera.c2w = LookAtC2w({0.2, -1.5, 2.0}, {0, 0, 0}, Eigen::Vector3d::UnitZ());
  s.plane.scale = Eigen::Vector3d(10, 10, 1);
  s.plane.diffuse = Eigen::Vector3d(0.5, 0.6, 0.7);
  return s;
}

SceneObject Object(const TriangleMesh& mesh, const Eigen::Vector3d& position, const Eigen::Vector3d& albedo,
                   bool is_train = true) {
  SceneObject o;
  o.mesh = mesh;
  o.o2w.block<3, 1>(0, 3) = position;
  o.diffuse = albedo;
  o.is_train = is_train;
  return o;
}

Eigen::Vector3d MeanRgb(const Image& img) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (size_t p = 0; p < img.pixels(); ++p) sum += img.rgb(p).cast<double>();
  return sum / img.pixels();
}

// A sky with a gradient, a sharp bright spot and a brown ground below.
Image TestEnvMap(int height) {
  const Eigen::Vector3d spot = Eigen::Vector3d(0.4, 0.3, 0.8).normalized();
  return MakeEnvMap(height, [&](const Eigen::Vector3d& d) -> Eigen::Vector3d {
    if (d.z() < 0) return Eigen::Vector3d(0.3, 0.2, 0.1);
    return (0.2 + 0.8 * d.z()) * Eigen::Vector3d(0.6, 0.8, 1.0) +
           std::exp(60 * (d.dot(spot) - 1)) * Eigen::Vector3d(40, 30, 20);
  });
}

TEST(PathTracer, PlaneUnderEnvMapIsAlbedoOverPiTimesCosineIntegral) {
  const Scene scene = PlaneScene(32);
  LightSet lights;
  lights.env = TestEnvMap(32);
  PathTraceOptions opt;
  opt.samples_per_pixel = 32;
  opt.objects = RenderObjects::kNone;
  const Image img = RenderPathTraced(scene, lights, opt);
  const Eigen::Vector3d expected =
      scene.plane.diffuse.cwiseProduct(EnvIrradiance(*lights.env, Eigen::Vector3d::UnitZ())) / M_PI;
  const Eigen::Vector3d mean = MeanRgb(img);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(mean[c], expected[c], 0.01 * expected[c]) << "channel " << c;
  // Pixels on their own are within a few percent (cosine-product sampling).
  double sq = 0;
  for (size_t p = 0; p < img.pixels(); ++p)
    sq += ((img.rgb(p).cast<double>() - expected).cwiseQuotient(expected)).squaredNorm() / 3;
  EXPECT_LT(std::sqrt(sq / img.pixels()), 0.05);
}

TEST(PathTracer, DeltaSunOverPlaneIsClosedForm) {
  const Scene scene = PlaneScene(16);
  LightSet lights;
  SunLight sun;
  sun.direction = Eigen::Vector3d(1, 0.5, 1.2).normalized();
  sun.irradiance = Eigen::Vector3d(3, 2, 1);
  lights.suns.push_back(sun);
  PathTraceOptions opt;
  opt.samples_per_pixel = 4;
  const Eigen::Vector3d expected = scene.plane.diffuse.cwiseProduct(sun.irradiance) / M_PI * sun.direction.z();
  const Image img = RenderPathTraced(scene, lights, opt);
  for (size_t p = 0; p < img.pixels(); ++p)
    for (int c = 0; c < 3; ++c) ASSERT_NEAR(img.rgb(p)[c], expected[c], 1e-5 * expected[c]);

  // A disc of radiance E / (pi sin^2 a) gives the same irradiance E cos(theta).
  lights.suns[0].angular_radius = 5 * M_PI / 180;
  opt.samples_per_pixel = 16;
  const Eigen::Vector3d mean = MeanRgb(RenderPathTraced(scene, lights, opt));
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(mean[c], expected[c], 2e-3 * expected[c]);
}

// Does the ray p + t d (t > 0) meet the axis-aligned box [lo, hi]? (slabs)
bool RayHitsBox(const Eigen::Vector3d& p, const Eigen::Vector3d& d, const Eigen::Vector3d& lo,
                const Eigen::Vector3d& hi) {
  double t0 = 0, t1 = 1e30;
  for (int k = 0; k < 3; ++k) {
    if (std::abs(d[k]) < 1e-12) {
      if (p[k] < lo[k] || p[k] > hi[k]) return false;
      continue;
    }
    double a = (lo[k] - p[k]) / d[k], b = (hi[k] - p[k]) / d[k];
    if (a > b) std::swap(a, b);
    t0 = std::max(t0, a);
    t1 = std::min(t1, b);
  }
  return t0 <= t1;
}

TEST(PathTracer, SunShadowOfABoxFallsWhereGeometrySaysIt) {
  // Direct light only, from a delta sun: a plane pixel is 0 where the ray to
  // the sun meets the box and rho/pi E cos elsewhere (away from the edges).
  Scene scene = PlaneScene(64);
  const Eigen::Vector3d half(0.3, 0.2, 0.25);
  scene.objects.push_back(Object(MakeBox(half), {0, 0, 0.25}, Eigen::Vector3d::Constant(0.5)));
  LightSet lights;
  SunLight sun;
  sun.direction = Eigen::Vector3d(-0.5, 0.3, 0.8).normalized();
  lights.suns.push_back(sun);
  PathTraceOptions opt;
  opt.samples_per_pixel = 8;
  opt.max_bounces = 0;
  const Image img = RenderPathTraced(scene, lights, opt);
  const PlanePixels px = FindPlanePixels(scene, BuildRayCaster(scene.Casters()));
  const Image mask = PlanePixelMask(px);
  const double lit = scene.plane.diffuse.x() / M_PI * sun.direction.z();
  const Eigen::Vector3d lo(-half.x(), -half.y(), 0), hi(half.x(), half.y(), 2 * half.z());
  const Eigen::Vector3d margin = Eigen::Vector3d::Constant(0.04);  // > a pixel footprint
  int shadowed = 0, lit_pixels = 0;
  for (size_t i = 0; i < px.size(); ++i) {
    const Eigen::Vector3d& p = px.point[i];
    const float value = img.data[px.pixel[i] * 3];
    // Skip pixels next to the box's silhouette: their footprint sees the box.
    const int x = px.pixel[i] % scene.camera.width, y = px.pixel[i] / scene.camera.width;
    bool interior = x > 0 && y > 0 && x + 1 < scene.camera.width && y + 1 < scene.camera.height;
    for (int dy = -1; interior && dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) interior = interior && mask.at(x + dx, y + dy, 0) > 0;
    if (!interior) continue;
    if (RayHitsBox(p, sun.direction, lo + margin, hi - margin)) {
      EXPECT_EQ(value, 0.0f) << p.transpose();
      ++shadowed;
    } else if (!RayHitsBox(p, sun.direction, lo - margin, hi + margin)) {
      EXPECT_NEAR(value, lit, 1e-5) << p.transpose();
      ++lit_pixels;
    }
  }
  EXPECT_GT(shadowed, 50);
  EXPECT_GT(lit_pixels, 2000);
}

TEST(PathTracer, EnvMapTexelLightsLikeASunFromItsDirection) {
  // An env map that is dark but for one texel casts the box's shadow where a
  // sun along EnvTexelDirection(texel) does: the map's orientation, seen
  // through the renderer.
  Scene scene = PlaneScene(48);
  scene.objects.push_back(Object(MakeBox({0.3, 0.2, 0.25}), {0, 0, 0.25}, Eigen::Vector3d::Constant(0.5)));
  const int h = 256, w = 2 * h, u = 170, v = 50;
  Image env(w, h, 3, 0.0f);
  const double irradiance = 2.0;
  for (int c = 0; c < 3; ++c) env.at(u, v, c) = static_cast<float>(irradiance / EnvTexelSolidAngle(v, w, h));
  LightSet as_env, as_sun;
  as_env.env = env;
  as_sun.suns.push_back({EnvTexelDirection(u, v, w, h), Eigen::Vector3d::Constant(irradiance), 0.0});
  PathTraceOptions opt;
  opt.samples_per_pixel = 16;
  opt.max_bounces = 0;
  const Image a = RenderPathTraced(scene, as_env, opt);
  const Image b = RenderPathTraced(scene, as_sun, opt);
  const Image mask = PlanePixelMask(FindPlanePixels(scene, BuildRayCaster(scene.Casters())));
  const ImageMetrics m = CompareImages(a, b, mask);
  EXPECT_GT(m.psnr, 40.0);  // differences only in the penumbra of the 0.7-degree texel
  const Eigen::Vector3d ma = MeanRgb(a), mb = MeanRgb(b);
  EXPECT_NEAR(ma.x(), mb.x(), 0.01 * mb.x());
  // A texel on the other side of the map leaves the shadow elsewhere.
  Image flipped(w, h, 3, 0.0f);
  for (int c = 0; c < 3; ++c) flipped.at((u + w / 2) % w, v, c) = env.at(u, v, c);
  as_env.env = flipped;
  EXPECT_LT(CompareImages(RenderPathTraced(scene, as_env, opt), b, mask).psnr, 20.0);
}

TEST(PathTracer, SmallSphereAppearsWhereProjectToPixelPredicts) {
  // A black sphere against a uniform white background (no plane): the
  // coverage-weighted centroid of its pixels is the projection of its centre.
  Scene scene;
  Camera& c = scene.camera;
  c.width = 64;
  c.height = 48;
  c.fx = 60;
  c.fy = 64;
  c.cx = 30.2;
  c.cy = 25.7;
  c.c2w = LookAtC2w({0.3, -2.0, 1.0}, {0, 0, 0.2}, Eigen::Vector3d(0.1, 0, 1).normalized());
  const Eigen::Vector3d centre(0.15, 0.1, 0.25);
  scene.objects.push_back(Object(MakeIcosphere(0.12, 3), centre, Eigen::Vector3d::Zero()));
  LightSet lights;
  lights.env = MakeEnvMap(8, [](const Eigen::Vector3d&) { return Eigen::Vector3d::Ones(); });
  PathTraceOptions opt;
  opt.samples_per_pixel = 256;
  opt.include_plane = false;
  const Image img = RenderPathTraced(scene, lights, opt);
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  double weight = 0;
  for (int y = 0; y < c.height; ++y)
    for (int x = 0; x < c.width; ++x) {
      const double coverage = 1.0 - img.at(x, y, 0);
      sum += coverage * Eigen::Vector2d(x, y);
      weight += coverage;
    }
  ASSERT_GT(weight, 10);
  const auto predicted = ProjectToPixel(c, centre);
  ASSERT_TRUE(predicted);
  EXPECT_NEAR(sum.x() / weight, predicted->x(), 0.1);
  EXPECT_NEAR(sum.y() / weight, predicted->y(), 0.1);
}

TEST(PathTracer, SgLightingAndItsEnvMapRenderTheSame) {
  Scene scene = PlaneScene(48);
  scene.objects.push_back(Object(MakeBox({0.2, 0.2, 0.2}), {0, 0, 0.2}, Eigen::Vector3d::Constant(0.7)));
  SgLighting sg;
  sg.lobes.push_back({Eigen::Vector3d(0.3, 0.2, 0.9).normalized(), 40.0, Eigen::Vector3d(8, 6, 4)});
  sg.lobes.push_back({Eigen::Vector3d(-0.5, 0.3, 0.5).normalized(), 3.0, Eigen::Vector3d(0.5, 0.6, 0.8)});
  LightSet as_sg, as_env;
  as_sg.sg = sg;
  as_env.env = SgToEnvMap(sg, 128);
  PathTraceOptions opt;
  opt.samples_per_pixel = 64;
  const Image a = RenderPathTraced(scene, as_sg, opt);
  opt.seed = 1;
  const Image b = RenderPathTraced(scene, as_env, opt);
  const PlanePixels px = FindPlanePixels(scene, BuildRayCaster(scene.Casters()));
  const Image mask = PlanePixelMask(px);
  // They differ by no more than two renders of the same lighting do (noise).
  const ImageMetrics m = CompareImages(b, a, mask);
  opt.seed = 2;
  const ImageMetrics noise = CompareImages(RenderPathTraced(scene, as_sg, opt), a, mask);
  EXPECT_GT(m.psnr, noise.psnr - 1.0);
  EXPECT_GT(m.psnr, 25.0);
  const Eigen::Vector3d ma = MeanRgb(a), mb = MeanRgb(b);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(mb[c], ma[c], 0.01 * ma[c]);
}

TEST(PathTracer, AreaLightMatchesQuadrature) {
  // A 0.5 x 0.5 light facing down at height 1; camera straight down.
  Scene scene = PlaneScene(16);
  scene.camera.c2w = LookAtC2w({0, 0, 3}, {0, 0, 0}, Eigen::Vector3d::UnitY());
  scene.camera.fx = scene.camera.fy = 40;  // 16 px cover ~0.4 x 0.4 on the plane
  AreaLight a;
  a.centre = Eigen::Vector3d(0.1, 0, 1);
  a.half_u = Eigen::Vector3d(0.25, 0, 0);
  a.half_v = Eigen::Vector3d(0, -0.25, 0);  // normal half_u x half_v = -z
  a.radiance = Eigen::Vector3d(4, 3, 2);
  LightSet lights;
  lights.areas.push_back(a);
  PathTraceOptions opt;
  opt.samples_per_pixel = 256;
  opt.objects = RenderObjects::kNone;
  const Image img = RenderPathTraced(scene, lights, opt);
  // Irradiance at p by midpoint quadrature over the light.
  auto irradiance = [&](const Eigen::Vector3d& p) {
    const int n = 200;
    double e = 0;
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) {
        const Eigen::Vector3d q = a.centre + (2 * (i + 0.5) / n - 1) * a.half_u + (2 * (j + 0.5) / n - 1) * a.half_v;
        const Eigen::Vector3d d = q - p;
        const double r2 = d.squaredNorm();
        e += d.z() * d.z() / (r2 * r2) * a.Area() / (n * n);  // cos_p cos_l / r^2 dA, both cos = dz / r
      }
    return e;
  };
  double sum_rendered = 0, sum_expected = 0;
  for (int y = 0; y < 16; y += 3)
    for (int x = 0; x < 16; x += 3) {
      const Ray r = PixelRay(scene.camera, x, y);
      const Eigen::Vector3d p = r.origin + (-r.origin.z() / r.dir.z()) * r.dir;
      const double expected = scene.plane.diffuse.x() / M_PI * a.radiance.x() * irradiance(p);
      EXPECT_NEAR(img.at(x, y, 0), expected, 0.05 * expected) << x << "," << y;
      sum_rendered += img.at(x, y, 0);
      sum_expected += expected;
    }
  EXPECT_NEAR(sum_rendered, sum_expected, 0.01 * sum_expected);

  // One-sided: turned to face up, it lights nothing below.
  std::swap(lights.areas[0].half_u, lights.areas[0].half_v);
  EXPECT_EQ(MeanRgb(RenderPathTraced(scene, lights, opt)).norm(), 0.0);
}

TEST(PathTracer, PlaneTextureMultipliesAlbedo) {
  Scene scene = PlaneScene(32);
  scene.camera.c2w = LookAtC2w({0, 0, 3}, {0, 0, 0}, Eigen::Vector3d::UnitY());
  scene.camera.fx = scene.camera.fy = 40;  // the view spans about +-1.2 on the plane
  scene.plane.scale = Eigen::Vector3d(1, 1, 1);
  scene.plane.diffuse = Eigen::Vector3d(1, 1, 0.5);
  // Quadrants: top-left red, top-right green, bottom-left blue, bottom-right white.
  Image tex(4, 4, 3);
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 4; ++x)
      tex.set_rgb(tex.index(x, y), y < 2 ? (x < 2 ? Eigen::Vector3f(1, 0, 0) : Eigen::Vector3f(0, 1, 0))
                                         : (x < 2 ? Eigen::Vector3f(0, 0, 1) : Eigen::Vector3f(1, 1, 1)));
  scene.plane.albedo_texture = tex;
  EXPECT_NEAR((PlaneAlbedo(scene.plane, {-0.6, 0.6, 0}) - Eigen::Vector3d(1, 0, 0)).norm(), 0, 1e-6);
  EXPECT_NEAR((PlaneAlbedo(scene.plane, {0.6, 0.6, 0}) - Eigen::Vector3d(0, 1, 0)).norm(), 0, 1e-6);
  EXPECT_NEAR((PlaneAlbedo(scene.plane, {-0.6, -0.6, 0}) - Eigen::Vector3d(0, 0, 0.5)).norm(), 0, 1e-6);
  LightSet lights;  // a zenith sun of irradiance pi: the plane shows its albedo
  lights.suns.push_back({Eigen::Vector3d::UnitZ(), Eigen::Vector3d::Constant(M_PI), 0.0});
  PathTraceOptions opt;
  opt.samples_per_pixel = 16;
  opt.objects = RenderObjects::kNone;
  const Image img = RenderPathTraced(scene, lights, opt);
  // The camera looks down with image-up = +y: the image's top-left shows the
  // texture's top-left, and a pixel off the rectangle sees the black sky.
  auto pixel_at = [&](const Eigen::Vector3d& p) {
    const Eigen::Vector2d uv = *ProjectToPixel(scene.camera, p);
    return img.rgb(img.index(static_cast<int>(std::lround(uv.x())), static_cast<int>(std::lround(uv.y()))));
  };
  EXPECT_NEAR((pixel_at({-0.6, 0.6, 0}) - Eigen::Vector3f(1, 0, 0)).norm(), 0, 1e-5);
  EXPECT_NEAR((pixel_at({0.6, -0.6, 0}) - Eigen::Vector3f(1, 1, 0.5)).norm(), 0, 1e-5);
  EXPECT_EQ(pixel_at({1.15, 0, 0}).norm(), 0.0f);
}

// PlaneRectContains keeps the last plane's rotation on each thread: planes
// of different normals asked in turn must each get their own rectangle.
TEST(PathTracer, PlaneRectContainsFollowsEachPlaneItIsGiven) {
  Plane flat, tilted;
  flat.scale = Eigen::Vector3d(1.0, 0.2, 1);
  tilted.scale = flat.scale;
  tilted.xyz = Eigen::Vector3d(0.1, -0.2, 0.3);
  tilted.normal = Eigen::Vector3d(1, 0.5, 0.8).normalized();
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-1.2, 1.2);
  int differ = 0;
  for (int i = 0; i < 2000; ++i) {
    // A point of either plane, tested against both in turn.
    const Plane& own = i % 2 ? tilted : flat;
    const Eigen::Matrix3d to_world = MinimalRotationToZ(own.normal).transpose();
    const Eigen::Vector3d p = own.xyz + to_world * Eigen::Vector3d(u(rng), u(rng), 0);
    bool answers[2];
    for (int k = 0; k < 2; ++k) {
      const Plane& plane = k ? tilted : flat;
      const Eigen::Vector3d local = MinimalRotationToZ(plane.normal) * (p - plane.xyz);
      const bool inside = std::abs(local.x()) <= plane.scale.x() && std::abs(local.y()) <= plane.scale.y();
      answers[k] = PlaneRectContains(plane, p);
      ASSERT_EQ(answers[k], inside) << "point " << i << ", plane " << k;
    }
    differ += answers[0] != answers[1];
  }
  EXPECT_GT(differ, 200);  // the two rectangles disagree often enough to tell them apart
}

TEST(PathTracer, DeterministicForAnyThreadCountAndSeedDependent) {
  Scene scene = PlaneScene(24);
  scene.objects.push_back(Object(MakeIcosphere(0.3, 2), {0, 0, 0.35}, Eigen::Vector3d::Constant(0.6)));
  LightSet lights;
  lights.env = TestEnvMap(16);
  lights.suns.push_back({Eigen::Vector3d(0.3, 0.1, 1).normalized(), Eigen::Vector3d::Ones(), 0.02});
  PathTraceOptions opt;
  opt.samples_per_pixel = 4;
  const int saved = omp_get_max_threads();
  omp_set_num_threads(1);
  const Image one = RenderPathTraced(scene, lights, opt);
  omp_set_num_threads(2);
  const Image two = RenderPathTraced(scene, lights, opt);
  omp_set_num_threads(saved);
  EXPECT_EQ(one.data, two.data);
  opt.seed = 99;
  EXPECT_NE(RenderPathTraced(scene, lights, opt).data, one.data);
}

// The per-sample split the compositor uses: asking for it leaves the image
// as it is, and matte-weighted object and rest radiances recombine into it.
TEST(PathTracer, VirtualObjectSplitRecombinesIntoTheImage) {
  Scene scene = PlaneScene(24);
  scene.objects.push_back(Object(MakeIcosphere(0.3, 2), {0, 0, 0.35}, Eigen::Vector3d::Constant(0.6)));
  scene.objects.push_back(Object(MakeIcosphere(0.2, 2), {0.5, -0.3, 0.25}, Eigen::Vector3d(0.7, 0.3, 0.2), false));
  LightSet lights;
  lights.env = TestEnvMap(16);
  PathTraceOptions opt;
  opt.samples_per_pixel = 8;
  opt.objects = RenderObjects::kAll;
  const Image plain = RenderPathTraced(scene, lights, opt);
  VirtualObjectSplit split;
  const Image image = RenderPathTraced(scene, lights, opt, {}, &split);
  EXPECT_EQ(plain.data, image.data);
  int full = 0, partial = 0;
  for (size_t p = 0; p < image.pixels(); ++p) {
    const float a = split.coverage.data[p];
    ASSERT_GE(a, 0.0f);
    ASSERT_LE(a, 1.0f);
    full += a == 1.0f;
    partial += a > 0.0f && a < 1.0f;
    const Eigen::Vector3f mix = a * split.object_radiance.rgb(p) + (1 - a) * split.rest_radiance.rgb(p);
    EXPECT_NEAR((mix - image.rgb(p)).norm(), 0, 1e-5 * (1 + image.rgb(p).norm()));
  }
  EXPECT_GT(full, 0);
  EXPECT_GT(partial, 0);  // the edges are anti-aliased
  // Casters are not in the matte.
  opt.objects = RenderObjects::kCasters;
  RenderPathTraced(scene, lights, opt, {}, &split);
  for (float a : split.coverage.data) ASSERT_EQ(a, 0.0f);
}

TEST(PathTracer, ProgressExceptionStopsTheRender) {
  const Scene scene = PlaneScene(16);
  LightSet lights;
  lights.suns.push_back(SunLight{});
  PathTraceOptions opt;
  opt.samples_per_pixel = 1;
  int calls = 0;
  EXPECT_THROW(RenderPathTraced(scene, lights, opt,
                                [&](double f, const std::string&) {
                                  if (++calls == 3) throw std::runtime_error("stop");
                                }),
               std::runtime_error);
}

TEST(PathTracer, OptionsAreChecked) {
  PathTraceOptions opt;
  std::string error;
  EXPECT_TRUE(opt.IsValid(&error));
  opt.samples_per_pixel = 0;
  EXPECT_FALSE(opt.IsValid(&error));
  EXPECT_NE(error.find("samples"), std::string::npos);
  opt.samples_per_pixel = 1;
  opt.max_bounces = -1;
  EXPECT_FALSE(opt.IsValid(&error));
}

TEST(LightEnvMap, SunsAndAreaLightsKeepTheirIrradiance) {
  LightSet lights;
  lights.suns.push_back({Eigen::Vector3d(0.5, -0.2, 0.8).normalized(), Eigen::Vector3d(3, 2, 1), 0.0});
  lights.suns.push_back({Eigen::Vector3d(-0.3, 0.4, 0.6).normalized(), Eigen::Vector3d(1, 1, 1), 0.05});
  LightEnvMapOptions opt;
  opt.height = 256;
  const Image env = LightSetToEnvMap(lights, opt);
  const Eigen::Vector3d n = Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d expected =
      lights.suns[0].irradiance * lights.suns[0].direction.z() + lights.suns[1].irradiance * lights.suns[1].direction.z();
  const Eigen::Vector3d e = EnvIrradiance(env, n);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(e[c], expected[c], 0.01 * expected[c]);

  // An area light above the viewpoint: the map's irradiance there equals the
  // light's (quadrature over the rectangle).
  LightSet area;
  AreaLight a;
  a.centre = Eigen::Vector3d(0.5, 0.2, 2);
  a.half_u = Eigen::Vector3d(0.4, 0, 0);
  a.half_v = Eigen::Vector3d(0, -0.3, 0);
  a.radiance = Eigen::Vector3d(2, 2, 2);
  area.areas.push_back(a);
  opt.height = 128;
  const Image env_area = LightSetToEnvMap(area, opt);
  double quad = 0;
  const int k = 200;
  for (int i = 0; i < k; ++i)
    for (int j = 0; j < k; ++j) {
      const Eigen::Vector3d q = a.centre + (2 * (i + 0.5) / k - 1) * a.half_u + (2 * (j + 0.5) / k - 1) * a.half_v;
      quad += q.z() * q.z() / std::pow(q.squaredNorm(), 2) * a.Area() / (k * k);
    }
  EXPECT_NEAR(EnvIrradiance(env_area, n).x(), 2 * quad, 0.01 * 2 * quad);
}

}  // namespace
}  // namespace shadowsg
