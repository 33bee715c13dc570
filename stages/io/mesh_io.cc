#include "stages/io/mesh_io.h"

#include <tiny_obj_loader.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <optional>
#include <sstream>
#include <vector>

#include "calib/error.h"
#include "stages/io/atomic_file.h"

namespace shadowsg {
namespace fs = std::filesystem;

namespace {

void Validate(const TriangleMesh& mesh, const std::string& name) {
  if (mesh.vertices.empty()) throw InputError(name, "mesh has no vertices");
  if (mesh.faces.empty()) throw InputError(name, "mesh has no faces");
  for (const auto& v : mesh.vertices)
    if (!v.allFinite()) throw InputError(name, "mesh has a non-finite vertex coordinate");
  const int n = static_cast<int>(mesh.vertices.size());
  for (const auto& f : mesh.faces)
    for (int k = 0; k < 3; ++k)
      if (f[k] < 0 || f[k] >= n) throw InputError(name, "face refers to vertex " + std::to_string(f[k]) +
                                                             " of " + std::to_string(n));
  // Coordinates that overflow once squared (1e300) are as unusable as NaN.
  for (const auto& v : mesh.vertices)
    if (v.cwiseAbs().maxCoeff() > 1e30) throw InputError(name, "mesh has a non-finite vertex coordinate (|x| > 1e30)");
  bool any_area = false;
  for (const auto& f : mesh.faces) {
    const Eigen::Vector3d a = mesh.vertices[f[0]], b = mesh.vertices[f[1]], c = mesh.vertices[f[2]];
    if ((b - a).cross(c - a).norm() > 0) {
      any_area = true;
      break;
    }
  }
  if (!any_area)
    throw InputError(name, "all " + std::to_string(mesh.faces.size()) + " faces are degenerate (zero area)");
}

// tinyobjloader reads a coordinate it cannot parse ("nan", "1.#IND") as 0;
// a vertex line must hold numbers, and finite ones. A pointer scan, not a
// stream per line: a scanned mesh has millions of lines (stop 59).
void CheckObjVertexLines(const std::string& text, const std::string& name) {
  const char* p = text.data();
  const char* const end = p + text.size();
  const auto space = [](char c) { return std::isspace(static_cast<unsigned char>(c)) != 0; };
  for (int line_no = 1; p < end; ++line_no) {
    const char* eol = static_cast<const char*>(std::memchr(p, '\n', static_cast<size_t>(end - p)));
    if (!eol) eol = end;
    const char* s = p;
    p = eol + 1;
    while (s < eol && (*s == ' ' || *s == '\t')) ++s;
    if (eol - s < 2 || s[0] != 'v' || s[1] != ' ') continue;
    const char* q = s + 2;
    for (int k = 0; k < 3; ++k) {
      while (q < eol && space(*q)) ++q;
      const char* token = q;
      while (q < eol && !space(*q)) ++q;
      if (token == q) throw InputError(name + ":" + std::to_string(line_no), "vertex needs x y z");
      // strtod stops at the whitespace or newline that ends the token.
      char* stop = nullptr;
      const double v = std::strtod(token, &stop);
      if (stop != q)
        throw InputError(name + ":" + std::to_string(line_no),
                         "vertex coordinate '" + std::string(token, q) + "' is not a number");
      if (!std::isfinite(v)) throw InputError(name + ":" + std::to_string(line_no), "mesh has a non-finite vertex coordinate");
    }
  }
}

}  // namespace

TriangleMesh ReadObj(std::istream& stream, const std::string& name) {
  std::stringstream in;
  in << stream.rdbuf();
  in.clear();  // an empty file sets failbit; "no vertices" below says it better
  CheckObjVertexLines(in.str(), name);
  tinyobj::attrib_t attrib;
  std::vector<tinyobj::shape_t> shapes;
  std::vector<tinyobj::material_t> materials;
  std::string warn, err;
  // No material reader: a scene's OBJ needs no .mtl, and a missing one must not fail.
  const bool ok = tinyobj::LoadObj(&attrib, &shapes, &materials, &warn, &err, &in, nullptr, true);
  if (!ok) throw InputError(name, "unreadable OBJ: " + err);
  TriangleMesh mesh;
  const size_t nv = attrib.vertices.size() / 3;
  mesh.vertices.resize(nv);
  for (size_t i = 0; i < nv; ++i)
    mesh.vertices[i] = Eigen::Vector3d(attrib.vertices[3 * i], attrib.vertices[3 * i + 1], attrib.vertices[3 * i + 2]);
  for (const auto& s : shapes) {
    size_t offset = 0;
    for (size_t f = 0; f < s.mesh.num_face_vertices.size(); ++f) {
      const int n = s.mesh.num_face_vertices[f];
      if (n == 3)
        mesh.faces.emplace_back(s.mesh.indices[offset].vertex_index, s.mesh.indices[offset + 1].vertex_index,
                                s.mesh.indices[offset + 2].vertex_index);
      offset += n;
    }
  }
  Validate(mesh, name);
  return mesh;
}

namespace {

enum class PlyFormat { kAscii, kBinaryLE, kBinaryBE };

enum class PlyType { kInt8, kUint8, kInt16, kUint16, kInt32, kUint32, kFloat32, kFloat64, kUnknown };

PlyType ParsePlyType(const std::string& t) {
  if (t == "char" || t == "int8") return PlyType::kInt8;
  if (t == "uchar" || t == "uint8") return PlyType::kUint8;
  if (t == "short" || t == "int16") return PlyType::kInt16;
  if (t == "ushort" || t == "uint16") return PlyType::kUint16;
  if (t == "int" || t == "int32") return PlyType::kInt32;
  if (t == "uint" || t == "uint32") return PlyType::kUint32;
  if (t == "float" || t == "float32") return PlyType::kFloat32;
  if (t == "double" || t == "float64") return PlyType::kFloat64;
  return PlyType::kUnknown;
}

struct PlyProperty {
  std::string name, type, count_type;  // count_type non-empty for lists
  PlyType value = PlyType::kUnknown, count = PlyType::kUnknown;
};
struct PlyElement {
  std::string name;
  long count = 0;
  std::vector<PlyProperty> props;
};

// The binary body, read from memory: a scan's million faces are too many
// for a stream read and a string compare per value (stop 59).
class PlyBinaryReader {
 public:
  PlyBinaryReader(std::string body, bool big_endian, const std::string& name)
      : body_(std::move(body)), big_endian_(big_endian), name_(name) {}

