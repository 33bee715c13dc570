// How well one level of a sphere tree fits a closed mesh: volume of the union
// against the mesh volume, how far spheres stick out of the surface, and
// whether the surface is covered (field-notes 3.2; method-notes: loose spheres
// cost several dB in the fit).
#pragma once

#include <cstdint>
#include <string>

#include "solver/mesh.h"
#include "solver/sphere_tree.h"

namespace shadowsg {

struct SphereTreeFitOptions {
  // Monte Carlo points in the box around mesh and spheres; the union/mesh
  // ratio's standard error is reported with it (about 0.3 % at the default for
  // a mesh that fills a third of its box).
  int volume_samples = 200000;
  // Uniform surface points for the coverage fraction.
  int surface_samples = 100000;
  // Points on each sphere at which protrusion is measured (Fibonacci lattice).
  int sphere_directions = 256;
  uint64_t seed = 1;

  bool IsValid(std::string* why) const;
  void Check() const;  // InputError("sphere tree fit options", why)
};

struct SphereTreeFit {
  int level = 0;
  int spheres = 0;            // non-empty spheres of the level
  double mesh_volume = 0;     // exact (divergence theorem)
  double union_volume = 0;    // Monte Carlo
  double volume_ratio = 0;    // union / mesh
  double volume_ratio_error = 0;  // one standard error of volume_ratio
  double outside_ratio = 0;   // union volume outside the mesh / mesh volume
  double inside_covered = 0;  // fraction of the mesh volume inside the union
  // Distance a sphere reaches beyond the surface (largest over its points that
  // lie outside the mesh), in units of the mesh's bounding-box diagonal: the
  // worst sphere and the mean over spheres (0 for a sphere inside).
  double max_protrusion = 0, mean_protrusion = 0;
  double vertex_coverage = 0;   // fraction of referenced vertices inside some sphere
  double surface_coverage = 0;  // fraction of uniform surface points inside some sphere
  int boundary_edges = 0;       // > 0: open mesh; inside/outside (and volumes) are unreliable

  std::string BriefReport() const;  // one line
};

// Level in [0, tree.levels); -1 = the leaf level. "Inside some sphere" allows
// 1e-9 of the bbox diagonal for rounding. Inside/outside of the mesh is by ray
// parity (Embree), so it needs a closed mesh. InputError for an empty mesh or a
// tree/level that does not fit.
SphereTreeFit EvaluateSphereTreeFit(const TriangleMesh& mesh, const SphereTree& tree, int level = -1,
                                    const SphereTreeFitOptions& options = {});

}  // namespace shadowsg
