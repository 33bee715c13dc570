#include "stages/io/scene_io.h"

#include <cctype>
#include <algorithm>
#include <cmath>
#include <limits>

#include "calib/error.h"
#include "stages/io/image_io.h"
#include "stages/io/mesh_io.h"
#include "stages/io/sph_io.h"

namespace shadowsg {
namespace fs = std::filesystem;

namespace {

constexpr int kMaxImageSide = 65536;

void CheckRigid(const JsonReader& r, const std::string& key, const Eigen::Matrix4d& m, bool allow_scale) {
  if ((m.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).norm() > 1e-6) r.Fail(key, "last row must be [0, 0, 0, 1]");
  const Eigen::Matrix3d R = m.block<3, 3>(0, 0);
  if (allow_scale) {
    if (std::abs(R.determinant()) < 1e-12) r.Fail(key, "matrix is singular");
    return;
  }
  if ((R.transpose() * R - Eigen::Matrix3d::Identity()).norm() > 1e-3 || R.determinant() < 0)
    r.Fail(key, "upper-left 3x3 is not a rotation");
}

}  // namespace

// The photograph must be able to show a shadow: finite, not black, not one
// value everywhere (a saturated or blank frame).
void CheckObservation(const Image& image, const fs::path& path) {
  float lo = std::numeric_limits<float>::infinity(), hi = -lo;
  for (float v : image.data) {
    if (!std::isfinite(v)) throw InputError(path.string(), "image has non-finite pixels");
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  if (hi <= 0) throw InputError(path.string(), "image is black (no pixel above 0): nothing to recover lighting from");
  if (hi - lo <= 1e-6f * hi)
    throw InputError(path.string(), "every pixel holds the same value " + std::to_string(hi) +
                                        " (a saturated or blank image): it shows no shadow");
}

Camera ParseCamera(const JsonReader& r) {
  Camera c;
  const std::string proj = r.String("proj_type", "perspective");
  if (proj == "perspective") c.projection = Projection::kPerspective;
  else if (proj == "orthographic") c.projection = Projection::kOrthographic;
  else r.Fail("proj_type", "expected \"perspective\" or \"orthographic\", got \"" + proj + "\"");
  c.width = r.Int("width");
  c.height = r.Int("height");
  if (c.width <= 0 || c.width > kMaxImageSide) r.Fail("width", "image size must be between 1 and 65536");
  if (c.height <= 0 || c.height > kMaxImageSide) r.Fail("height", "image size must be between 1 and 65536");
  c.c2w = r.Mat4("c2w");
  CheckRigid(r, "c2w", c.c2w, false);
  if (c.projection == Projection::kPerspective) {
    c.fx = r.Number("fx");
    c.fy = r.Number("fy");
    c.cx = r.Number("cx");
    c.cy = r.Number("cy");
    if (c.fx <= 0 || c.fy <= 0) r.Fail("fx", "focal lengths must be positive");
    c.k1 = r.Number("k1", 0);
    c.k2 = r.Number("k2", 0);
    c.p1 = r.Number("p1", 0);
    c.p2 = r.Number("p2", 0);
    c.k3 = r.Number("k3", 0);
  } else {
    c.znear = r.Number("znear");
    c.zfar = r.Number("zfar");
    c.min_x = r.Number("min_x");
    c.max_x = r.Number("max_x");
    c.min_y = r.Number("min_y");
    c.max_y = r.Number("max_y");
    c.scale = r.Number("scale", 1.0);
    if (c.max_x <= c.min_x || c.max_y <= c.min_y || c.zfar == c.znear || c.scale <= 0)
      r.Fail("", "orthographic extents must be non-empty and scale positive");
  }
  return c;
}

Plane ParsePlane(const JsonReader& r) {
  Plane p;
  p.xyz = r.Vec3("xyz");
  p.normal = r.Vec3("normal");
  const double n = p.normal.norm();
  if (n < 1e-9) r.Fail("normal", "normal is zero");
  if (std::abs(n - 1) > 1e-3) r.Fail("normal", "normal is not unit length (|n| = " + std::to_string(n) + ")");
  p.normal /= n;
  if (r.Has("scale")) p.scale = r.Vec3("scale");
  if (p.scale.x() <= 0 || p.scale.y() <= 0) r.Fail("scale", "half extents must be positive");
  if (r.Has("diffuse")) p.diffuse = r.Vec3("diffuse");
  if ((p.diffuse.array() < 0).any()) r.Fail("diffuse", "albedo must be non-negative");
  p.texture_path = r.String("texture", "");
  return p;
}

Image ReadPlaneTexture(const fs::path& path) {
  std::string ext = path.extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  Image tex = ReadImage(path);
  if (ext != ".exr")  // 8/16-bit files hold sRGB-encoded albedo
    for (float& v : tex.data) v = SrgbDecode(v);
  if (tex.channels < 3) {
    Image rgb(tex.width, tex.height, 3);
    for (size_t i = 0; i < rgb.pixels(); ++i) rgb.set_rgb(i, tex.rgb(i));
    tex = std::move(rgb);
  }
  for (float v : tex.data)
    if (!std::isfinite(v) || v < 0) throw InputError(path.string(), "albedo texture has negative or non-finite texels");
  return tex;
}

SceneObject ParseSceneObject(const JsonReader& o, const fs::path& dir) {
  std::error_code ec;
  SceneObject obj;
  obj.mesh_path = o.String("path_to_mesh");
  obj.sph_path = o.String("path_to_sph", "");
  obj.o2w = o.Mat4("o2w");
  CheckRigid(o, "o2w", obj.o2w, true);
  if (o.Has("diffuse")) obj.diffuse = o.Vec3("diffuse");
  if ((obj.diffuse.array() < 0).any()) o.Fail("diffuse", "albedo must be non-negative");
  obj.is_train = o.Bool("is_train", true);
  obj.mesh = ReadMesh(dir / obj.mesh_path);
  if (!obj.sph_path.empty() && fs::is_regular_file(dir / obj.sph_path, ec)) obj.sphere_tree = ReadSph(dir / obj.sph_path);
  return obj;
}

std::vector<SceneObject> ReadObjectsFile(const fs::path& path) {
  const Json doc = ReadJsonFile(path);
  const JsonReader root(doc, path.string());
  if (!doc.is_object()) root.Fail("", "expected a JSON object");
  const std::string format = root.String("format", "objects/1");
  if (format != "objects/1") root.Fail("format", "expected \"objects/1\", got \"" + format + "\"");
  const JsonReader list = root.Child("objects");
  if (list.Size() == 0) root.Fail("objects", "no objects");
  std::vector<SceneObject> objects;
  for (size_t i = 0; i < list.Size(); ++i) {
    const JsonReader o = list.Element(i);
    if (o.Bool("is_train", false)) o.Fail("is_train", "an objects file lists virtual objects (\"is_train\": false)");
    objects.push_back(ParseSceneObject(o, path.parent_path()));
    objects.back().is_train = false;
  }
  return objects;
}

Scene LoadScene(const fs::path& dir, const SceneLoadOptions& options) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw InputError(dir.string(), "scene folder not found");
  const fs::path json_path = dir / "scene.json";
  const Json doc = ReadJsonFile(json_path);
  const JsonReader root(doc, json_path.string());
  if (!doc.is_object()) root.Fail("", "expected a JSON object");

  Scene scene;
  scene.name = fs::absolute(dir).lexically_normal().filename().string();
  if (scene.name.empty()) scene.name = fs::absolute(dir).lexically_normal().parent_path().filename().string();
  scene.camera = ParseCamera(root.Child("camera"));
  scene.plane = ParsePlane(root.Child("plane"));
  if (!scene.plane.texture_path.empty()) scene.plane.albedo_texture = ReadPlaneTexture(dir / scene.plane.texture_path);

  const JsonReader objects = root.Child("objects");
  if (objects.Size() == 0) root.Fail("objects", "no objects: a scene needs a shadow caster");
  for (size_t i = 0; i < objects.Size(); ++i) scene.objects.push_back(ParseSceneObject(objects.Element(i), dir));
  if (scene.Casters().empty()) root.Fail("objects", "no object has \"is_train\": true (no shadow caster)");

  auto check_size = [&](const Image& img, const fs::path& path) {
    if (img.width != scene.camera.width || img.height != scene.camera.height)
      throw InputError(path.string(), "image is " + std::to_string(img.width) + "x" + std::to_string(img.height) +
                                          " but the camera is " + std::to_string(scene.camera.width) + "x" +
                                          std::to_string(scene.camera.height));
  };

  if (options.require_image) {
    fs::path image_path;
    if (root.Has("image")) {
      image_path = dir / root.String("image");
    } else {
      for (const char* name : {"image.exr", "image.png", "image.jpg", "image.jpeg"})
        if (fs::exists(dir / name)) {
          image_path = dir / name;
          break;
        }
      if (image_path.empty()) throw InputError(dir.string(), "no image.exr (or image.png/.jpg) in the scene folder");
    }
    scene.image = ReadImage(image_path);
    check_size(scene.image, image_path);
    if (scene.image.channels < 3) {
      Image rgb(scene.image.width, scene.image.height, 3);
      for (size_t p = 0; p < rgb.pixels(); ++p) rgb.set_rgb(p, scene.image.rgb(p));
      scene.image = std::move(rgb);
    }
    if (options.require_observation) {
      CheckObservation(scene.image, image_path);
    } else {
      for (float v : scene.image.data)
        if (!std::isfinite(v)) throw InputError(image_path.string(), "image has non-finite pixels");
    }
  }

  if (options.load_extras) {
    const fs::path mask_path = root.Has("mask") ? dir / root.String("mask") : dir / "mask.png";
    const fs::path ref_mask = dir / "mask_plane.png";  // the reference code's name
    if (fs::exists(mask_path)) {
      scene.mask = ReadMask(mask_path);
      check_size(*scene.mask, mask_path);
    } else if (fs::exists(ref_mask)) {
      scene.mask = ReadMask(ref_mask);
      check_size(*scene.mask, ref_mask);
    } else if (root.Has("mask")) {
      throw InputError(mask_path.string(), "file not found");
    }
    const fs::path env_path = dir / root.String("env_gt", "env_gt.exr");
    if (fs::exists(env_path)) {
      scene.env_gt = ReadEnvMapExr(env_path);
    }
    const fs::path virt = dir / root.String("image_virtual_objs", "image_virtual_objs.exr");
    if (fs::exists(virt)) {
      scene.image_virtual_objs = ReadExr(virt);
      check_size(*scene.image_virtual_objs, virt);
    }
  }
  return scene;
}

Json CameraToJson(const Camera& c) {
  Json j;
  j["proj_type"] = c.projection == Projection::kPerspective ? "perspective" : "orthographic";
  j["width"] = c.width;
  j["height"] = c.height;
  if (c.projection == Projection::kPerspective) {
    j["fx"] = c.fx;
    j["fy"] = c.fy;
    j["cx"] = c.cx;
    j["cy"] = c.cy;
    j["k1"] = c.k1;
    j["k2"] = c.k2;
    j["p1"] = c.p1;
    j["p2"] = c.p2;
    j["k3"] = c.k3;
  } else {
    j["znear"] = c.znear;
    j["zfar"] = c.zfar;
    j["min_x"] = c.min_x;
    j["max_x"] = c.max_x;
    j["min_y"] = c.min_y;
    j["max_y"] = c.max_y;
    j["scale"] = c.scale;
  }
  j["c2w"] = ToJson(c.c2w);
  return j;
}

Json PlaneToJson(const Plane& p) {
  Json j{{"xyz", ToJson(p.xyz)}, {"normal", ToJson(p.normal)}, {"scale", ToJson(p.scale)},
         {"diffuse", ToJson(p.diffuse)}};
  if (!p.texture_path.empty()) j["texture"] = p.texture_path;
  return j;
}

Json SceneToJson(const Scene& scene) {
  Json j;
  j["camera"] = CameraToJson(scene.camera);
  j["plane"] = PlaneToJson(scene.plane);
  j["objects"] = Json::array();
  for (const auto& o : scene.objects) {
    Json jo{{"path_to_mesh", o.mesh_path}, {"o2w", ToJson(o.o2w)}, {"diffuse", ToJson(o.diffuse)},
            {"is_train", o.is_train}};
    if (!o.sph_path.empty()) jo["path_to_sph"] = o.sph_path;
    j["objects"].push_back(jo);
  }
  j["image"] = "image.exr";
  if (scene.env_gt) j["env_gt"] = "env_gt.exr";
  return j;
}

}  // namespace shadowsg
