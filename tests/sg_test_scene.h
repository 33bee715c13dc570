// A closed-form test scene: a grid of plane points around a small sphere-tree
// caster, rendered by the model itself, for solver and gradient tests.
#pragma once

#include <cmath>

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

}  // namespace shadowsg::testing
