#include "stages/synth_stage.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "calib/error.h"
#include "solver/metrics.h"
#include "solver/plane_pixels.h"
#include "stages/io/image_io.h"
#include "stages/io/lighting_io.h"
#include "stages/io/scene_io.h"
#include "stages/render_stage.h"
#include "quiet_context.h"
#include "test_util.h"

namespace shadowsg {
namespace {

namespace fs = std::filesystem;
using shadowsg::testing::TempDir;

const char* kSpec = R"({
  "format": "synth/1",
  "camera": {"width": 40, "height": 30, "fov_deg": 50,
             "look_from": [0.4, -2.0, 1.3], "look_at": [0, 0, 0.2]},
  "plane": {"xyz": [0, 0, 0], "normal": [0, 0, 1], "scale": [4, 4, 1], "diffuse": [1, 1, 1],
            "texture": {"checker": 4, "a": [0.8, 0.8, 0.8], "b": [0.4, 0.5, 0.6], "size": 64}},
  "objects": [
    {"mesh": {"primitive": "icosphere", "radius": 0.3, "subdivisions": 2},
     "position": [0, 0, 0], "rest_on_plane": true, "diffuse": [0.7, 0.7, 0.7]},
    {"mesh": {"primitive": "box", "half_extents": [0.1, 0.1, 0.1]}, "name": "cube",
     "position": [0.5, 0.3, 0.1], "rotate_deg": [0, 0, 30], "diffuse": [0.6, 0.3, 0.3], "is_train": false}
  ],
  "lights": {"suns": [{"direction": [0.4, 0.2, 0.9], "irradiance": [3, 3, 2.5], "angular_radius_deg": 1}],
             "lobes": [{"axis": [0, 0, 1], "sharpness": 2, "amplitude": [0.2, 0.3, 0.5]}]},
  "render": {"spp": 4, "bounces": 2, "seed": 3},
  "env_gt_height": 32
})";

fs::path WriteSpec(const TempDir& tmp, const std::string& text) {
  const fs::path p = tmp / "spec.json";
  std::ofstream(p) << text;
  return p;
}

using shadowsg::testing::QuietContext;

TEST(Synth, WritesASceneFolderThatLoadSceneAccepts) {
  TempDir tmp;
  const SynthSpec spec = ReadSynthSpec(WriteSpec(tmp, kSpec));
  ASSERT_EQ(spec.objects.size(), 2u);
  EXPECT_EQ(spec.objects[0].name, "mesh");
  EXPECT_EQ(spec.objects[1].name, "cube");
  // rest_on_plane put the sphere's lowest vertex on the plane.
  EXPECT_NEAR(spec.objects[0].o2w(2, 3), 0.3, 1e-9);
  EXPECT_EQ(spec.trace.samples_per_pixel, 4);
  EXPECT_EQ(spec.trace.seed, 3u);

  const fs::path out = tmp / "scene";
  const SynthResult r = RunSynthStage(spec, out, QuietContext());
  EXPECT_TRUE(r.has_virtual_objects);
  for (const char* f : {"scene.json", "image.exr", "image.png", "env_gt.exr", "image_virtual_objs.exr",
                        "lights.json", "plane_albedo.png", "geometry/mesh.obj", "geometry/cube.obj"})
    EXPECT_TRUE(fs::is_regular_file(out / f)) << f;

  const Scene scene = LoadScene(out);
  EXPECT_EQ(scene.camera.width, 40);
  EXPECT_EQ(scene.camera.height, 30);
  EXPECT_NEAR(scene.camera.cx, 19.5, 1e-12);
  ASSERT_EQ(scene.objects.size(), 2u);
  EXPECT_TRUE(scene.objects[0].is_train);
  EXPECT_FALSE(scene.objects[1].is_train);
  ASSERT_TRUE(scene.plane.albedo_texture);
  EXPECT_EQ(scene.plane.albedo_texture->width, 64);
  ASSERT_TRUE(scene.env_gt);
  EXPECT_EQ(scene.env_gt->height, 32);
  ASSERT_TRUE(scene.image_virtual_objs);
  EXPECT_NE(scene.image.data, scene.image_virtual_objs->data);

  // The lights round-trip through lights.json, and re-rendering the folder
  // with them and the spec's seed reproduces image.exr (up to the last bits
  // of the re-read light parameters).
  const LightSet lights = ReadLighting(out / "lights.json");
  ASSERT_EQ(lights.suns.size(), 1u);
  EXPECT_NEAR(lights.suns[0].angular_radius, M_PI / 180, 1e-12);
  ASSERT_TRUE(lights.sg);
  RenderStageOptions ro;
  ro.lighting = out / "lights.json";
  ro.out = tmp / "again.exr";
  ro.trace = spec.trace;
  ro.compare = true;
  const RenderStageResult again = RunRenderStage(out, ro, QuietContext());
  ASSERT_TRUE(again.metrics);
  EXPECT_GT(again.metrics->psnr, 60);
}

TEST(Synth, OverridesScaleTheCameraAboutPixelCentres) {
  TempDir tmp;
  SynthSpec spec = ReadSynthSpec(WriteSpec(tmp, kSpec));
  const Camera before = spec.camera;
  SynthOverrides o;
  o.resolution_scale = 0.5;
  o.samples_per_pixel = 2;
  o.seed = 11;
  ApplyOverrides(o, &spec);
  EXPECT_EQ(spec.camera.width, 20);
  EXPECT_EQ(spec.camera.height, 15);
  EXPECT_NEAR(spec.camera.cx, 9.5, 1e-12);
  EXPECT_NEAR(spec.camera.fx, before.fx / 2, 1e-12);
  EXPECT_EQ(spec.trace.samples_per_pixel, 2);
  EXPECT_EQ(spec.trace.seed, 11u);
}

TEST(Synth, BadSpecsNameTheFileAndKey) {
  TempDir tmp;
  std::string bad = kSpec;
  bad.replace(bad.find("\"fov_deg\": 50"), 13, "\"fov_deg\": 500");
  const fs::path p = WriteSpec(tmp, bad);
  try {
    ReadSynthSpec(p);
    FAIL() << "no error";
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("spec.json"), std::string::npos) << msg;
    EXPECT_NE(msg.find("camera.fov_deg"), std::string::npos) << msg;
  }
  std::string no_caster = kSpec;
  no_caster.replace(no_caster.find("\"diffuse\": [0.7, 0.7, 0.7]}"), 27,
                    "\"diffuse\": [0.7, 0.7, 0.7], \"is_train\": false}");
  EXPECT_THROW(ReadSynthSpec(WriteSpec(tmp, no_caster)), InputError);
}

TEST(Synth, BundledSampleSpecParses) {
  const fs::path sample = fs::path(SHADOWSG_SOURCE_DIR) / "data" / "sample" / "sample.json";
  ASSERT_TRUE(fs::exists(sample));
  const SynthSpec spec = ReadSynthSpec(sample);
  int casters = 0, virtuals = 0;
  for (const auto& o : spec.objects) (o.is_train ? casters : virtuals)++;
  EXPECT_EQ(casters, 1);
  EXPECT_GE(virtuals, 1);
  EXPECT_GT(spec.objects[0].mesh.faces.size(), 5000u);  // Spot
  EXPECT_FALSE(spec.lights.empty());
}

}  // namespace
}  // namespace shadowsg
