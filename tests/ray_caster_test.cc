#include "solver/ray_caster.h"

#include <gtest/gtest.h>

#include "solver/mesh.h"
#include "solver/primitives.h"

namespace shadowsg {
namespace {

TEST(RayCaster, HitsUnitSphereAtRadius) {
  RayCaster rc;
  rc.AddMesh(MakeIcosphere(1.0, 4));
  rc.Commit();
  const auto hit = rc.Intersect(Eigen::Vector3d(0, 0, -5), Eigen::Vector3d::UnitZ());
  ASSERT_TRUE(hit);
  EXPECT_NEAR(hit->t, 4.0, 2e-3);
  EXPECT_LT(hit->normal.z(), -0.99);
  EXPECT_FALSE(rc.Intersect(Eigen::Vector3d(0, 2, -5), Eigen::Vector3d::UnitZ()));
  EXPECT_TRUE(rc.Occluded(Eigen::Vector3d(0, 0, -5), Eigen::Vector3d::UnitZ()));
  EXPECT_FALSE(rc.Occluded(Eigen::Vector3d(0, 0, -5), Eigen::Vector3d::UnitZ(), 0, 3.0));
}

TEST(RayCaster, BatchedVisibilityMatchesSingleRays) {
  RayCaster rc;
  rc.AddMesh(MakeBox(Eigen::Vector3d(0.5, 0.5, 0.5)));
  rc.Commit();
  std::vector<Eigen::Vector3d> dirs;
  for (int i = 0; i < 37; ++i) dirs.push_back(Eigen::Vector3d(std::cos(i * 0.3), std::sin(i * 0.3), 0.7).normalized());
  std::vector<char> vis;
  const Eigen::Vector3d o(0.3, 0.1, -2);
  rc.Visible(o, dirs, 0, &vis);
  ASSERT_EQ(vis.size(), dirs.size());
  for (size_t i = 0; i < dirs.size(); ++i) EXPECT_EQ(vis[i] != 0, !rc.Occluded(o, dirs[i]));
}

TEST(Primitives, ClosedAndOutward) {
  for (const TriangleMesh& m : {MakeBox(Eigen::Vector3d(1, 2, 3)), MakeIcosphere(1, 2), MakeCylinder(1, 2, 32),
                                MakeCone(1, 2, 32), MakeTorus(1, 0.3, 32, 16)}) {
    EXPECT_EQ(CountBoundaryEdges(m), 0);
    EXPECT_GT(MeshVolume(m), 0);
  }
  EXPECT_NEAR(MeshVolume(MakeBox(Eigen::Vector3d(1, 2, 3))), 48.0, 1e-12);
}

}  // namespace
}  // namespace shadowsg
