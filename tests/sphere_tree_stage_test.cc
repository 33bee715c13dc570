#include "stages/sphere_tree_stage.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <fstream>

#include "solver/primitives.h"
#include "stages/io/sph_io.h"
#include "test_util.h"

namespace shadowsg {
namespace {

namespace fs = std::filesystem;

// A context that records log lines, and a user cache inside the test folder.
struct Fixture {
  testing::TempDir dir;
  std::vector<std::string> lines;
  StageContext ctx;
  Fixture() {
    setenv("XDG_CACHE_HOME", (dir / "cache").c_str(), 1);
    ctx.log = [this](const std::string& l) { lines.push_back(l); };
  }
  bool Logged(const std::string& what) const {
    for (const auto& l : lines)
      if (l.find(what) != std::string::npos) return true;
    return false;
  }
};

SceneObject Torus() {
  SceneObject o;
  o.mesh = MakeTorus(0.5, 0.2, 24, 12);
  o.mesh_path = "geometry/mesh.obj";
  return o;
}

void ExpectSameTree(const SphereTree& a, const SphereTree& b) {
  ASSERT_EQ(a.nodes.size(), b.nodes.size());
  for (size_t i = 0; i < a.nodes.size(); ++i) {
    EXPECT_LT((a.nodes[i].centre - b.nodes[i].centre).norm(), 1e-7);
    EXPECT_NEAR(a.nodes[i].radius, b.nodes[i].radius, 1e-7);
  }
}

TEST(SphereTreeStage, BuildsWritesNextToTheMeshAndReuses) {
  Fixture f;
  SceneObject a = Torus();
  const SphereTree& built = EnsureSphereTree(a, f.dir.path(), f.ctx);
  EXPECT_EQ(built.nodes.size(), 585u);
  EXPECT_EQ(a.sph_path, "geometry/mesh_sphere.sph");
  EXPECT_TRUE(fs::is_regular_file(f.dir / "geometry/mesh_sphere.sph"));
  EXPECT_TRUE(f.Logged("built"));
  // The file reads as a plain .sph.
  ExpectSameTree(ReadSph(f.dir / "geometry/mesh_sphere.sph"), built);
  // A second run finds it instead of building again.
  f.lines.clear();
  SceneObject b = Torus();
  ExpectSameTree(EnsureSphereTree(b, f.dir.path(), f.ctx), built);
  EXPECT_TRUE(f.Logged("using"));
  EXPECT_FALSE(f.Logged("built"));
}

TEST(SphereTreeStage, UnwritableSceneFolderUsesTheUserCache) {
  Fixture f;
  // A scene "folder" below a regular file can never be created, whoever runs the test.
  std::ofstream(f.dir / "not_a_folder") << "x";
  const fs::path scene = f.dir / "not_a_folder";
  SceneObject a = Torus();
  const SphereTree built = EnsureSphereTree(a, scene, f.ctx);
  EXPECT_EQ(a.sph_path, "");
  const fs::path cached = SphereTreeCacheDir() / (SphereTreeCacheKey(a.mesh, SceneSphereTreeOptions()) + ".sph");
  EXPECT_EQ(SphereTreeCacheDir(), f.dir / "cache" / "shadowsg" / "spheretrees");
  ASSERT_TRUE(fs::is_regular_file(cached));
  f.lines.clear();
  SceneObject b = Torus();
  ExpectSameTree(EnsureSphereTree(b, scene, f.ctx), built);
  EXPECT_TRUE(f.Logged("using " + cached.string()));
}

TEST(SphereTreeStage, KeepsALoadedTreeAndRebuildsAStaleOne) {
  Fixture f;
  SceneObject a = Torus();
  // A reference tree (no key line) loaded with the scene is used as it is.
  SphereTree given;
  given.levels = 1;
  given.branching = 8;
  given.nodes = {{Eigen::Vector3d::Zero(), 1.0}};
  fs::create_directories(f.dir / "geometry");
  WriteSph(f.dir / "geometry/ref.sph", given);
  a.sph_path = "geometry/ref.sph";
  a.sphere_tree = given;
  EXPECT_EQ(EnsureSphereTree(a, f.dir.path(), f.ctx).nodes.size(), 1u);
  // One this project wrote for another mesh is rebuilt, in the same place.
  std::ofstream(f.dir / "geometry/old.sph") << SphTextWithKey(given, "0123456789abcdef");
  SceneObject b = Torus();
  b.sph_path = "geometry/old.sph";
  b.sphere_tree = ReadSph(f.dir / "geometry/old.sph");
  EXPECT_EQ(EnsureSphereTree(b, f.dir.path(), f.ctx).nodes.size(), 585u);
  EXPECT_TRUE(f.Logged("rebuilding"));
  EXPECT_EQ(ReadSph(f.dir / "geometry/old.sph").nodes.size(), 585u);
}

TEST(SphereTreeStage, CacheKeyFollowsMeshAndOptions) {
  const SceneObject a = Torus();
  SphereTreeBuildOptions o;
  const std::string k = SphereTreeCacheKey(a.mesh, o);
  EXPECT_EQ(k.size(), 16u);
  EXPECT_EQ(k, SphereTreeCacheKey(Torus().mesh, o));
  o.seed = 1;
  EXPECT_NE(k, SphereTreeCacheKey(a.mesh, o));
  TriangleMesh moved = a.mesh;
  moved.vertices[0].x() += 1e-9;
  EXPECT_NE(k, SphereTreeCacheKey(moved, SphereTreeBuildOptions{}));
}

}  // namespace
}  // namespace shadowsg
