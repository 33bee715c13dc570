#include "solver/envmap.h"

#include <gtest/gtest.h>

#include <cmath>

#include "calib/conventions.h"
#include "solver/sg.h"

namespace shadowsg {
namespace {

TEST(EnvMap, ConstantMapGivesPiIrradiance) {
  const Image env = MakeEnvMap(64, [](const Eigen::Vector3d&) { return Eigen::Vector3d::Ones(); });
  const Eigen::Vector3d e = EnvIrradiance(env, Eigen::Vector3d::UnitZ());
  EXPECT_NEAR(e.x(), M_PI, 2e-3 * M_PI);
}

TEST(EnvMap, ResampleKeepsIntegral) {
  SgLighting sg;
  sg.lobes.push_back({Eigen::Vector3d(0.3, 0.2, 0.9).normalized(), 20.0, Eigen::Vector3d(1, 2, 3)});
  const Image hi = SgToEnvMap(sg, 256);
  const Image lo = ResampleEnvMap(hi, 64);
  ASSERT_EQ(lo.height, 64);
  ASSERT_EQ(lo.width, 128);
  auto integral = [](const Image& env) {
    double s = 0;
    for (int v = 0; v < env.height; ++v)
      for (int u = 0; u < env.width; ++u) s += env.at(u, v, 2) * 2 * M_PI / env.width *
                                              (std::cos(M_PI * v / env.height) - std::cos(M_PI * (v + 1) / env.height));
    return s;
  };
  EXPECT_NEAR(integral(lo), integral(hi), 1e-4 * integral(hi));
  EXPECT_NEAR(integral(hi), SgIntegral(sg.lobes[0]).z(), 1e-2 * integral(hi));
}

TEST(EnvMap, SampleAtTexelCentreReturnsTexel) {
  const Image env = MakeEnvMap(16, [](const Eigen::Vector3d& d) { return Eigen::Vector3d(d.x() + 2, d.y() + 2, d.z() + 2); });
  const Eigen::Vector3d d = EnvTexelDirection(5, 3, 32, 16);
  EXPECT_NEAR(SampleEnvMap(env, d).x(), env.at(5, 3, 0), 1e-5);
}

}  // namespace
}  // namespace shadowsg
