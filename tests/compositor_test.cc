// The object-insertion compositor (solver/compositor.h) and the composite
// stage, on a scene synthesised by the project's path tracer: a checkered
// plane, a sphere caster and a virtual sphere beside it under a sun-like and a
// sky SG lobe, with image_virtual_objs.exr as ground truth.
#include "solver/compositor.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include "calib/conventions.h"
#include "calib/error.h"
#include "solver/light_envmap.h"
#include "solver/plane_pixels.h"
#include "stages/composite_stage.h"
#include "stages/eval_stage.h"
#include "stages/io/image_io.h"
#include "stages/io/json_util.h"
#include "stages/io/lighting_io.h"
#include "stages/io/scene_io.h"
#include "stages/render_stage.h"
#include "stages/sphere_tree_stage.h"
#include "stages/synth_stage.h"
#include "quiet_context.h"
#include "test_util.h"

namespace shadowsg {
namespace {

namespace fs = std::filesystem;
using shadowsg::testing::TempDir;

// 96 x 96, 64 spp: small enough for the sanitizer pass.
const char* kSpec = R"({
  "format": "synth/1",
  "camera": {"width": 96, "height": 96, "fov_deg": 45,
             "look_from": [0.5, -2.2, 1.7], "look_at": [0.15, 0.0, 0.1]},
  "plane": {"xyz": [0, 0, 0], "normal": [0, 0, 1], "scale": [3, 3, 1], "diffuse": [1, 1, 1],
            "texture": {"checker": 8, "a": [0.8, 0.8, 0.8], "b": [0.45, 0.55, 0.65], "size": 64}},
  "objects": [
    {"mesh": {"primitive": "icosphere", "radius": 0.25, "subdivisions": 2},
     "position": [-0.2, 0.1, 0], "rest_on_plane": true, "diffuse": [0.7, 0.7, 0.7]},
    {"mesh": {"primitive": "icosphere", "radius": 0.18, "subdivisions": 2}, "name": "ball",
     "position": [0.45, -0.25, 0], "rest_on_plane": true, "diffuse": [0.65, 0.3, 0.25], "is_train": false}
  ],
  "lights": {"lobes": [{"axis": [-0.5, 0.35, 0.79], "sharpness": 300, "amplitude": [140, 130, 115]},
                       {"axis": [0, 0, 1], "sharpness": 1.5, "amplitude": [0.25, 0.32, 0.45]}]},
  "render": {"spp": 64, "bounces": 2, "seed": 0},
  "env_gt_height": 64
})";

using shadowsg::testing::QuietContext;

// One synthesised scene for the whole suite (rendering it is the slow part).
class Composite : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new fs::path(fs::temp_directory_path() / ("shadowsg_Composite_" + std::to_string(getpid())));
    fs::remove_all(*dir_);
    fs::create_directories(*dir_);
    std::ofstream(*dir_ / "spec.json") << kSpec;
    RunSynthStage(ReadSynthSpec(*dir_ / "spec.json"), *dir_ / "scene", QuietContext());
  }
  static void TearDownTestSuite() {
    std::error_code ec;
    fs::remove_all(*dir_, ec);
    delete dir_;
  }
  static fs::path SceneDir() { return *dir_ / "scene"; }
  // The scene with sphere trees on every object (the preview needs them).
  static Scene LoadWithTrees() {
    Scene scene = LoadScene(SceneDir());
    EnsureCompositeTrees(scene, SceneDir(), QuietContext());
    return scene;
  }
  static LightSet TrueLights() { return ReadLighting(SceneDir() / "lights.json"); }

  static fs::path* dir_;
};
fs::path* Composite::dir_ = nullptr;

double InsertPsnr(const Scene& scene, const Image& composite) {
  const auto m = CompareWithPhotograph(scene, composite, RenderObjects::kAll);
  EXPECT_TRUE(m.has_value());
  return m ? m->psnr : 0;
}

