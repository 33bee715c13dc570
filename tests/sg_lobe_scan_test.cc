#include <gtest/gtest.h>

#include <cmath>

#include "sg_test_scene.h"
#include "solver/sg_lobe_scan.h"
#include "solver/sg_shading.h"
#include "solver/shadow_plane.h"

namespace shadowsg {
namespace {

using testing::TestPlaneModel;

constexpr double kDeg = M_PI / 180;

Eigen::Vector3d Direction(double elevation_deg, double azimuth_deg) {
  const double e = elevation_deg * kDeg, a = azimuth_deg * kDeg;
  return {std::cos(e) * std::cos(a), std::cos(e) * std::sin(a), std::sin(e)};
}

SgLighting SunAndSky(const Eigen::Vector3d& sun_axis, double sun_sharpness) {
  SgLighting l;
  l.lobes.push_back({Eigen::Vector3d(0, 0, 1), 2.0, Eigen::Vector3d(1.0, 1.1, 1.3)});
  l.lobes.push_back({sun_axis, sun_sharpness, Eigen::Vector3d(60, 55, 45)});
  return l;
}

double AngleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)) / kDeg;
}

// A sun started 5 degrees too high, 2 degrees off in azimuth and half as
// sharp casts a shadow that misses the observed one; the scan puts it back.
TEST(LobeScan, MovesAMisplacedSunOntoItsShadow) {
  ShadowPlaneModel model = TestPlaneModel(64, CosineModel::kExact);
  model.PrepareCones();
  const Eigen::Vector3d sun = Direction(25, 40);
  const std::vector<Eigen::Vector3f> targets = RenderShadowPlane(model, SunAndSky(sun, 200));
  const std::vector<double> weight(model.points.size(), 1.0);

  SgLighting start = SunAndSky(Direction(30, 42), 100);
  const LobeScanResult r = ScanBrightestSharpLobe(model, weight, targets, &start);
  EXPECT_EQ(r.lobe, 1);
  ASSERT_TRUE(r.moved);
  EXPECT_NEAR(r.elevation_shift_deg, -5, 1e-9);
  EXPECT_NEAR(r.azimuth_shift_deg, -2, 1e-9);
  EXPECT_LT(r.error_after, 1e-4 * r.error_before);
  ASSERT_EQ(start.lobes.size(), 2u);
  const SgLobe& moved = start.lobes.back();  // the scanned lobe goes last
  EXPECT_LT(AngleDeg(moved.axis, sun), 1e-6);
  // On this plane the sun's shadow is hard at sharpness 50, 100 and 200
  // alike: the three columns are proportional, and with the amplitudes
  // re-solved all three fit to rounding (1e-15 of the signal). Which of them
  // the scan takes is rounding's choice (it differs between instruction
  // sets); the light on the plane is what it must get right.
  const SgLobe truth = SunAndSky(sun, 200).lobes[1];
  auto unoccluded = [&](const SgLobe& l) {
    return EvalProductLobe(l.axis, l.sharpness, model.normal, model.cosine, false).scale * l.amplitude.sum();
  };
  EXPECT_NEAR(unoccluded(moved) / unoccluded(truth), 1.0, 1e-4);
  const std::vector<Eigen::Vector3f> render = RenderShadowPlane(model, start);
  double se = 0, ss = 0;
  for (size_t k = 0; k < render.size(); ++k)
    se += (render[k] - targets[k]).squaredNorm(), ss += targets[k].squaredNorm();
  EXPECT_LT(se, 1e-8 * ss);
}

// A sharp lobe past the scan's elevation limits (89.5 degrees, near the
// pole; -7, below the horizon) is scanned from its own place: it stays where
// nothing fits better, and a sun above it is found.
TEST(LobeScan, ScansALobePastTheElevationLimitsFromItsOwnPlace) {
  ShadowPlaneModel model = TestPlaneModel(48, CosineModel::kExact);
  model.PrepareCones();
  const std::vector<double> weight(model.points.size(), 1.0);
  for (double elevation : {89.5, -7.0}) {
    const SgLighting truth = SunAndSky(Direction(elevation, 30), 200);
    SgLighting placed = truth;
    const LobeScanResult r = ScanBrightestSharpLobe(model, weight, RenderShadowPlane(model, truth), &placed);
    EXPECT_EQ(r.lobe, 1) << elevation;
    EXPECT_FALSE(r.moved) << elevation;
    EXPECT_LT(AngleDeg(placed.lobes[1].axis, truth.lobes[1].axis), 1e-9) << elevation;
  }
  // Started 6 degrees under the near-pole sun: the grid's highest point under
  // its 89-degree limit (88.5, 5 steps up) is the closest it can reach.
  const SgLighting truth = SunAndSky(Direction(89.5, 30), 200);
  SgLighting low = SunAndSky(Direction(83.5, 30), 200);
  const LobeScanResult r = ScanBrightestSharpLobe(model, weight, RenderShadowPlane(model, truth), &low);
  ASSERT_TRUE(r.moved);
  EXPECT_NEAR(r.elevation_shift_deg, 5, 1e-9);
}

// At the right place nothing moves, and a scene of broad lobes alone has no
// shadow edge to scan.
TEST(LobeScan, LeavesAPlacedSunAndBroadLightAlone) {
  ShadowPlaneModel model = TestPlaneModel(48, CosineModel::kExact);
  model.PrepareCones();
  const SgLighting truth = SunAndSky(Direction(35, -60), 150);
  const std::vector<Eigen::Vector3f> targets = RenderShadowPlane(model, truth);
  const std::vector<double> weight(model.points.size(), 1.0);
  SgLighting placed = truth;
  const LobeScanResult r = ScanBrightestSharpLobe(model, weight, targets, &placed);
  EXPECT_EQ(r.lobe, 1);
  EXPECT_FALSE(r.moved) << r.error_before << " -> " << r.error_after << " shift " << r.elevation_shift_deg << " " << r.azimuth_shift_deg << " x" << r.sharpness_factor;
  EXPECT_EQ(placed.lobes[1].axis, truth.lobes[1].axis);

  SgLighting broad;
  broad.lobes.push_back({Eigen::Vector3d(0, 0, 1), 2.0, Eigen::Vector3d(1, 1, 1)});
  broad.lobes.push_back({Direction(40, 10), 8.0, Eigen::Vector3d(3, 3, 3)});
  const LobeScanResult none = ScanBrightestSharpLobe(model, weight, RenderShadowPlane(model, broad), &broad);
  EXPECT_EQ(none.lobe, -1);
  EXPECT_FALSE(none.moved);
}

}  // namespace
}  // namespace shadowsg
