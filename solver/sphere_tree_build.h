// Builds a tight, covering sphere tree of a closed triangle mesh after the
// adaptive medial-axis approximation of Bradshaw & O'Sullivan (ACM TOG 23(1),
// 2004; field-notes 3.2) and its "Expand" reduction:
//  1. the surface is tiled by a fine grid of micro-triangles (surface_samples.h);
//     a mesh finer than the grid asks for (a scan, whose grid is its vertices)
//     gives steps 2-3 an even subset of about surface_points of its points,
//     and every point then goes where its nearest subset point may;
//  2. inscribed (medial) spheres are grown from seed points by the shrinking-ball
//     method (medial_spheres.h): they touch the surface and do not cross it;
//  3. the leaves: all medial spheres are grown by a common stand-off delta, and
//     the smallest delta at which a greedy set cover with at most B^(L-1) of
//     them covers every grid point is found by bisection (Expand, done once for
//     the whole surface so that hard parts get more leaves than easy ones);
//     each point goes to the chosen sphere it protrudes least from, and each
//     leaf is shrunk to its farthest point (points a sibling already holds are
//     handed over first);
//  4. each micro-triangle is made to lie inside one leaf, split into four where
//     it straddles leaves, growing the cheapest leaf only where a piece is in
//     none: a ball is convex, so the leaves cover the whole surface, not only
//     the points;
//  5. the leaves are grouped B at a time by balanced spatial splits, and every
//     inner node is a sphere enclosing its children, so a child lies inside its
//     parent and every level covers what the leaves cover.
// Deterministic in the seed and independent of the thread count.
#pragma once

#include <cstdint>
#include <string>

#include "solver/mesh.h"
#include "solver/progress.h"
#include "solver/sphere_tree.h"

namespace shadowsg {

struct SphereTreeBuildOptions {
  // Levels including the root (as in the .sph header): 4 gives 1 + 8 + 64 + 512 spheres.
  int levels = 4;
  int branching = 8;
  uint64_t seed = 0;
  // Surface grid points; the leaves cover the micro-triangles between them.
  int surface_points = 40000;
  // Shrinking-ball seeds, i.e. candidate leaves before near-duplicates are
  // dropped (Bradshaw & O'Sullivan's -initSpheres is 1000; 8000 is where the
  // union/mesh volume of Spot, a cow and a cone stopped improving by > 1 %).
  int medial_spheres = 8000;

  bool IsValid(std::string* why) const;
  void Check() const;  // InputError("sphere tree options", why)
};

struct SphereTreeBuildSummary {
  double seconds = 0;
  int surface_points = 0;
  int cover_points = 0;      // those the medial balls and the leaf cover used (fewer on a fine mesh)
  double spacing = 0;        // longest micro-triangle edge
  int medial_spheres = 0;    // distinct candidates found
  int leaves = 0;            // non-empty leaves (at most B^(L-1))
  double leaf_standoff = 0;  // the stand-off delta of the leaf cover, in units of the bbox diagonal
  double leaf_growth = 0;    // largest growth of a leaf to cover the micro-triangles, same unit
  int boundary_edges = 0;    // > 0: the mesh is open and "inside" is a guess
  bool inverted = false;     // faces wound inwards (negative volume); normals were flipped
};

// InputError for a mesh without faces, with bad indices, non-finite or
// zero-area geometry, or for invalid options. An open mesh is built anyway;
// summary->boundary_edges says so.
SphereTree BuildSphereTree(const TriangleMesh& mesh, const SphereTreeBuildOptions& options,
                           const ProgressFn& progress = {}, SphereTreeBuildSummary* summary = nullptr);

}  // namespace shadowsg