  // A value of type `type` (spelled `spelling` in the header, for errors).
  double Next(PlyType type, const std::string& spelling) {
    static constexpr int kSize[] = {1, 1, 2, 2, 4, 4, 4, 8};
    if (type == PlyType::kUnknown) throw InputError(name_, "unknown PLY property type '" + spelling + "'");
    const size_t size = kSize[static_cast<int>(type)];
    if (body_.size() - at_ < size) throw InputError(name_, "PLY body is truncated");
    // The value's bits in the machine's order, assembled byte by byte.
    const auto* src = reinterpret_cast<const unsigned char*>(body_.data() + at_);
    at_ += size;
    uint64_t bits = 0;
    if (big_endian_)
      for (size_t i = 0; i < size; ++i) bits = (bits << 8) | src[i];
    else
      for (size_t i = size; i-- > 0;) bits = (bits << 8) | src[i];
    switch (type) {
      case PlyType::kInt8: return static_cast<int8_t>(static_cast<uint8_t>(bits));
      case PlyType::kUint8: return static_cast<uint8_t>(bits);
      case PlyType::kInt16: return static_cast<int16_t>(static_cast<uint16_t>(bits));
      case PlyType::kUint16: return static_cast<uint16_t>(bits);
      case PlyType::kInt32: return static_cast<int32_t>(static_cast<uint32_t>(bits));
      case PlyType::kUint32: return static_cast<uint32_t>(bits);
      case PlyType::kFloat32: {
        const uint32_t u = static_cast<uint32_t>(bits);
        float v;
        std::memcpy(&v, &u, 4);
        return v;
      }
      default: {
        double v;
        std::memcpy(&v, &bits, 8);
        return v;
      }
    }
  }

