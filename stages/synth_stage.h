// `shadowsg synth`: a complete registered-scene folder with ground truth,
// rendered by the path tracer from a spec (format: README.md, "Synthetic
// scenes (synth)"). Writes scene.json, image.exr, geometry/*.obj,
// env_gt.exr, lights.json (the exact lights, "lights/1"),
// image_virtual_objs.exr when the spec has virtual objects, the plane
// texture when there is one, and PNG previews of the images.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "solver/lights.h"
#include "solver/mesh.h"
#include "solver/path_tracer.h"
#include "solver/scene.h"
#include "stages/io/json_util.h"
#include "stages/stage_context.h"

namespace shadowsg {

struct SynthObject {
  std::string name;  // file stem under geometry/
  TriangleMesh mesh;  // object coordinates
  Eigen::Matrix4d o2w = Eigen::Matrix4d::Identity();
  Eigen::Vector3d diffuse = Eigen::Vector3d::Constant(0.8);
  bool is_train = true;
};

struct SynthSpec {
  Camera camera;
  Plane plane;  // albedo_texture set when the spec has a texture
  std::string texture_file;  // name to write the texture under ("" = none)
  std::vector<SynthObject> objects;
  LightSet lights;
  PathTraceOptions trace;  // spp, bounces, seed from "render"
  int env_gt_height = 256;
};

// Parses a spec; files it names are relative to base_dir. InputError names
// the spec file and the key on any problem.
SynthSpec ParseSynthSpec(const JsonReader& spec, const std::filesystem::path& base_dir);
SynthSpec ReadSynthSpec(const std::filesystem::path& path);

// Command-line overrides of the spec.
struct SynthOverrides {
  std::optional<int> samples_per_pixel;
  std::optional<int> max_bounces;
  std::optional<uint64_t> seed;
  double resolution_scale = 1.0;  // scales width, height and intrinsics
};
void ApplyOverrides(const SynthOverrides& overrides, SynthSpec* spec);

struct SynthResult {
  std::filesystem::path scene_dir;
  double render_seconds = 0;
  bool has_virtual_objects = false;
};

SynthResult RunSynthStage(const SynthSpec& spec, const std::filesystem::path& out_dir, const StageContext& ctx);

// OpenCV-axes c2w of a camera at `from` looking at `at`, image "up" towards `up`.
Eigen::Matrix4d LookAt(const Eigen::Vector3d& from, const Eigen::Vector3d& at, const Eigen::Vector3d& up);

}  // namespace shadowsg
