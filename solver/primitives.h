// Closed, outward-oriented primitive meshes for synthetic scenes and tests.
#pragma once

#include "solver/mesh.h"

namespace shadowsg {

TriangleMesh MakeBox(const Eigen::Vector3d& half_extents);
TriangleMesh MakeIcosphere(double radius, int subdivisions);
// Axis +z, base at z = 0.
TriangleMesh MakeCylinder(double radius, double height, int segments);
TriangleMesh MakeCone(double radius, double height, int segments);
// Around the z axis, centred at the origin.
TriangleMesh MakeTorus(double major_radius, double minor_radius, int major_segments, int minor_segments);

}  // namespace shadowsg
