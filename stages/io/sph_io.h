// The .sph sphere-tree text format of Bradshaw & O'Sullivan's spheretree tools
// (scene-format.md): "L B", then (B^L-1)/(B-1) lines "x y z r [error]".
#pragma once

#include <filesystem>
#include <istream>
#include <ostream>
#include <string>

#include "solver/sphere_tree.h"

namespace shadowsg {

SphereTree ReadSph(std::istream& in, const std::string& name_for_errors);
SphereTree ReadSph(const std::filesystem::path& path);
void WriteSph(std::ostream& out, const SphereTree& tree);
void WriteSph(const std::filesystem::path& path, const SphereTree& tree);

}  // namespace shadowsg