TEST_F(Composite, FinalMatchesThePathTracedTruthAndPreviewIsClose) {
  const Scene scene = LoadWithTrees();
  ASSERT_TRUE(scene.image_virtual_objs);
  ASSERT_EQ(scene.VirtualObjects().size(), 1u);
  const LightSet lights = TrueLights();
  ASSERT_TRUE(lights.sg);

  // The synth used seed 0; another seed makes the test honest (with the same
  // seed and spp the two renders would reproduce image.exr and the truth).
  CompositeOptions final_options;
  final_options.samples_per_pixel = 64;
  final_options.max_bounces = 2;
  final_options.seed = 1;
  const CompositeResult final_result = CompositeVirtualObjects(scene, lights, final_options);
  CompositeOptions preview_options;
  preview_options.quality = CompositeQuality::kPreview;
  const CompositeResult preview_result = CompositeVirtualObjects(scene, lights, preview_options);

  const double final_psnr = InsertPsnr(scene, final_result.composite);
  const double preview_psnr = InsertPsnr(scene, preview_result.composite);
  // Photo alone (no insertion at all), for scale.
  const double photo_psnr = InsertPsnr(scene, scene.image);
  std::printf("insert_psnr: final %.2f dB, preview %.2f dB, photo without insertion %.2f dB\n", final_psnr,
              preview_psnr, photo_psnr);
  EXPECT_GE(final_psnr, 35.0);
  EXPECT_GE(preview_psnr, 30.0);
  EXPECT_GT(preview_psnr, photo_psnr + 3);
  EXPECT_EQ(final_result.additive_channels, 0u);

  // The layers recombine into the composite where the ratio was used.
  const Image& o = final_result.objects;
  double worst = 0;
  for (size_t p = 0; p < scene.image.pixels(); ++p)
    for (int c = 0; c < 3; ++c) {
      const double a = o.data[p * 4 + 3];
      if (a >= 1) continue;
      const double rebuilt = o.data[p * 4 + c] + (1 - a) * scene.image.data[p * 3 + c] * final_result.shadow.data[p * 3 + c];
      worst = std::max(worst, std::abs(rebuilt - final_result.composite.data[p * 3 + c]));
    }
  EXPECT_LT(worst, 1e-4);

  // The matte covers the virtual ball's pixels: its share of the image is
  // about its projected area, and both levels agree on it.
  double final_cover = 0, preview_cover = 0;
  for (size_t p = 0; p < scene.image.pixels(); ++p) {
    final_cover += final_result.objects.data[p * 4 + 3];
    preview_cover += preview_result.objects.data[p * 4 + 3];
  }
  EXPECT_GT(final_cover, 50);
  EXPECT_NEAR(preview_cover / final_cover, 1.0, 0.05);

  // On the ball itself (pixels both levels see fully covered) the preview's
  // closed-form shading is close to the path tracer's on average.
  double diff = 0, sum = 0;
  for (size_t p = 0; p < scene.image.pixels(); ++p) {
    if (final_result.objects.data[p * 4 + 3] < 1 || preview_result.objects.data[p * 4 + 3] < 1) continue;
    for (int c = 0; c < 3; ++c) {
      diff += std::abs(preview_result.composite.data[p * 3 + c] - final_result.composite.data[p * 3 + c]);
      sum += final_result.composite.data[p * 3 + c];
    }
  }
  std::printf("object pixels: preview vs final mean relative difference %.1f %%\n", 100 * diff / sum);
  EXPECT_LT(diff / sum, 0.2);
}

TEST_F(Composite, EnvMapLightingWorksAtBothLevels) {
  // The same lighting as an env map (as the baselines estimate it): the
  // composite must still carry the ball's shadow.
  const Scene scene = LoadWithTrees();
  LightEnvMapOptions eo;
  eo.height = 128;
  LightSet env;
  env.env = LightSetToEnvMap(TrueLights(), eo);
  CompositeOptions options;
  options.samples_per_pixel = 32;
  options.max_bounces = 2;
  options.seed = 2;
  const double final_psnr = InsertPsnr(scene, CompositeVirtualObjects(scene, env, options).composite);
  options.quality = CompositeQuality::kPreview;
  const double preview_psnr = InsertPsnr(scene, CompositeVirtualObjects(scene, env, options).composite);
  const double photo_psnr = InsertPsnr(scene, scene.image);
  std::printf("env map lighting: insert_psnr final %.2f dB, preview %.2f dB (photo %.2f dB)\n", final_psnr,
              preview_psnr, photo_psnr);
  EXPECT_GE(final_psnr, 32.0);
  EXPECT_GT(preview_psnr, photo_psnr + 3);
}

TEST_F(Composite, NoVirtualObjectsGiveThePhotoBitForBit) {
  Scene scene = LoadWithTrees();
  std::erase_if(scene.objects, [](const SceneObject& o) { return !o.is_train; });
  const LightSet lights = TrueLights();
  const PlanePixels plane = FindPlanePixels(scene, BuildRayCaster(scene.Casters()));
  ASSERT_GT(plane.size(), 1000u);
  for (const CompositeQuality q : {CompositeQuality::kFinal, CompositeQuality::kPreview}) {
    CompositeOptions options;
    options.quality = q;
    options.samples_per_pixel = 4;
    const CompositeResult r = CompositeVirtualObjects(scene, lights, options);
    size_t differ = 0;
    for (int p : plane.pixel)
      for (int c = 0; c < 3; ++c) differ += r.composite.data[p * 3 + c] != scene.image.data[p * 3 + c];
    EXPECT_EQ(differ, 0u) << (q == CompositeQuality::kFinal ? "final" : "preview");
    // Everywhere else too, and the object layer is empty.
    EXPECT_EQ(r.composite.data, scene.image.data);
    for (size_t p = 0; p < scene.image.pixels(); ++p) ASSERT_EQ(r.objects.data[p * 4 + 3], 0.0f);
  }
}

