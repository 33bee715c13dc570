// `shadowsg spheretree MESH --out FILE.sph`: builds a sphere tree of a closed
// mesh (solver/sphere_tree_build.h) and prints how well each level fits it
// (solver/sphere_tree_fit.h).
#include <cstdio>

#include "calib/error.h"
#include "pipeline/cli_common.h"
#include "pipeline/commands.h"
#include "solver/sphere_tree_build.h"
#include "solver/sphere_tree_fit.h"
#include "stages/io/mesh_io.h"
#include "stages/io/sph_io.h"

namespace shadowsg {

void RegisterSphereTreeCommand(CLI::App& app) {
  struct Options {
    CommonOptions common;
    std::string mesh, out;
    SphereTreeBuildOptions build;
    bool no_fit = false, all_levels = false;
  };
  auto opt = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand("spheretree", "Build the sphere tree of a closed mesh (.sph) and report its fit");
  cmd->add_option("MESH", opt->mesh, "Closed triangle mesh (.obj or .ply)")->required();
  cmd->add_option("--out", opt->out, "Output sphere tree (.sph)")->required();
  cmd->add_option("--levels", opt->build.levels, "Levels including the root (4: 1 + 8 + 64 + 512 spheres)")
      ->capture_default_str();
  cmd->add_option("--branching", opt->build.branching, "Children per node")->capture_default_str();
  cmd->add_option("--surface-points", opt->build.surface_points, "Surface grid points every level covers")
      ->capture_default_str();
  cmd->add_option("--medial-spheres", opt->build.medial_spheres, "Candidate inscribed spheres (shrinking-ball seeds)")
      ->capture_default_str();
  cmd->add_flag("--no-fit", opt->no_fit, "Skip the fit report (volume, protrusion, coverage)");
  cmd->add_flag("--all-levels", opt->all_levels, "Report the fit of every level, not only the leaves");
  AddCommonOptions(cmd, &opt->common);
  cmd->callback([opt] {
    const StageContext ctx = MakeContext(opt->common);
    opt->build.seed = opt->common.seed;
    std::string why;
    if (!opt->build.IsValid(&why)) throw InputError("spheretree", why);
    const TriangleMesh mesh = ReadMesh(opt->mesh);
    SphereTreeBuildSummary s;
    SphereTree tree;
    try {
      tree = BuildSphereTree(mesh, opt->build, ctx.Progress("sphere tree"), &s);
    } catch (const InputError& e) {  // the mesh's problem: name its file
      throw InputError(opt->mesh, e.what());
    }
    WriteSph(opt->out, tree);
    std::printf("wrote %s: %d levels, branching %d, %d leaves in %zu slots; %.2f s on %d threads\n",
                opt->out.c_str(), tree.levels, tree.branching, s.leaves, tree.nodes.size(), s.seconds, ctx.threads);
    std::printf("surface %d points (spacing %.4g), %d of them in the cover, %d medial spheres, leaf stand-off %.4f "
                "and growth %.4f of the diagonal\n",
                s.surface_points, s.spacing, s.cover_points, s.medial_spheres, s.leaf_standoff, s.leaf_growth);
    if (s.boundary_edges > 0)
      ctx.Warn("the mesh is open (" + std::to_string(s.boundary_edges) + " boundary edges): inside/outside is a guess");
    if (s.inverted) ctx.Warn("the faces wind inwards (negative volume); normals were flipped");
    int tiny = 0;
    for (const Sphere& sp : tree.nodes) tiny += !sp.empty() && sp.radius <= 1e-4;  // sph_io's empty-slot radius
    if (tiny > 0)
      ctx.Warn(std::to_string(tiny) + " spheres have radius <= 1e-4 and read back from .sph as empty slots; scale the mesh up");
    if (opt->no_fit) return;
    SphereTreeFitOptions fo;
    fo.seed = opt->common.seed + 1;
    for (int level = opt->all_levels ? 1 : tree.levels - 1; level < tree.levels; ++level)
      std::printf("%s\n", EvaluateSphereTreeFit(mesh, tree, level, fo).BriefReport().c_str());
  });
}

}  // namespace shadowsg
