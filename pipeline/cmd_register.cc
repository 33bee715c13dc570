// `shadowsg register --camera camera.json --image linear.exr --plane plane.json --pose pose.json --mesh MESH
//  --out SCENE_DIR`.
#include <cmath>
#include <cstdio>
#include <sstream>

#include "calib/error.h"
#include "pipeline/cli_common.h"
#include "pipeline/commands.h"
#include "stages/register_stage.h"

namespace shadowsg {

namespace {

std::vector<double> ParseNumbers(const std::string& text, const std::string& option, size_t count) {
  std::vector<double> v;
  std::istringstream ss(text);
  std::string part;
  while (std::getline(ss, part, ',')) {
    try {
      size_t used = 0;
      v.push_back(std::stod(part, &used));
      if (used != part.size() || !std::isfinite(v.back())) throw std::invalid_argument(part);
    } catch (const std::exception&) {
      throw InputError(option, "\"" + part + "\" is not a number");
    }
  }
  if (v.size() == 1 && count == 3) v.assign(3, v[0]);  // a grey
  if (v.size() != count) throw InputError(option, "expected " + std::to_string(count) + " comma-separated numbers");
  return v;
}

}  // namespace

void RegisterRegisterCommand(CLI::App& app) {
  struct Options {
    CommonOptions common;
    RegisterStageOptions stage;
    std::string albedo, object_albedo, plane_half_size;
    bool no_tag_mask = false;
  };
  auto opt = std::make_shared<Options>();
  RegisterStageOptions& s = opt->stage;
  CLI::App* cmd = app.add_subcommand(
      "register", "Assemble a registered scene folder (scene.json, image.exr, mesh, mask.png) from the capture stages");
  cmd->add_option("--camera", s.camera,
                  "camera.json of the linear image (default: the hero camera in plane.json)");
  cmd->add_option("--image", s.image, "The linear hero photo (EXR from `shadowsg linearize`)")->required();
  cmd->add_option("--plane", s.plane, "plane.json from `shadowsg plane`")->required();
  cmd->add_option("--pose", s.pose, "pose.json from `shadowsg pose` (the object in the hero photo)")->required();
  cmd->add_option("--mesh", s.mesh, "The object's mesh (OBJ/PLY, in pose.json's units)")->required();
  cmd->add_option("--out", s.out, "Scene folder to write")->required();
  cmd->add_option("--clipped", s.clipped, "Mask of clipped pixels (default: <image stem>_clipped.png if present)");
  cmd->add_option("--clip-level", s.clip_level,
                  "Pixels with a channel at or above this are clipped (0: the image's maximum when 16+ pixels reach "
                  "it)")
      ->capture_default_str();
  cmd->add_option("--plane-half-size", opt->plane_half_size,
                  "HX,HY: half extents of the plane rectangle (default: the reconstructed plane points' extent)");
  cmd->add_option("--object-margin", s.object_margin_px,
                  "Pixels masked around the object, tags and clipped pixels")
      ->capture_default_str();
  cmd->add_option("--albedo", opt->albedo,
                  "Plane albedo: R,G,B (or one grey value) if known, \"tag\" (from an AprilTag's white paper), "
                  "\"convention\" (0.8), or \"auto\" (tag when one is seen, else convention)")
      ->capture_default_str();
  cmd->add_option("--paper-albedo", s.paper_albedo, "Albedo of the tag's white paper")->capture_default_str();
  cmd->add_option("--object-albedo", opt->object_albedo, "R,G,B (or one grey value) of the object")
      ->capture_default_str();
  cmd->add_option("--tag-family", s.tag_family, "AprilTag family masked out")->capture_default_str();
  cmd->add_option("--tag-exclude-scale", s.tag_exclude_scale,
                  "Masked square around a tag, in units of its whole printed pattern")
      ->capture_default_str();
  cmd->add_flag("--no-tag-mask", opt->no_tag_mask, "Do not look for AprilTags (nor mask them out)");
  cmd->add_flag("--snap-to-plane", s.snap_to_plane, "Move the object along the normal to rest on the plane");
  AddCommonOptions(cmd, &opt->common);
  opt->albedo = "auto";
  opt->object_albedo = "0.8";
  cmd->callback([opt] {
    RegisterStageOptions& s = opt->stage;
    if (opt->albedo == "auto") {
      s.albedo_mode = AlbedoMode::kAuto;
    } else if (opt->albedo == "tag") {
      s.albedo_mode = AlbedoMode::kTag;
    } else if (opt->albedo == "convention") {
      s.albedo_mode = AlbedoMode::kConvention;
    } else {
      const auto v = ParseNumbers(opt->albedo, "--albedo", 3);
      s.albedo_mode = AlbedoMode::kGiven;
      s.albedo = Eigen::Vector3d(v[0], v[1], v[2]);
    }
    const auto oa = ParseNumbers(opt->object_albedo, "--object-albedo", 3);
    s.object_albedo = Eigen::Vector3d(oa[0], oa[1], oa[2]);
    if (!opt->plane_half_size.empty()) {
      const auto v = ParseNumbers(opt->plane_half_size, "--plane-half-size", 2);
      s.plane_half_size = Eigen::Vector2d(v[0], v[1]);
    }
    s.mask_tags = !opt->no_tag_mask;
    const RegisterStageResult r = RunRegisterStage(s, MakeContext(opt->common));
    const Eigen::Vector3d& d = r.scene.plane.diffuse;
    std::printf("units        x%.6g (from %s)\n", r.pose_units_per_world_unit, r.units_from.c_str());
    std::printf("plane        +-%.4g x +-%.4g, albedo %.3f %.3f %.3f (%s)\n", r.scene.plane.scale.x(),
                r.scene.plane.scale.y(), d.x(), d.y(), d.z(), r.albedo_source.c_str());
    std::printf("object       lowest point %.4g from the plane\n", r.object_gap);
    std::printf("mask         %zu plane pixels (%zu clipped, %d tag(s) masked)\n", r.mask_pixels, r.clipped_pixels,
                r.tags_masked);
    std::printf("wrote        %s\n", r.scene_dir.string().c_str());
  });
}

}  // namespace shadowsg
