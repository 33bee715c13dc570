// `shadowsg pose --image PHOTO --camera camera.json (--tag-size S | --tag-layout F | --points CSV) --out pose.json`.
#include <cstdio>
#include <sstream>

#include "calib/error.h"
#include "pipeline/cli_common.h"
#include "pipeline/commands.h"
#include "stages/pose_stage.h"

namespace shadowsg {

void RegisterPoseCommand(CLI::App& app) {
  struct Options {
    CommonOptions common;
    PoseStageOptions stage;
    std::string method, offset, mesh_up = "z";
    double ground_z = 0.0;
  };
  auto opt = std::make_shared<Options>();
  CLI::App* cmd =
      app.add_subcommand("pose", "Object pose (o2c) and ground plane from AprilTags or from 2D-3D correspondences");
  cmd->add_option("--image", opt->stage.image, "The photo (JPEG/PNG, or a linear EXR)")->required();
  cmd->add_option("--camera", opt->stage.camera, "camera.json from `shadowsg intrinsics` (or a scene.json)")
      ->required();
  cmd->add_option("--out", opt->stage.out, "pose.json to write")->capture_default_str();
  cmd->add_option("--overlay", opt->stage.overlay, "Overlay picture (default: <out>_overlay.png)");
  cmd->add_option("--mesh", opt->stage.mesh, "The object's mesh (OBJ/PLY), drawn on the overlay");
  cmd->add_option("--method", opt->method, "apriltag or pnp (default: pnp when --points is given)");
  cmd->add_option("--tag-family", opt->stage.detector.family, "AprilTag family")->capture_default_str();
  cmd->add_option("--tag-size", opt->stage.tag_size,
                  "Edge of the tag's black border square (length unit of the scene)");
  cmd->add_option("--tag-id", opt->stage.tag_id, "Single tag: which id to use (default: the only one seen)");
  cmd->add_option("--tag-layout", opt->stage.tag_layout, "JSON placement of several tags on the object (README)");
  cmd->add_option("--offset", opt->offset,
                  "Single tag: object origin X,Y,Z from the tag centre (x: tag right, y: tag up, z: plane normal)");
  cmd->add_option("--mesh-up", opt->mesh_up, "Mesh axis pointing up from the plane: z or y")->capture_default_str();
  cmd->add_option("--tag-decimate", opt->stage.detector.decimate, "Quad decimation (0: automatic)")
      ->capture_default_str();
  cmd->add_option("--tag-blur", opt->stage.detector.blur_sigma, "Gaussian blur sigma before detection")
      ->capture_default_str();
  cmd->add_option("--tag-max-hamming", opt->stage.detector.max_hamming, "Bit errors accepted (0-2)")
      ->capture_default_str();
  cmd->add_option("--points", opt->stage.points, "PnP: CSV of u, v, x, y, z (pixels; object coordinates)");
  cmd->add_option("--ransac-px", opt->stage.pnp.ransac_threshold_px, "PnP: RANSAC inlier distance in pixels")
      ->capture_default_str();
  cmd->add_option("--ransac-iterations", opt->stage.pnp.ransac_iterations, "PnP: RANSAC iterations")
      ->capture_default_str();
  auto* ground = cmd->add_option("--ground-z", opt->ground_z, "PnP: the object's plane z = Z is the ground (plane_c)");
  AddCommonOptions(cmd, &opt->common);
  cmd->callback([opt, ground] {
    PoseStageOptions& s = opt->stage;
    if (opt->method.empty())
      s.method = s.points.empty() ? PoseMethod::kAprilTag : PoseMethod::kPnp;
    else if (opt->method == "apriltag")
      s.method = PoseMethod::kAprilTag;
    else if (opt->method == "pnp")
      s.method = PoseMethod::kPnp;
    else
      throw InputError("--method", "expected apriltag or pnp, got \"" + opt->method + "\"");
    if (!opt->offset.empty()) {
      std::istringstream ss(opt->offset);
      std::string part;
      int k = 0;
      while (std::getline(ss, part, ',')) {
        if (k >= 3) throw InputError("--offset", "expected X,Y,Z");
        try {
          s.offset[k++] = std::stod(part);
        } catch (const std::exception&) {
          throw InputError("--offset", "\"" + part + "\" is not a number");
        }
      }
      if (k != 3) throw InputError("--offset", "expected X,Y,Z");
    }
    if (opt->mesh_up == "z")
      s.mesh_up = MeshUp::kZ;
    else if (opt->mesh_up == "y")
      s.mesh_up = MeshUp::kY;
    else
      throw InputError("--mesh-up", "expected z or y");
    if (ground->count()) s.ground_z = opt->ground_z;
    const PoseStageResult r = RunPoseStage(s, MakeContext(opt->common));
    const Eigen::Matrix4d& T = r.pose.o2c;
    std::printf("method       %s\n", r.method.c_str());
    std::printf("rms          %.4f px\n", r.pose.rms_px);
    std::printf("o2c t        %.5f %.5f %.5f (distance %.5f)\n", T(0, 3), T(1, 3), T(2, 3),
                T.topRightCorner<3, 1>().norm());
    if (r.plane)
      std::printf("plane_c      xyz %.5f %.5f %.5f  normal %.4f %.4f %.4f\n", r.plane->first.x(), r.plane->first.y(),
                  r.plane->first.z(), r.plane->second.x(), r.plane->second.y(), r.plane->second.z());
    std::printf("wrote        %s, %s\n", r.pose_json.string().c_str(), r.overlay_png.string().c_str());
  });
}

}  // namespace shadowsg
