// A small sphere enclosing a set of spheres (or points: radius 0), by the
// Badoiu-Clarkson walk ("Smaller core-sets for balls", SODA 2003): after k
// steps the radius is within about 1/sqrt(k) of the smallest; the best centre
// seen is kept and its radius is made exact, so the result always encloses.
#pragma once

#include <vector>

#include "solver/sphere_tree.h"

namespace shadowsg {

// Empty spheres (radius <= 0) count as points only when all are points:
// `spheres` must be non-empty.
Sphere EnclosingSphere(const std::vector<Sphere>& spheres, int iterations);

}  // namespace shadowsg
