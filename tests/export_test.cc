// `shadowsg export`: every lat-long layout round-trips through its file with
// the same irradiance, and the irradiance computed in the tool's own frame
// (its texel directions, its axes) is ours.
#include "stages/export_stage.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <sstream>

#include "calib/conventions.h"
#include "calib/error.h"
#include "solver/envmap.h"
#include "solver/metrics.h"
#include "stages/io/image_io.h"
#include "stages/io/lighting_io.h"
#include "quiet_context.h"
#include "test_util.h"

namespace shadowsg {
namespace {

namespace fs = std::filesystem;
using shadowsg::testing::TempDir;

using shadowsg::testing::QuietContext;

// A sky with a gradient, a sharp warm spot and a dark ground.
Image TestSky(int height) {
  const Eigen::Vector3d spot = Eigen::Vector3d(0.5, -0.3, 0.6).normalized();
  return MakeEnvMap(height, [&](const Eigen::Vector3d& d) -> Eigen::Vector3d {
    if (d.z() < 0) return Eigen::Vector3d(0.08, 0.06, 0.04);
    return (0.2 + 0.8 * d.z()) * Eigen::Vector3d(0.5, 0.7, 1.0) +
           std::exp(200 * (d.dot(spot) - 1)) * Eigen::Vector3d(60, 50, 35);
  });
}

// Normals over the whole sphere: the upper hemisphere's and their mirrors.
std::vector<Eigen::Vector3d> SphereNormals() {
  std::vector<Eigen::Vector3d> n = HemisphereNormals(kIrradianceNormals);
  const size_t k = n.size();
  for (size_t i = 0; i < k; ++i) n.push_back(-n[i]);
  return n;
}

// Largest relative irradiance error over the normals.
double WorstIrradianceError(const Image& reference, const std::function<Eigen::Vector3d(const Eigen::Vector3d&)>& e) {
  double worst = 0;
  for (const auto& n : SphereNormals()) {
    const Eigen::Vector3d r = EnvIrradiance(reference, n);
    worst = std::max(worst, (e(n) - r).norm() / r.norm());
  }
  return worst;
}

// Irradiance of a map in a tool's layout, integrated with the tool's own texel
// directions (`direction`, in the tool's frame) for a normal in its frame.
Eigen::Vector3d ToolIrradiance(const Image& map, const Eigen::Vector3d& normal,
                               const std::function<Eigen::Vector3d(double, double, int, int)>& direction) {
  Eigen::Vector3d e = Eigen::Vector3d::Zero();
  for (int v = 0; v < map.height; ++v) {
    const double dw = EnvTexelSolidAngle(v, map.width, map.height);  // rows are latitude bands in every layout
    for (int u = 0; u < map.width; ++u) {
      const double c = normal.dot(direction(u, v, map.width, map.height));
      if (c > 0) e += c * dw * map.rgb(map.index(u, v)).cast<double>();
    }
  }
  return e;
}

TEST(Export, EveryLayoutRoundTripsWithTheSameIrradiance) {
  TempDir tmp;
  const Image sky = TestSky(32);
  WriteExr(tmp / "sky.exr", sky);
  struct Case {
    const char* format;
    const char* file;
    const char* map;
    LatLongConvention convention;
  };
  for (const Case& c : {Case{"exr", "ours.exr", "ours.exr", LatLongConvention::kShadowSg},
                        Case{"openexr", "openexr.exr", "openexr.exr", LatLongConvention::kOpenExr},
                        Case{"usd", "dome.usda", "dome.exr", LatLongConvention::kOpenExr},
                        Case{"blender", "world.py", "world.exr", LatLongConvention::kBlender}}) {
    ExportOptions o;
    o.format = c.format;
    const auto written = RunExport(tmp / "sky.exr", tmp / c.file, o, QuietContext());
    ASSERT_FALSE(written.empty());
    EXPECT_EQ(written.front(), tmp / c.file);
    const Image exported = ReadExr(tmp / c.map);
    ASSERT_EQ(exported.height, 32);  // height 0: the map's own
    // Re-imported into our layout: at the same size every layout is an exact
    // texel permutation (W = 64 is a multiple of 4), so nothing changes.
    const Image back = EnvMapFromLatLong(exported, c.convention);
    EXPECT_EQ(back.data, sky.data) << c.format;
    const double round_trip = WorstIrradianceError(sky, [&](const Eigen::Vector3d& n) { return EnvIrradiance(back, n); });
    // In the tool's own frame, with its own texel directions.
    const double native = WorstIrradianceError(sky, [&](const Eigen::Vector3d& n) -> Eigen::Vector3d {
      switch (c.convention) {
        case LatLongConvention::kOpenExr:
          return ToolIrradiance(exported, WorldToUsdDirection(n), UsdTexelDirection);
        case LatLongConvention::kBlender:
          return ToolIrradiance(exported, n, BlenderTexelDirection);
        default:
          return ToolIrradiance(exported, n, EnvTexelDirection);
      }
    });
    std::printf("export %-8s round-trip irradiance error %.2e, in the tool's frame %.2e\n", c.format, round_trip,
                native);
    EXPECT_LT(round_trip, 1e-12);
    EXPECT_LT(native, 1e-9);
  }
  EXPECT_TRUE(ExrIsLatLong(tmp / "openexr.exr"));
  EXPECT_TRUE(ExrIsLatLong(tmp / "dome.exr"));
  EXPECT_FALSE(ExrIsLatLong(tmp / "ours.exr"));
}

TEST(Export, AnyHeightRoundTripsAndOddHeightsInterpolate) {
  // --height resamples in our layout first (ResampleEnvMap, area-weighted);
  // the layout conversion after it is exact for even heights and bilinear in
  // azimuth for odd ones (OpenEXR's texel centres then fall between ours).
  TempDir tmp;
  const Image sky = TestSky(32);
  WriteExr(tmp / "sky.exr", sky);
  for (const int height : {16, 48, 21}) {
    ExportOptions o;
    o.format = "openexr";
    o.height = height;
    RunExport(tmp / "sky.exr", tmp / "out.exr", o, QuietContext());
    const Image exported = ReadExr(tmp / "out.exr");
    ASSERT_EQ(exported.height, height);
    const Image back = EnvMapFromLatLong(exported, LatLongConvention::kOpenExr);
    const Image resampled = ResampleEnvMap(sky, height);
    const double layout = WorstIrradianceError(resampled, [&](const Eigen::Vector3d& n) { return EnvIrradiance(back, n); });
    const double resampling =
        WorstIrradianceError(sky, [&](const Eigen::Vector3d& n) { return EnvIrradiance(resampled, n); });
    std::printf("export openexr at H=%d: round-trip irradiance error %.2e (resampling 32 -> %d rows: %.2e)\n", height,
                layout, height, resampling);
    // Even heights: exact. Odd: each way averages two texels half a texel
    // apart (the area-weighted overlap), so the round trip blurs a 4-degree
    // spot by one 8.6-degree texel in azimuth.
    if (height % 2 == 0) EXPECT_EQ(back.data, resampled.data) << height;
    else EXPECT_LT(layout, 0.03) << height;
  }
}

TEST(Export, SgLightingAsMapScriptStageAndJson) {
  TempDir tmp;
  SgLighting sg;
  sg.lobes.push_back({Eigen::Vector3d(0.3, -0.4, 0.86).normalized(), 80, Eigen::Vector3d(20, 18, 15)});
  sg.lobes.push_back({Eigen::Vector3d::UnitZ(), 2, Eigen::Vector3d(0.3, 0.4, 0.5)});
  WriteSgLighting(tmp / "lighting.json", sg);

  // json: the lobes, unchanged.
  ExportOptions o;
  o.format = "json";
  RunExport(tmp / "lighting.json", tmp / "copy.json", o, QuietContext());
  const LightSet again = ReadLighting(tmp / "copy.json");
  ASSERT_TRUE(again.sg);
  ASSERT_EQ(again.sg->lobes.size(), 2u);
  EXPECT_NEAR((again.sg->lobes[0].axis - sg.lobes[0].axis).norm(), 0, 1e-12);

  // blender: SG at 256 rows, the world script names its map and builds the
  // Environment Texture -> Background -> World Output chain.
  o.format = "blender";
  RunExport(tmp / "lighting.json", tmp / "world.py", o, QuietContext());
  const Image map = ReadExr(tmp / "world.exr");
  EXPECT_EQ(map.height, 256);
  std::stringstream script;
  script << std::ifstream(tmp / "world.py").rdbuf();
  for (const char* s : {"world.exr", "ShaderNodeTexEnvironment", "ShaderNodeBackground", "ShaderNodeOutputWorld",
                        "scene.world = world", "Non-Color"})
    EXPECT_NE(script.str().find(s), std::string::npos) << s;
  // The map's irradiance is the lobes': SG integrals against the cosine.
  const Image ours = EnvMapFromLatLong(map, LatLongConvention::kBlender);
  const Eigen::Vector3d from_map = EnvIrradiance(ours, Eigen::Vector3d::UnitZ());
  const Eigen::Vector3d from_sg = EnvIrradiance(SgToEnvMap(sg, 1024), Eigen::Vector3d::UnitZ());
  EXPECT_NEAR((from_map - from_sg).norm() / from_sg.norm(), 0, 0.01);

  // usd: a y-up stage with a dome light on the map.
  o.format = "usd";
  RunExport(tmp / "lighting.json", tmp / "dome.usda", o, QuietContext());
  std::stringstream usda;
  usda << std::ifstream(tmp / "dome.usda").rdbuf();
  for (const char* s : {"#usda 1.0", "upAxis = \"Y\"", "def DomeLight", "@./dome.exr@", "\"latlong\""})
    EXPECT_NE(usda.str().find(s), std::string::npos) << s;

  // Wrong extension, wrong input for json, bad height.
  o.format = "openexr";
  EXPECT_THROW(RunExport(tmp / "lighting.json", tmp / "x.png", o, QuietContext()), InputError);
  WriteExr(tmp / "sky.exr", TestSky(8));
  o.format = "json";
  EXPECT_THROW(RunExport(tmp / "sky.exr", tmp / "x.json", o, QuietContext()), InputError);
  o.format = "exr";
  o.height = -1;
  EXPECT_THROW(RunExport(tmp / "sky.exr", tmp / "x.exr", o, QuietContext()), InputError);
}

}  // namespace
}  // namespace shadowsg