TEST_F(Composite, StageWritesLayersAndScoresOnlyTheScenesOwnObjects) {
  TempDir tmp;
  CompositeStageOptions options;
  options.lighting = SceneDir() / "lights.json";
  options.composite.quality = CompositeQuality::kPreview;
  const Json m = RunComposite(SceneDir(), tmp / "own", options, QuietContext());
  for (const char* f : {"composite.exr", "composite.png", "shadow.exr", "objects.exr", "side_by_side.png",
                        "metrics.json"})
    EXPECT_TRUE(fs::is_regular_file(tmp / "own" / f)) << f;
  ASSERT_TRUE(m["insert_psnr"].is_number());
  EXPECT_GT(m["insert_psnr"].get<double>(), 30);
  EXPECT_TRUE(m["insert_ssim"].is_number());
  EXPECT_EQ(m["virtual_objects"].get<int>(), 1);
  const Json on_disk = ReadJsonFile(tmp / "own" / "metrics.json");
  EXPECT_EQ(on_disk["insert_psnr"], m["insert_psnr"]);
  const Image objects = ReadExr(tmp / "own" / "objects.exr", true);
  EXPECT_EQ(objects.channels, 4);
  const Image side = ReadLdr(tmp / "own" / "side_by_side.png");
  EXPECT_EQ(side.width, 2 * 96);

  // The same ball from an objects file: same composite, but not scored (the
  // ground truth shows the scene's own objects).
  const Scene scene = LoadScene(SceneDir());
  const SceneObject& ball = *scene.VirtualObjects()[0];
  Json entry;
  entry["path_to_mesh"] = fs::absolute(SceneDir() / ball.mesh_path).string();
  entry["o2w"] = ToJson(ball.o2w);
  entry["diffuse"] = ToJson(ball.diffuse);
  WriteJsonFile(tmp / "objects.json", Json{{"format", "objects/1"}, {"objects", Json::array({entry})}});
  options.objects = tmp / "objects.json";
  const Json m2 = RunComposite(SceneDir(), tmp / "file", options, QuietContext());
  EXPECT_TRUE(m2["insert_psnr"].is_null());
  EXPECT_EQ(ReadExr(tmp / "file" / "composite.exr").data, ReadExr(tmp / "own" / "composite.exr").data);

  // Bad inputs stop with a message naming them.
  options.objects.clear();
  options.composite.supersampling = 0;
  EXPECT_THROW(RunComposite(SceneDir(), tmp / "bad", options, QuietContext()), InputError);
}

TEST_F(Composite, EvalReportsInsertionScores) {
  // solve and eval share ScoreAndWrite, which scores the preview composite.
  TempDir tmp;
  EvalOptions options;
  RunEval(SceneDir(), SceneDir() / "lights.json", tmp / "eval", options, QuietContext());
  const Json m = ReadJsonFile(tmp / "eval" / "metrics.json");
  ASSERT_TRUE(m["insert_psnr"].is_number());
  EXPECT_GT(m["insert_psnr"].get<double>(), 30);
  EXPECT_TRUE(m["insert_ssim"].is_number());
}

TEST(CompositeLobes, EnvTexelsAndSunsKeepTheirPower) {
  // A map with one bright texel and a uniform sky: the lobes' integrals sum to
  // the map's (its power), and a sun lobe integrates to its irradiance.
  const int h = 16;
  Image env(2 * h, h, 3, 0.5f);
  env.set_rgb(env.index(5, 3), Eigen::Vector3f(40, 30, 20));
  const SgLighting sg = EnvMapToSgLobes(env, h);
  EXPECT_EQ(sg.lobes.size(), static_cast<size_t>(2 * h * h));
  Eigen::Vector3d lobes = Eigen::Vector3d::Zero(), map = Eigen::Vector3d::Zero();
  for (const auto& l : sg.lobes) lobes += SgIntegral(l);
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < 2 * h; ++u) map += env.rgb(env.index(u, v)).cast<double>() * EnvTexelSolidAngle(v, 2 * h, h);
  EXPECT_NEAR((lobes - map).norm() / map.norm(), 0, 1e-9);

  SunLight sun;
  sun.direction = Eigen::Vector3d(0.3, 0.2, 0.9).normalized();
  sun.irradiance = Eigen::Vector3d(3, 2.5, 2);
  sun.angular_radius = 0.5 * M_PI / 180;
  const SgLobe lobe = SunToSgLobe(sun);
  EXPECT_NEAR((SgIntegral(lobe) - sun.irradiance).norm(), 0, 1e-9);
  EXPECT_NEAR(lobe.sharpness, 2 / (sun.angular_radius * sun.angular_radius), 1e-6);
}

}  // namespace
}  // namespace shadowsg
