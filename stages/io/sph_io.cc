#include "stages/io/sph_io.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>

#include "calib/error.h"
#include "stages/io/atomic_file.h"

namespace shadowsg {
namespace fs = std::filesystem;

// Radii at or below this are empty slots, as in the reference code.
constexpr double kEmptyRadius = 1e-4;

SphereTree ReadSph(std::istream& in, const std::string& name) {
  SphereTree tree;
  std::string line;
  if (!std::getline(in, line)) throw InputError(name, "empty sphere-tree file");
  std::istringstream header(line);
  if (!(header >> tree.levels >> tree.branching)) throw InputError(name, "first line must be 'levels branching'");
  if (tree.levels < 1 || tree.levels > 8 || tree.branching < 2 || tree.branching > 64)
    throw InputError(name, "unreasonable sphere tree shape " + std::to_string(tree.levels) + " levels, branching " +
                               std::to_string(tree.branching));
  const size_t n = SphereTree::NodeCount(tree.levels, tree.branching);
  if (n > 20000000) throw InputError(name, "sphere tree too large");
  tree.nodes.reserve(std::min<size_t>(n, 1 << 16));  // the header is not trusted for memory
  for (size_t i = 0; i < n; ++i) {
    if (!std::getline(in, line))
      throw InputError(name, "truncated: expected " + std::to_string(n) + " spheres, found " + std::to_string(i));
    std::istringstream ls(line);
    Sphere s;
    if (!(ls >> s.centre.x() >> s.centre.y() >> s.centre.z() >> s.radius))
      throw InputError(name, "line " + std::to_string(i + 2) + ": expected 'x y z r'");
    if (!s.centre.allFinite() || !std::isfinite(s.radius))
      throw InputError(name, "line " + std::to_string(i + 2) + ": non-finite value");
    if (s.radius <= kEmptyRadius) s.radius = 0;
    tree.nodes.push_back(s);
  }
  return tree;
}

SphereTree ReadSph(const fs::path& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw InputError(path.string(), "sphere-tree file not found");
  std::ifstream in(path);
  return ReadSph(in, path.string());
}

void WriteSph(std::ostream& out, const SphereTree& tree) {
  out << tree.levels << ' ' << tree.branching << '\n';
  // Every digit of a double: a solve that builds a tree and one that reads
  // its cached .sph back must see the same spheres (same result).
  out.precision(std::numeric_limits<double>::max_digits10);
  for (const auto& s : tree.nodes)
    out << s.centre.x() << ' ' << s.centre.y() << ' ' << s.centre.z() << ' ' << (s.empty() ? -1.0 : s.radius)
        << '\n';
}

void WriteSph(const fs::path& path, const SphereTree& tree) {
  std::ostringstream out;
  WriteSph(out, tree);
  WriteTextAtomically(path, out.str());
}

}  // namespace shadowsg
