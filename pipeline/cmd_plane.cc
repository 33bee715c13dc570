// `shadowsg plane --images DIR [--colmap-model DIR] --hero IMAGE --out plane.json`.
#include <cmath>
#include <cstdio>
#include <sstream>

#include "calib/error.h"
#include "pipeline/cli_common.h"
#include "pipeline/commands.h"
#include "stages/plane_stage.h"

namespace shadowsg {

namespace {

// "1,2,3,4" -> numbers; exactly `count` of them.
std::vector<double> ParseList(const std::string& text, const std::string& option, size_t count) {
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
  if (v.size() != count) throw InputError(option, "expected " + std::to_string(count) + " comma-separated numbers");
  return v;
}

}  // namespace

void RegisterPlaneCommand(CLI::App& app) {
  struct Options {
    CommonOptions common;
    PlaneStageOptions stage;
    std::string distance_pixels, distance_points;
  };
  auto opt = std::make_shared<Options>();
  PlaneStageOptions& s = opt->stage;
  CLI::App* cmd = app.add_subcommand(
      "plane", "Ground plane and hero camera from a multi-view capture (runs COLMAP, or reads a sparse model)");
  cmd->add_option("--images", s.images, "Folder of photos of the scene from many directions (.jpg .png .tif)");
  cmd->add_option("--colmap-model", s.colmap_model,
                  "Existing COLMAP sparse model (cameras/images/points3D .bin or .txt, or a folder of numbered "
                  "models): COLMAP is not run");
  cmd->add_option("--hero", s.hero, "The hero photo's file name in --images (the view the scene is registered in)")
      ->required();
  cmd->add_option("--out", s.out, "plane.json to write")->capture_default_str();
  cmd->add_option("--camera", s.camera,
                  "camera.json from `shadowsg intrinsics`: hero intrinsics, and COLMAP's fixed camera");
  cmd->add_option("--workspace", s.workspace, "COLMAP's working folder (default: <out stem>_colmap beside --out)");
  cmd->add_option("--colmap", s.colmap, "The COLMAP program (name on PATH or a path)")->capture_default_str();
  cmd->add_option("--matcher", s.matcher, "exhaustive or sequential")->capture_default_str();
  cmd->add_option("--camera-model", s.camera_model, "COLMAP camera model without --camera")->capture_default_str();
  cmd->add_option("--max-image-size", s.max_image_size, "Photos are downscaled to this side for SIFT")
      ->capture_default_str();
  cmd->add_option("--max-features", s.max_features,
                  "SIFT features per photo at most (CPU matching time grows with its square)")
      ->capture_default_str();
  cmd->add_option("--min-registered", s.min_registered, "Fewest registered photos accepted")->capture_default_str();
  cmd->add_option("--plane-threshold", s.inlier_threshold,
                  "Plane inlier distance in COLMAP units (0: --plane-threshold-fraction x median viewing distance)")
      ->capture_default_str();
  cmd->add_option("--plane-threshold-fraction", s.threshold_fraction,
                  "Automatic inlier distance as a share of the median viewing distance")
      ->capture_default_str();
  cmd->add_option("--ransac-iterations", s.ransac_iterations, "Plane RANSAC hypotheses at most")
      ->capture_default_str();
  cmd->add_option("--min-inlier-fraction", s.min_inlier_fraction,
                  "A dominant plane holds at least this share of the points")
      ->capture_default_str();
  cmd->add_option("--tag-size", s.tag_size,
                  "Metric scale: edge of an AprilTag's black border square (the scene's length unit)");
  cmd->add_option("--tag-family", s.tag_family, "AprilTag family")->capture_default_str();
  cmd->add_option("--tag-id", s.tag_id, "Only this tag id (default: every tag found)");
  cmd->add_option("--distance", s.distance, "Metric scale: the distance between two points (with one of below)");
  cmd->add_option("--distance-pixels", opt->distance_pixels,
                  "U1,V1,U2,V2: two points on the plane in the hero photo (pixel centres at integers)");
  cmd->add_option("--distance-points", opt->distance_points, "ID1,ID2: two COLMAP 3D point ids");
  AddCommonOptions(cmd, &opt->common);
  cmd->callback([opt] {
    PlaneStageOptions& s = opt->stage;
    if (!opt->distance_pixels.empty()) {
      const auto v = ParseList(opt->distance_pixels, "--distance-pixels", 4);
      s.distance_pixels = {Eigen::Vector2d(v[0], v[1]), Eigen::Vector2d(v[2], v[3])};
    }
    if (!opt->distance_points.empty()) {
      const auto v = ParseList(opt->distance_points, "--distance-points", 2);
      for (double x : v) {
        if (x < 0 || x != std::floor(x)) throw InputError("--distance-points", "ids are non-negative integers");
        s.distance_points.push_back(static_cast<uint64_t>(x));
      }
    }
    const PlaneStageResult r = RunPlaneStage(s, MakeContext(opt->common));
    const Eigen::Matrix4d& T = r.hero.c2w;
    if (r.input_images > 0)
      std::printf("registered   %d of %d photos (COLMAP %.1f s)\n", r.registered_images, r.input_images,
                  r.colmap_seconds);
    else
      std::printf("registered   %d photos\n", r.registered_images);
    std::printf("plane        %d of %zu points within %.4g, rms %.4g (%s)\n", r.fit.num_inliers, r.points,
                r.threshold * r.scale, r.fit.rms * r.scale,
                r.scale_source == "none" ? "COLMAP units" : "metric");
    std::printf("scale        %s, %.6g per COLMAP unit\n", r.scale_source.c_str(), r.scale);
    std::printf("hero         %s at %.4f %.4f %.4f (height %.4f), intrinsics from %s\n", r.hero_name.c_str(),
                T(0, 3), T(1, 3), T(2, 3), T(2, 3), r.hero_intrinsics.c_str());
    std::printf("extent       +-%.4g x +-%.4g\n", r.half_extent.x(), r.half_extent.y());
    std::printf("wrote        %s\n", r.plane_json.string().c_str());
  });
}

}  // namespace shadowsg
