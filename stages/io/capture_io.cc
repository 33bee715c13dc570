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

Json PlaneFileToJson(const PlaneFile& f) {
  Json j = f.extra.is_object() ? f.extra : Json::object();
  Json plane{{"xyz", ToJson(f.xyz)}, {"normal", ToJson(f.normal)}};
  if (f.half_extent) plane["scale"] = ToJson(Eigen::Vector3d(f.half_extent->x(), f.half_extent->y(), 1.0));
  j["plane"] = plane;
  Json hero{{"image", f.hero_image}, {"c2w", ToJson(f.hero_c2w)}};
  if (f.hero_camera) {
    Camera cam = *f.hero_camera;
    cam.c2w = f.hero_c2w;
    hero["camera"] = CameraToJson(cam);
  }
  j["hero"] = hero;
  j["scale_source"] = f.scale_source;
  j["registered_images"] = f.registered_images;
  j["plane_inliers"] = f.plane_inliers;
  return j;
}

PlaneFile ParsePlaneFile(const Json& json, const std::string& name) {
  const JsonReader r(json, name);
  if (!json.is_object()) r.Fail("", "expected a JSON object");
  PlaneFile f;
  const JsonReader plane = r.Child("plane");
  f.xyz = plane.Vec3("xyz");
  f.normal = plane.Vec3("normal");
  if (std::abs(f.normal.norm() - 1) > 1e-3) plane.Fail("normal", "not a unit vector");
  f.normal.normalize();
  if (plane.Has("scale")) {
    const Eigen::Vector3d s = plane.Vec3("scale");
    if (!(s.x() > 0 && s.y() > 0)) plane.Fail("scale", "half extents must be positive");
    f.half_extent = s.head<2>();
  }
  const JsonReader hero = r.Child("hero");
  f.hero_image = hero.String("image");
  f.hero_c2w = hero.Mat4("c2w");
  const Eigen::Matrix3d R = f.hero_c2w.topLeftCorner<3, 3>();
  if ((f.hero_c2w.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).norm() > 1e-6 ||
      (R.transpose() * R - Eigen::Matrix3d::Identity()).norm() > 1e-3 || R.determinant() < 0)
    hero.Fail("c2w", "not a rigid transform");
  if (hero.Has("camera")) f.hero_camera = ParseCamera(hero.Child("camera"));
  f.scale_source = r.String("scale_source");
  if (f.scale_source != "apriltag" && f.scale_source != "distance" && f.scale_source != "none")
    r.Fail("scale_source", "expected \"apriltag\", \"distance\" or \"none\", got \"" + f.scale_source + "\"");
  f.registered_images = r.Int("registered_images");
  f.plane_inliers = r.Int("plane_inliers");
  f.extra = json;
  for (const char* k : {"plane", "hero", "scale_source", "registered_images", "plane_inliers"}) f.extra.erase(k);
  return f;
}

PlaneFile ReadPlaneFile(const fs::path& path) { return ParsePlaneFile(ReadJsonFile(path), path.string()); }

Correspondences ReadCorrespondencesFile(const fs::path& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw InputError(path.string(), "file not found");
  std::ifstream in(path);
  if (!in) throw InputError(path.string(), "cannot open file");
  return ReadCorrespondences(in, path.string());
}

}  // namespace shadowsg
