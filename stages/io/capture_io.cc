#include "stages/io/capture_io.h"

#include <cmath>
#include <fstream>
#include <sstream>

#include "calib/error.h"
#include "stages/io/scene_io.h"

namespace shadowsg {
namespace fs = std::filesystem;

namespace {

std::vector<std::string> StringList(const JsonReader& r, const std::string& key) {
  std::vector<std::string> out;
  if (!r.Has(key)) return out;
  const JsonReader list = r.Child(key);
  for (size_t i = 0; i < list.Size(); ++i) {
    const Json& j = list.Element(i).node();
    if (!j.is_string()) list.Element(i).Fail("", "expected a string");
    out.push_back(j.get<std::string>());
  }
  return out;
}

}  // namespace

Json CameraFileToJson(const CameraFile& f) {
  Json j = CameraToJson(f.camera);
  j["rms_px"] = f.rms_px;
  j["views_used"] = f.views_used;
  j["views_rejected"] = f.views_rejected;
  return j;
}

CameraFile ParseCameraFile(const Json& json, const std::string& name) {
  const JsonReader root(json, name);
  if (!json.is_object()) root.Fail("", "expected a JSON object");
  // A scene.json carries the camera as a block; camera.json is the block.
  const bool is_scene = json.contains("camera") && json["camera"].is_object();
  Json block = is_scene ? json["camera"] : json;
  if (!block.contains("c2w")) block["c2w"] = ToJson(Eigen::Matrix4d(Eigen::Matrix4d::Identity()));
  const JsonReader r(block, name, is_scene ? "camera" : "");
  CameraFile f;
  f.camera = ParseCamera(r);
  f.rms_px = r.Number("rms_px", 0.0);
  f.views_used = StringList(r, "views_used");
  f.views_rejected = StringList(r, "views_rejected");
  return f;
}

CameraFile ReadCameraFile(const fs::path& path) { return ParseCameraFile(ReadJsonFile(path), path.string()); }

Json PoseFileToJson(const PoseFile& f) {
  Json j;
  j["o2c"] = ToJson(f.o2c);
  j["rms_px"] = f.rms_px;
  j["method"] = f.method;
  if (f.plane_c) j["plane_c"] = Json{{"xyz", ToJson(f.plane_c->xyz)}, {"normal", ToJson(f.plane_c->normal)}};
  return j;
}

PoseFile ParsePoseFile(const Json& json, const std::string& name) {
  const JsonReader r(json, name);
  PoseFile f;
  f.o2c = r.Mat4("o2c");
  const Eigen::Matrix3d R = f.o2c.topLeftCorner<3, 3>();
  if ((f.o2c.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).norm() > 1e-6 ||
      (R.transpose() * R - Eigen::Matrix3d::Identity()).norm() > 1e-3 || R.determinant() < 0)
    r.Fail("o2c", "not a rigid transform");
  f.rms_px = r.Number("rms_px");
  f.method = r.String("method");
  if (f.method != "apriltag" && f.method != "pnp")
    r.Fail("method", "expected \"apriltag\" or \"pnp\", got \"" + f.method + "\"");
  if (r.Has("plane_c")) {
    const JsonReader p = r.Child("plane_c");
    PlaneInCamera plane;
    plane.xyz = p.Vec3("xyz");
    plane.normal = p.Vec3("normal");
    if (plane.normal.norm() < 1e-9) p.Fail("normal", "zero vector");
    plane.normal.normalize();
    f.plane_c = plane;
  }
  return f;
}

PoseFile ReadPoseFile(const fs::path& path) { return ParsePoseFile(ReadJsonFile(path), path.string()); }

Correspondences ReadCorrespondences(std::istream& in, const std::string& name) {
  Correspondences c;
  std::string line;
  int line_no = 0;
  bool first_content = true;
  while (std::getline(in, line)) {
    ++line_no;
    for (char& ch : line)
      if (ch == ',' || ch == ';' || ch == '\t' || ch == '\r') ch = ' ';
    const size_t start = line.find_first_not_of(' ');
    if (start == std::string::npos || line[start] == '#') continue;
    std::istringstream ss(line);
    std::vector<double> v;
    std::string tok;
    bool numeric = true;
    while (ss >> tok) {
      try {
        size_t used = 0;
        const double x = std::stod(tok, &used);
        if (used != tok.size() || !std::isfinite(x)) numeric = false;
        v.push_back(x);
      } catch (const std::exception&) {
        numeric = false;
      }
    }
    if (!numeric && first_content) {  // header
      first_content = false;
      continue;
    }
    first_content = false;
    if (!numeric || v.size() != 5)
      throw InputError(name + ":" + std::to_string(line_no), "expected 5 numbers u, v, x, y, z");
    c.image.emplace_back(v[0], v[1]);
    c.object.emplace_back(v[2], v[3], v[4]);
  }
  if (c.image.empty()) throw InputError(name, "no correspondences (lines u, v, x, y, z)");
  return c;
}

Correspondences ReadCorrespondencesFile(const fs::path& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw InputError(path.string(), "file not found");
  std::ifstream in(path);
  if (!in) throw InputError(path.string(), "cannot open file");
  return ReadCorrespondences(in, path.string());
}

}  // namespace shadowsg