 private:
  std::string body_;
  size_t at_ = 0;
  bool big_endian_;
  const std::string& name_;
};

}  // namespace

TriangleMesh ReadPly(std::istream& in, const std::string& name) {
  std::string line;
  if (!std::getline(in, line) || line.rfind("ply", 0) != 0) throw InputError(name, "not a PLY file (no 'ply' magic)");
  PlyFormat format = PlyFormat::kAscii;
  std::vector<PlyElement> elements;
  bool header_done = false;
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::istringstream ls(line);
    std::string word;
    ls >> word;
    if (word == "format") {
      std::string f;
      ls >> f;
      if (f == "ascii") format = PlyFormat::kAscii;
      else if (f == "binary_little_endian") format = PlyFormat::kBinaryLE;
      else if (f == "binary_big_endian") format = PlyFormat::kBinaryBE;
      else throw InputError(name, "unknown PLY format '" + f + "'");
    } else if (word == "element") {
      PlyElement e;
      ls >> e.name >> e.count;
      if (!ls || e.count < 0 || e.count > (1L << 31)) throw InputError(name, "bad PLY element line: " + line);
      elements.push_back(e);
    } else if (word == "property") {
      if (elements.empty()) throw InputError(name, "PLY property before any element");
      PlyProperty p;
      std::string t;
      ls >> t;
      if (t == "list") ls >> p.count_type >> p.type >> p.name;
      else { p.type = t; ls >> p.name; }
      p.value = ParsePlyType(p.type);
      p.count = ParsePlyType(p.count_type);
      elements.back().props.push_back(p);
    } else if (word == "end_header") {
      header_done = true;
      break;
    }
  }
  if (!header_done) throw InputError(name, "PLY header has no end_header");
  std::optional<PlyBinaryReader> binary;
  if (format != PlyFormat::kAscii) {
    std::ostringstream body;
    if (in.peek() != std::char_traits<char>::eof()) body << in.rdbuf();
    binary.emplace(body.str(), format == PlyFormat::kBinaryBE, name);
  }
  TriangleMesh mesh;
  std::vector<long> list;
  std::istringstream row;
  for (const auto& e : elements) {
    // A binary row of no properties reads no bytes, so a huge count would spin
    // without ever reaching the end of the file.
    if (e.props.empty() && e.count > 0)
      throw InputError(name, "PLY element '" + e.name + "' has " + std::to_string(e.count) + " rows but no properties");
    const bool is_vertex = e.name == "vertex", is_face = e.name == "face";
    for (long i = 0; i < e.count; ++i) {
      list.clear();
      if (!binary) {
        if (!std::getline(in, line)) throw InputError(name, "PLY body is truncated");
        row.clear();
        row.str(line);
      }
      auto next = [&](PlyType type, const std::string& spelling) {
        if (binary) return binary->Next(type, spelling);
        double v;
        if (!(row >> v)) throw InputError(name, "PLY row is short or not numeric: " + line);
        return v;
      };
      Eigen::Vector3d xyz = Eigen::Vector3d::Zero();
      for (const auto& p : e.props) {
        if (!p.count_type.empty()) {
          const double n = next(p.count, p.count_type);
          // Written so that NaN fails too: a float count type can carry one.
          if (!(n >= 0 && n <= 1024) || n != std::floor(n))
            throw InputError(name, "PLY list length " + std::to_string(n) + " is not a count from 0 to 1024");
          const bool indices = p.name == "vertex_indices" || p.name == "vertex_index";
          if (indices) list.clear();
          for (int k = 0; k < static_cast<int>(n); ++k) {
            const double v = next(p.value, p.type);
            if (!indices) continue;  // other lists (texture coordinates, ...) are not used
            if (!(v >= 0 && v < 2147483647.0) || v != std::floor(v))
              throw InputError(name, "PLY face has vertex index " + std::to_string(v) + ", not a vertex number");
            list.push_back(static_cast<long>(v));
          }
        } else {
          const double v = next(p.value, p.type);
          if (p.name == "x") xyz.x() = v;
          if (p.name == "y") xyz.y() = v;
          if (p.name == "z") xyz.z() = v;
        }
      }
      if (is_vertex) mesh.vertices.push_back(xyz);
      if (is_face)
        for (size_t k = 2; k < list.size(); ++k)  // fan triangulation
          mesh.faces.emplace_back(static_cast<int>(list[0]), static_cast<int>(list[k - 1]), static_cast<int>(list[k]));
    }
  }
  Validate(mesh, name);
  return mesh;
}

TriangleMesh ReadMesh(const fs::path& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw InputError(path.string(), "mesh file not found");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path.string(), "cannot open mesh file");
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
  if (ext == ".obj") return ReadObj(in, path.string());
  if (ext == ".ply") return ReadPly(in, path.string());
  throw InputError(path.string(), "unsupported mesh type '" + ext + "' (expected .obj or .ply)");
}

void WriteObj(const fs::path& path, const TriangleMesh& mesh) {
  std::ostringstream out;
  out.precision(9);
  for (const auto& v : mesh.vertices) out << "v " << v.x() << ' ' << v.y() << ' ' << v.z() << '\n';
  for (const auto& f : mesh.faces) out << "f " << f[0] + 1 << ' ' << f[1] + 1 << ' ' << f[2] + 1 << '\n';
  WriteTextAtomically(path, out.str());
}

}  // namespace shadowsg
