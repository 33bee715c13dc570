// Makes sure a caster has a sphere tree (scene-format.md: built and cached
// when the scene has none): the one loaded with the scene; else a cached
// build of the same mesh and options; else a fresh build, written to the
// scene's path_to_sph (or "<mesh stem>_sphere.sph" next to the mesh) when that
// folder is writable, otherwise to the user cache
// ($XDG_CACHE_HOME or ~/.cache)/shadowsg/spheretrees/<key>.sph.
// The key hashes the mesh's vertices and faces, the build options and the
// builder version; files this project writes carry it on a trailing
// "# shadowsg ..." line (ignored by .sph readers, which read exactly the
// header's sphere count), so a stale file next to a changed mesh is rebuilt.
#pragma once

#include <filesystem>
#include <string>

#include "solver/scene.h"
#include "solver/sphere_tree_build.h"
#include "stages/stage_context.h"

namespace shadowsg {

// Bumped whenever BuildSphereTree's output changes for the same input.
// 2: meshes with more than 1.5x surface_points vertices (scans) are thinned.
constexpr int kSphereTreeBuilderVersion = 2;

// The options EnsureSphereTree builds with: the defaults with a fixed seed
// (not the run's --seed), so every run shares one cached tree per mesh.
SphereTreeBuildOptions SceneSphereTreeOptions();

// 16 hex digits identifying (mesh, options, builder version).
std::string SphereTreeCacheKey(const TriangleMesh& mesh, const SphereTreeBuildOptions& options);

// The user cache folder for sphere trees.
std::filesystem::path SphereTreeCacheDir();

// The .sph text of a built tree with its key line.
std::string SphTextWithKey(const SphereTree& tree, const std::string& key);

// The object's tree (object coordinates), loading, building and caching as
// above and logging what it did; sets object.sphere_tree (and object.sph_path
// when it wrote the file into the scene folder and the scene named none).
const SphereTree& EnsureSphereTree(SceneObject& object, const std::filesystem::path& scene_dir,
                                   const StageContext& ctx);

}  // namespace shadowsg
