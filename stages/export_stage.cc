#include "stages/export_stage.h"

#include <cstdio>

#include "calib/conventions.h"
#include "calib/error.h"
#include "solver/envmap.h"
#include "solver/light_envmap.h"
#include "stages/evaluation.h"
#include "stages/io/atomic_file.h"
#include "stages/io/image_io.h"
#include "stages/io/json_util.h"
#include "stages/io/lighting_io.h"
#include "stages/stage_util.h"

namespace shadowsg {
namespace fs = std::filesystem;

namespace {

constexpr int kMaxExportHeight = 8192;

// The extension each format's main file must have.
const char* MainExtension(const std::string& format) {
  if (format == "usd") return ".usda";
  if (format == "blender") return ".py";
  if (format == "json") return ".json";
  return ".exr";
}

// A string as a double-quoted literal that Python and USD both read back
// unchanged (JSON's escapes are a subset of theirs).
std::string Quoted(const std::string& s) { return Json(s).dump(); }

std::string UsdStage(const std::string& map_name) {
  return "#usda 1.0\n"
         "(\n"
         "    doc = \"shadowsg lighting (shadowsg export --format usd). The stage is y-up: shadowsg's z-up world "
         "maps to it by (x, y, z) -> (x, z, -y), so place the scene's geometry with the same rotation.\"\n"
         "    upAxis = \"Y\"\n"
         ")\n"
         "\n"
         "def DomeLight \"ShadowSgDome\"\n"
         "{\n"
         "    float inputs:intensity = 1\n"
         "    float inputs:exposure = 0\n"
         "    asset inputs:texture:file = @./" + map_name + "@\n"
         "    token inputs:texture:format = \"latlong\"\n"
         "}\n";
}

}  // namespace

std::string ExportOptions::Validate() const {
  if (format != "exr" && format != "openexr" && format != "usd" && format != "blender" && format != "json")
    return "--format: expected exr, openexr, usd, blender or json";
  if (height < 0 || height > kMaxExportHeight)
    return "--height: expected 1 to " + std::to_string(kMaxExportHeight) + " rows (0: the lighting's own)";
  return "";
}

Image ExportEnvMap(const LightSet& lights, int height) {
  if (height == 0) {
    const bool map_only = lights.env && !lights.sg && lights.suns.empty() && lights.areas.empty();
    height = map_only ? lights.env->height : kEnvMapOutputHeight;
  }
  LightEnvMapOptions options;
  options.height = height;
  return LightSetToEnvMap(lights, options);
}

std::string BlenderWorldScript(const fs::path& map_file) {
  const fs::path absolute = fs::absolute(map_file).lexically_normal();
  return "# shadowsg lighting as a Blender world (written by `shadowsg export --format blender`).\n"
         "#\n"
         "# Run it in Blender: `blender --python " + map_file.stem().string() + ".py`, or open it in the Scripting\n"
         "# workspace and Run Script. It makes the world \"shadowsg\" the scene's world:\n"
         "# Environment Texture (the map) -> Background (strength 1) -> World Output.\n"
         "# The map holds radiance in the estimate's own units, in Blender's equirectangular\n"
         "# layout (z up, image centre towards +x): Blender's world frame is shadowsg's, so\n"
         "# objects placed with scene.json's coordinates (o2w) are lit as shadowsg renders them.\n"
         "# Blender cameras look along their -z with +y up: c2w_blender = c2w @ diag(1, -1, -1, 1).\n"
         "import os\n"
         "\n"
         "import bpy\n"
         "\n"
         "MAP_ABSOLUTE = " + Quoted(absolute.string()) + "\n"
         "MAP_NAME = " + Quoted(map_file.filename().string()) + "\n"
         "\n"
         "\n"
         "def map_path():\n"
         "    if os.path.isfile(MAP_ABSOLUTE):\n"
         "        return MAP_ABSOLUTE\n"
         "    return os.path.join(os.path.dirname(os.path.abspath(__file__)), MAP_NAME)\n"
         "\n"
         "\n"
         "scene = bpy.context.scene\n"
         "world = bpy.data.worlds.get(\"shadowsg\") or bpy.data.worlds.new(\"shadowsg\")\n"
         "scene.world = world\n"
         "world.use_nodes = True\n"
         "nodes, links = world.node_tree.nodes, world.node_tree.links\n"
         "nodes.clear()\n"
         "texture = nodes.new(\"ShaderNodeTexEnvironment\")\n"
         "texture.image = bpy.data.images.load(map_path(), check_existing=True)\n"
         "texture.image.colorspace_settings.name = \"Non-Color\"  # radiance values, no colour transform\n"
         "texture.interpolation = \"Closest\"  # constant per texel, as shadowsg integrates a map\n"
         "texture.projection = \"EQUIRECTANGULAR\"\n"
         "texture.location = (-600, 0)\n"
         "background = nodes.new(\"ShaderNodeBackground\")\n"
         "background.inputs[\"Strength\"].default_value = 1.0\n"
         "background.location = (-300, 0)\n"
         "output = nodes.new(\"ShaderNodeOutputWorld\")\n"
         "links.new(texture.outputs[\"Color\"], background.inputs[\"Color\"])\n"
         "links.new(background.outputs[\"Background\"], output.inputs[\"Surface\"])\n"
         "print(\"shadowsg: world lighting from\", texture.image.filepath)\n";
}

std::vector<fs::path> RunExport(const fs::path& lighting_file, const fs::path& out, const ExportOptions& options,
                                const StageContext& ctx) {
  if (const std::string e = options.Validate(); !e.empty()) throw InputError("", e);
  const std::string ext = MainExtension(options.format);
  if (out.extension() != ext)
    throw InputError(out.string(), "--format " + options.format + " writes a " + ext + " file");
  const LightSet lights = ReadLighting(lighting_file);
  if (lights.empty()) throw InputError(lighting_file.string(), "no lights in the lighting file");
  if (out.has_parent_path()) EnsureOutputDir(out.parent_path());

  std::vector<fs::path> written;
  if (options.format == "json") {
    if (!lights.sg || lights.env || !lights.suns.empty() || !lights.areas.empty())
      throw InputError(lighting_file.string(), "--format json writes SG lobes; this lighting is not SG lobes alone");
    WriteSgLighting(out, *lights.sg);
    written.push_back(out);
    ctx.Log("export: " + std::to_string(lights.sg->lobes.size()) + " SG lobes to " + out.string());
    return written;
  }

  const Image map = ExportEnvMap(lights, options.height);
  fs::path map_file = out;
  if (options.format == "exr") {
    WriteExrWithPreview(out, map);
  } else if (options.format == "openexr") {
    WriteLatLongExr(out, EnvMapToLatLong(map, LatLongConvention::kOpenExr));
    WritePreviewPng(fs::path(out).replace_extension(".png"), EnvMapToLatLong(map, LatLongConvention::kOpenExr));
  } else if (options.format == "usd") {
    map_file = fs::path(out).replace_extension(".exr");
    if (map_file.filename().string().find('@') != std::string::npos)
      throw InputError(out.string(), "USD asset paths cannot hold '@'");
    WriteLatLongExr(map_file, EnvMapToLatLong(map, LatLongConvention::kOpenExr));
    WriteTextAtomically(out, UsdStage(map_file.filename().string()));
    written.push_back(out);
  } else {  // blender
    map_file = fs::path(out).replace_extension(".exr");
    WriteExr(map_file, EnvMapToLatLong(map, LatLongConvention::kBlender));
    WriteTextAtomically(out, BlenderWorldScript(map_file));
    written.push_back(out);
  }
  written.push_back(map_file);
  const Eigen::Vector3d e = EnvIrradiance(map, Eigen::Vector3d::UnitZ());
  char line[256];
  std::snprintf(line, sizeof line, "export: %s, %dx%d map, irradiance on +z (%.4g, %.4g, %.4g)",
                options.format.c_str(), map.width, map.height, e.x(), e.y(), e.z());
  ctx.Log(line);
  ctx.Log("wrote " + written.front().string());
  return written;
}

}  // namespace shadowsg
