#include "stages/sphere_tree_stage.h"

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>

#include "calib/error.h"
#include "stages/io/atomic_file.h"
#include "stages/io/sph_io.h"

namespace shadowsg {
namespace fs = std::filesystem;
namespace {

constexpr char kKeyTag[] = "# shadowsg sphere-tree key ";
// The .sph empty-slot radius (stages/io/sph_io.cc, after the reference code).
constexpr double kSphEmptyRadius = 1e-4;

// FNV-1a, 64 bit (Fowler, Noll, Vo): a content hash for cache names, not security.
class Fnv1a {
 public:
  void Add(const void* data, size_t n) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (size_t i = 0; i < n; ++i) h_ = (h_ ^ p[i]) * 0x100000001b3ull;
  }
  template <typename T>
  void AddValue(const T& v) {
    Add(&v, sizeof v);
  }
  uint64_t value() const { return h_; }

 private:
  uint64_t h_ = 0xcbf29ce484222325ull;
};

// The key stored in a file this project wrote, or "" when there is none.
std::string StoredKey(const fs::path& path) {
  std::ifstream in(path);
  std::string line, key;
  while (std::getline(in, line))
    if (line.rfind(kKeyTag, 0) == 0) key = line.substr(std::strlen(kKeyTag));
  return key;
}

bool FolderWritable(const fs::path& dir) {
  std::error_code ec;
  fs::path d = dir;
  // The folder may not exist yet: then its nearest existing ancestor decides.
  while (!d.empty() && !fs::exists(d, ec)) d = d.parent_path();
  if (d.empty()) d = ".";
  // root passes access(W_OK) everywhere: also honour the folder's mode bits,
  // so a scene folder marked read-only (shared data sets) is never written.
  const fs::perms p = fs::status(d, ec).permissions();
  if (ec || (p & fs::perms::owner_write) == fs::perms::none) return false;
  return access(d.c_str(), W_OK) == 0;
}

}  // namespace

SphereTreeBuildOptions SceneSphereTreeOptions() { return SphereTreeBuildOptions{}; }

std::string SphereTreeCacheKey(const TriangleMesh& mesh, const SphereTreeBuildOptions& o) {
  Fnv1a h;
  h.AddValue(kSphereTreeBuilderVersion);
  for (const auto& v : mesh.vertices) h.Add(v.data(), 3 * sizeof(double));
  for (const auto& f : mesh.faces) h.Add(f.data(), 3 * sizeof(int));
  h.AddValue(o.levels);
  h.AddValue(o.branching);
  h.AddValue(o.seed);
  h.AddValue(o.surface_points);
  h.AddValue(o.medial_spheres);
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h.value()));
  return buf;
}

fs::path SphereTreeCacheDir() {
  const char* xdg = std::getenv("XDG_CACHE_HOME");
  fs::path base;
  if (xdg && *xdg) {
    base = xdg;
  } else if (const char* home = std::getenv("HOME"); home && *home) {
    base = fs::path(home) / ".cache";
  } else {
    base = fs::temp_directory_path();
  }
  return base / "shadowsg" / "spheretrees";
}

std::string SphTextWithKey(const SphereTree& tree, const std::string& key) {
  std::ostringstream out;
  WriteSph(out, tree);
  out << kKeyTag << key << '\n';
  return out.str();
}

const SphereTree& EnsureSphereTree(SceneObject& object, const fs::path& scene_dir, const StageContext& ctx) {
  const SphereTreeBuildOptions options = SceneSphereTreeOptions();
  const std::string key = SphereTreeCacheKey(object.mesh, options);
  std::error_code ec;
  if (object.sphere_tree) {
    // A tree loaded with the scene is used as it is (reference data carries no
    // key), unless this project wrote it for a different mesh.
    const fs::path loaded = scene_dir / object.sph_path;
    const std::string stored = object.sph_path.empty() ? "" : StoredKey(loaded);
    if (stored.empty() || stored == key) return *object.sphere_tree;
    ctx.Warn("sphere tree: " + loaded.string() + " was built for another mesh or builder version; rebuilding");
    object.sphere_tree.reset();
  }
  const std::string name = object.sph_path.empty()
                               ? (fs::path(object.mesh_path).parent_path() /
                                  (fs::path(object.mesh_path).stem().string() + "_sphere.sph"))
                                     .string()
                               : object.sph_path;
  const fs::path scene_file = scene_dir / name;
  const fs::path cache_file = SphereTreeCacheDir() / (key + ".sph");

  // A file this project wrote for the same mesh, next to it or in the cache.
  for (const fs::path& f : {scene_file, cache_file}) {
    if (!fs::is_regular_file(f, ec) || StoredKey(f) != key) continue;
    try {
      object.sphere_tree = ReadSph(f);
    } catch (const InputError& e) {
      ctx.Warn(std::string("sphere tree: ignoring a damaged cached file: ") + e.what());
      continue;
    }
    if (f == scene_file && object.sph_path.empty()) object.sph_path = name;
    ctx.Log("sphere tree: " + object.mesh_path + ": using " + f.string());
    return *object.sphere_tree;
  }

  SphereTreeBuildSummary summary;
  SphereTree tree;
  try {
    tree = BuildSphereTree(object.mesh, options, ctx.Progress("sphere tree " + object.mesh_path), &summary);
  } catch (const InputError& e) {  // the mesh's problem: name its file
    throw InputError((scene_dir / object.mesh_path).string(), e.what());
  }
  char line[256];
  std::snprintf(line, sizeof line, "built %zu spheres (%d levels, branching %d) in %.2f s, leaf stand-off %.4f of the diagonal",
                tree.nodes.size(), tree.levels, tree.branching, summary.seconds, summary.leaf_standoff);
  ctx.Log("sphere tree: " + object.mesh_path + ": " + line);
  if (summary.boundary_edges > 0)
    ctx.Warn("sphere tree: " + object.mesh_path + ": the mesh is open (" + std::to_string(summary.boundary_edges) +
             " boundary edges); spheres may fill or miss parts of it");
  if (summary.inverted) ctx.Warn("sphere tree: " + object.mesh_path + ": faces wind inwards (negative volume)");
  // The .sph readers (ours and the reference's) take radii <= 1e-4 for empty
  // slots, whatever the unit: such spheres would be lost when read back.
  int tiny = 0;
  for (const Sphere& s : tree.nodes) tiny += !s.empty() && s.radius <= kSphEmptyRadius;
  if (tiny > 0)
    ctx.Warn("sphere tree: " + object.mesh_path + ": " + std::to_string(tiny) +
             " spheres have radius <= 1e-4 and read back from .sph as empty slots; the mesh's unit is too small");

  const std::string text = SphTextWithKey(tree, key);
  bool written = false;
  if (FolderWritable(scene_file.parent_path())) {
    try {
      WriteTextAtomically(scene_file, text);
      written = true;
      if (object.sph_path.empty()) object.sph_path = name;
      ctx.Log("sphere tree: wrote " + scene_file.string());
    } catch (const std::exception& e) {
      ctx.Warn(std::string("sphere tree: cannot write into the scene folder: ") + e.what());
    }
  }
  if (!written) {
    try {
      WriteTextAtomically(cache_file, text);
      ctx.Log("sphere tree: scene folder not writable; cached " + cache_file.string());
    } catch (const std::exception& e) {
      ctx.Warn(std::string("sphere tree: not cached (") + e.what() + "); it will be rebuilt next time");
    }
  }
  object.sphere_tree = std::move(tree);
  return *object.sphere_tree;
}

}  // namespace shadowsg
