// `shadowsg info SCENE_DIR`: loads a registered scene and reports what it holds.
#include <cstdio>
#include <filesystem>

#include "pipeline/cli_common.h"
#include "pipeline/commands.h"
#include "solver/mesh.h"
#include "solver/plane_pixels.h"
#include "stages/io/scene_io.h"

namespace shadowsg {

void RegisterInfoCommand(CLI::App& app) {
  struct Options {
    CommonOptions common;
    std::string scene_dir;
  };
  auto opt = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand("info", "Check a registered scene folder and summarise it");
  cmd->add_option("SCENE_DIR", opt->scene_dir, "Registered scene folder")->required();
  AddCommonOptions(cmd, &opt->common);
  cmd->callback([opt] {
    MakeContext(opt->common);
    const Scene scene = LoadScene(opt->scene_dir);
    const RayCaster casters = BuildRayCaster(scene.Casters());
    const PlanePixels px = FindPlanePixels(scene, casters);
    std::printf("scene        %s\n", scene.name.c_str());
    std::printf("camera       %dx%d %s\n", scene.camera.width, scene.camera.height,
                scene.camera.projection == Projection::kPerspective ? "perspective" : "orthographic");
    for (const auto& o : scene.objects)
      std::printf("object       %s: %zu vertices, %zu faces, %d boundary edges, %s%s\n", o.mesh_path.c_str(),
                  o.mesh.vertices.size(), o.mesh.faces.size(), CountBoundaryEdges(o.mesh),
                  o.is_train ? "caster" : "virtual", o.sphere_tree ? ", sphere tree" : "");
    std::printf("plane pixels %zu\n", px.size());
    std::printf("env_gt       %s\n", scene.env_gt ? "yes" : "no");
    std::printf("insertion gt %s\n", scene.image_virtual_objs ? "yes" : "no");
  });
}

}  // namespace shadowsg
