// Inscribed ("medial") spheres of a closed surface by the shrinking-ball method
// (Ma, Bae, Choi, Park, "3D medial axis point approximation using nearest
// neighbors and the normal field", The Visual Computer 28(1), 2012): for a
// surface point p with inward normal n, the largest ball tangent to the surface
// at p that holds no surface point. Their union approximates the solid; the
// sphere-tree builder chooses among them.
#pragma once

#include <Eigen/Dense>
#include <vector>

#include "solver/point_kdtree.h"

namespace shadowsg {

struct MedialSphere {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  double radius = 0;
  int seed = -1;  // the surface point it touches
};

// One sphere per seed whose inward normal is non-zero and whose ball does not
// collapse (radius <= min_radius). `surface` holds the surface points (the
// balls are empty of them), inward_normals their unit inward normals.
// start_radius[s] is the first radius tried for seeds[s]: any upper bound
// works (e.g. half the distance to the opposite wall along the normal; the
// bounding-box diagonal for open or badly oriented surfaces, whose balls need
// not stop); a tight one saves nearest-neighbour queries far from the surface.
// With touch_tolerance > 0, a seed is skipped when an earlier ball already
// touches it (it lies within the tolerance of that ball's surface, its normal
// pointing at the centre): its ball would nearly repeat that one. This keeps
// round shapes, whose every point touches the same few balls, fast.
std::vector<MedialSphere> ShrinkingBallSpheres(const PointKdTree& surface,
                                               const std::vector<Eigen::Vector3d>& inward_normals,
                                               const std::vector<int>& seeds,
                                               const std::vector<double>& start_radius, double min_radius,
                                               double touch_tolerance = 0);

}  // namespace shadowsg
