// Triangle meshes from OBJ (tinyobjloader; polygons are triangulated) and PLY
// (ASCII and binary little/big endian; vertex x y z and face vertex_indices).
#pragma once

#include <filesystem>
#include <istream>
#include <string>

#include "solver/mesh.h"

namespace shadowsg {

TriangleMesh ReadMesh(const std::filesystem::path& path);  // by extension
TriangleMesh ReadObj(std::istream& in, const std::string& name_for_errors);
TriangleMesh ReadPly(std::istream& in, const std::string& name_for_errors);
void WriteObj(const std::filesystem::path& path, const TriangleMesh& mesh);

}  // namespace shadowsg
