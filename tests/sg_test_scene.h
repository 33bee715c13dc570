// A closed-form test scene: a grid of plane points around a small sphere-tree
// caster, rendered by the model itself, for solver and gradient tests.
#pragma once

#include <cmath>
#include <memory>

#include "solver/caster_bounce.h"
#include "solver/primitives.h"
#include "solver/ray_caster.h"
#include "solver/shadow_plane.h"

namespace shadowsg::testing {

inline SphereTree TestCasterTree() {
  SphereTree t;
  t.levels = 2;
  t.branching = 8;
  t.nodes.push_back({Eigen::Vector3d(0, 0, 0.35), 0.45});
  for (int k = 0; k < 8; ++k) {
    const double a = 2 * M_PI * k / 8;
    // A leaning, uneven cluster: shadows differ with the light direction.
    t.nodes.push_back({Eigen::Vector3d(0.18 * std::cos(a), 0.12 * std::sin(a), 0.15 + 0.05 * k), 0.09 + 0.01 * (k % 3)});
  }
  return t;
}

inline ShadowPlaneModel TestPlaneModel(int grid, CosineModel cosine) {
  ShadowPlaneModel m;
  m.cosine = cosine;
  m.occluders.push_back(TestCasterTree());
  for (int y = 0; y < grid; ++y)
    for (int x = 0; x < grid; ++x) {
      m.points.emplace_back(-1.5 + 3.0 * (x + 0.5) / grid, -1.5 + 3.0 * (y + 0.5) / grid, 0.0);
      m.albedo.emplace_back(0.8f, 0.7f, 0.6f);
    }
  return m;
}

// The casters' bounce for the test plane: a white sphere mesh of about the
// caster's size (the direct light's sphere tree and it need not agree).
// albedo above 1 makes a bounce no real caster gives (a model that cannot fit).
inline void AddTestCasterBounce(ShadowPlaneModel* model, double albedo = 0.9) {
  TriangleMesh ball = MakeIcosphere(0.3, 3);
  for (Eigen::Vector3d& v : ball.vertices) v += Eigen::Vector3d(0, 0, 0.301);
  RayCaster casters;
  casters.AddMesh(ball);
  casters.Commit();
  CasterBounceOptions o;
  o.patches = 64;
  model->bounce = std::make_shared<const CasterBounce>(std::vector<TriangleMesh>{ball},
                                                       std::vector<Eigen::Vector3d>{Eigen::Vector3d::Constant(albedo)},
                                                       casters, Eigen::Vector3d::Zero(), model->normal, o);
}

}  // namespace shadowsg::testing
