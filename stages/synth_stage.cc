#include "stages/synth_stage.h"

#include <cmath>
#include <set>

#include "calib/error.h"
#include "solver/light_envmap.h"
#include "solver/primitives.h"
#include "stages/io/image_io.h"
#include "stages/io/lighting_io.h"
#include "stages/io/mesh_io.h"
#include "stages/io/scene_io.h"
#include "stages/stage_util.h"

namespace shadowsg {
namespace fs = std::filesystem;

namespace {

constexpr double kDegree = M_PI / 180;
constexpr const char* kFormat = "synth/1";
// Largest side of a synthetic image, and of a procedural texture.
constexpr int kMaxSide = 16384;

TriangleMesh ParsePrimitive(const JsonReader& p) {
  const std::string kind = p.String("primitive");
  if (kind == "icosphere") return MakeIcosphere(p.Number("radius"), p.Int("subdivisions", 3));
  if (kind == "box") return MakeBox(p.Vec3("half_extents"));
  if (kind == "cylinder") return MakeCylinder(p.Number("radius"), p.Number("height"), p.Int("segments", 48));
  if (kind == "cone") return MakeCone(p.Number("radius"), p.Number("height"), p.Int("segments", 48));
  if (kind == "torus")
    return MakeTorus(p.Number("major_radius"), p.Number("minor_radius"), p.Int("major_segments", 48),
                     p.Int("minor_segments", 24));
  p.Fail("primitive", "unknown primitive \"" + kind + "\" (icosphere, box, cylinder, cone, torus)");
}

Eigen::Matrix3d EulerXyz(const Eigen::Vector3d& deg) {
  // Blender's XYZ Euler: rotate about x first, then y, then z.
  return (Eigen::AngleAxisd(deg.z() * kDegree, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(deg.y() * kDegree, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(deg.x() * kDegree, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

SynthObject ParseObject(const JsonReader& o, const fs::path& base_dir, const Plane& plane) {
  SynthObject obj;
  if (!o.Has("mesh")) o.Fail("mesh", "missing key (a file name or {\"primitive\": ...})");
  if (o.node()["mesh"].is_string()) {
    const fs::path file = base_dir / o.String("mesh");
    obj.mesh = ReadMesh(file);
    obj.name = fs::path(o.String("mesh")).stem().string();
  } else {
    obj.mesh = ParsePrimitive(o.Child("mesh"));
    obj.name = o.Child("mesh").String("primitive");
  }
  if (obj.mesh.faces.empty()) o.Fail("mesh", "mesh has no faces");
  obj.name = o.String("name", obj.name);
  if (o.Has("diffuse")) obj.diffuse = o.Vec3("diffuse");
  if ((obj.diffuse.array() < 0).any() || (obj.diffuse.array() > 1).any())
    o.Fail("diffuse", "albedo must lie in [0, 1]");
  obj.is_train = o.Bool("is_train", true);

  if (o.Has("o2w")) {
    obj.o2w = o.Mat4("o2w");
    if ((obj.o2w.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).norm() > 1e-9) o.Fail("o2w", "last row must be [0, 0, 0, 1]");
  } else {
    const double scale = o.Number("scale", 1.0);
    if (scale <= 0) o.Fail("scale", "scale must be positive");
    const Eigen::Vector3d rot = o.Has("rotate_deg") ? o.Vec3("rotate_deg") : Eigen::Vector3d::Zero();
    const Eigen::Vector3d pos = o.Has("position") ? o.Vec3("position") : Eigen::Vector3d::Zero();
    obj.o2w.block<3, 3>(0, 0) = scale * EulerXyz(rot);
    obj.o2w.block<3, 1>(0, 3) = pos;
  }
  if (obj.o2w.block<3, 3>(0, 0).determinant() <= 0) o.Fail("o2w", "transform must keep orientation (det > 0)");
  if (o.Bool("rest_on_plane", false)) {
    // Move along the plane normal until the lowest vertex touches the plane.
    double lowest = 1e300;
    for (const auto& v : obj.mesh.vertices)
      lowest = std::min(lowest, plane.normal.dot(obj.o2w.block<3, 3>(0, 0) * v + obj.o2w.block<3, 1>(0, 3) - plane.xyz));
    obj.o2w.block<3, 1>(0, 3) -= lowest * plane.normal;
  }
  return obj;
}

Camera ParseSynthCamera(const JsonReader& c) {
  Camera cam;
  cam.width = c.Int("width");
  cam.height = c.Int("height");
  if (cam.width < 1 || cam.height < 1 || cam.width > kMaxSide || cam.height > kMaxSide)
    c.Fail("width", "image size must be between 1 and 16384");
  if (c.Has("fx")) {
    cam.fx = c.Number("fx");
  } else if (c.Has("fov_deg")) {
    const double fov = c.Number("fov_deg");
    if (fov <= 0 || fov >= 179) c.Fail("fov_deg", "horizontal field of view must be in (0, 179) degrees");
    cam.fx = cam.width / (2 * std::tan(fov * kDegree / 2));
  } else {
    c.Fail("fx", "missing key (give \"fx\" in pixels or \"fov_deg\", the horizontal field of view)");
  }
  cam.fy = c.Number("fy", cam.fx);
  if (cam.fx <= 0 || cam.fy <= 0) c.Fail("fx", "focal lengths must be positive");
  // Pixel centres at integers: the image centre is ((w - 1) / 2, (h - 1) / 2).
  cam.cx = c.Number("cx", (cam.width - 1) / 2.0);
  cam.cy = c.Number("cy", (cam.height - 1) / 2.0);
  cam.k1 = c.Number("k1", 0);
  cam.k2 = c.Number("k2", 0);
  cam.p1 = c.Number("p1", 0);
  cam.p2 = c.Number("p2", 0);
  cam.k3 = c.Number("k3", 0);
  if (c.Has("c2w")) {
    cam.c2w = c.Mat4("c2w");
    const Eigen::Matrix3d r = cam.Rotation();
    if ((r.transpose() * r - Eigen::Matrix3d::Identity()).norm() > 1e-3 || r.determinant() < 0)
      c.Fail("c2w", "upper-left 3x3 is not a rotation");
  } else {
    const Eigen::Vector3d from = c.Vec3("look_from"), at = c.Vec3("look_at");
    const Eigen::Vector3d up = c.Has("up") ? c.Vec3("up") : Eigen::Vector3d::UnitZ();
    if ((at - from).norm() < 1e-12) c.Fail("look_at", "look_at equals look_from");
    if ((at - from).normalized().cross(up.normalized()).norm() < 1e-6)
      c.Fail("up", "up is parallel to the viewing direction");
    cam.c2w = LookAt(from, at, up);
  }
  return cam;
}

// A checkerboard albedo: {"checker": squares, "a": rgb, "b": rgb, "size": pixels}.
Image CheckerTexture(const JsonReader& t) {
  const int squares = t.Int("checker");
  const int size = t.Int("size", 512);
  if (squares < 1 || size < squares || size > kMaxSide) t.Fail("checker", "need 1 <= checker <= size <= 16384");
  const Eigen::Vector3d a = t.Has("a") ? t.Vec3("a") : Eigen::Vector3d::Constant(0.9);
  const Eigen::Vector3d b = t.Has("b") ? t.Vec3("b") : Eigen::Vector3d::Constant(0.3);
  if ((a.array() < 0).any() || (a.array() > 1).any() || (b.array() < 0).any() || (b.array() > 1).any())
    t.Fail("a", "checker albedos must lie in [0, 1]");
  Image tex(size, size, 3);
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x)
      tex.set_rgb(tex.index(x, y), (((x * squares / size) + (y * squares / size)) % 2 ? b : a).cast<float>());
  return tex;
}

LightSet ParseSynthLights(const JsonReader& spec, const fs::path& base_dir) {
  if (!spec.Has("lights")) spec.Fail("lights", "missing key (inline \"lights/1\" content or a lighting file)");
  LightSet lights;
  if (spec.node()["lights"].is_string()) {
    lights = ReadLighting(base_dir / spec.String("lights"));
  } else {
    const JsonReader l = spec.Child("lights");
    const std::string format = l.String("format", "lights/1");
    if (format == "sg-lighting/1") lights.sg = ParseSgLighting(l);
    else if (format == "lights/1") lights = ParseLights(l, base_dir);
    else l.Fail("format", "expected \"lights/1\" or \"sg-lighting/1\", got \"" + format + "\"");
  }
  if (lights.empty()) spec.Fail("lights", "no light");
  return lights;
}



}  // namespace

Eigen::Matrix4d LookAt(const Eigen::Vector3d& from, const Eigen::Vector3d& at, const Eigen::Vector3d& up) {
  // OpenCV axes: z forward, x right, y down.
  const Eigen::Vector3d z = (at - from).normalized();
  const Eigen::Vector3d x = z.cross(up).normalized();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix4d c2w = Eigen::Matrix4d::Identity();
  c2w.block<3, 1>(0, 0) = x;
  c2w.block<3, 1>(0, 1) = y;
  c2w.block<3, 1>(0, 2) = z;
  c2w.block<3, 1>(0, 3) = from;
  return c2w;
}

SynthSpec ParseSynthSpec(const JsonReader& spec, const fs::path& base_dir) {
  if (!spec.node().is_object()) spec.Fail("", "expected a JSON object");
  const std::string format = spec.String("format", kFormat);
  if (format != kFormat) spec.Fail("format", "expected \"synth/1\", got \"" + format + "\"");
  SynthSpec out;
  out.camera = ParseSynthCamera(spec.Child("camera"));

  // The plane: scene.json's keys, with "texture" a file or a procedural checker.
  Json plane_json = spec.Child("plane").node();
  Json texture_json;
  if (plane_json.contains("texture")) {
    texture_json = plane_json["texture"];
    plane_json.erase("texture");
  }
  out.plane = ParsePlane(JsonReader(plane_json, spec.file(), "plane"));
  if (!texture_json.is_null()) {
    const JsonReader t(texture_json, spec.file(), "plane.texture");
    if (texture_json.is_string()) {
      const fs::path file = base_dir / texture_json.get<std::string>();
      out.plane.albedo_texture = ReadPlaneTexture(file);
      out.texture_file = "plane_albedo" + file.extension().string();
    } else if (texture_json.is_object()) {
      out.plane.albedo_texture = CheckerTexture(t);
      out.texture_file = "plane_albedo.png";
    } else {
      spec.Fail("plane.texture", "expected a file name or {\"checker\": squares, ...}");
    }
    out.plane.texture_path = out.texture_file;
  }

  const JsonReader objects = spec.Child("objects");
  std::set<std::string> names;
  for (size_t i = 0; i < objects.Size(); ++i) {
    SynthObject obj = ParseObject(objects.Element(i), base_dir, out.plane);
    // The first caster is geometry/mesh.obj, as in the reference scenes.
    if (obj.is_train && names.count("mesh") == 0 && !objects.Element(i).Has("name")) obj.name = "mesh";
    std::string name = obj.name;
    for (int k = 2; names.count(name); ++k) name = obj.name + "_" + std::to_string(k);
    obj.name = name;
    names.insert(name);
    out.objects.push_back(std::move(obj));
  }
  bool any_caster = false;
  for (const auto& o : out.objects) any_caster |= o.is_train;
  if (!any_caster) spec.Fail("objects", "no object with \"is_train\": true (a scene needs a shadow caster)");

  out.lights = ParseSynthLights(spec, base_dir);
  if (spec.Has("render")) {
    const JsonReader r = spec.Child("render");
    out.trace.samples_per_pixel = r.Int("spp", out.trace.samples_per_pixel);
    out.trace.max_bounces = r.Int("bounces", out.trace.max_bounces);
    const double seed = r.Number("seed", 0);
    if (seed < 0 || seed != std::floor(seed)) r.Fail("seed", "seed must be a non-negative integer");
    out.trace.seed = static_cast<uint64_t>(seed);
    std::string error;
    if (!out.trace.IsValid(&error)) r.Fail("", error);
  }
  out.env_gt_height = spec.Int("env_gt_height", out.env_gt_height);
  if (out.env_gt_height < 4 || out.env_gt_height > 4096) spec.Fail("env_gt_height", "expected 4 to 4096");
  return out;
}

SynthSpec ReadSynthSpec(const fs::path& path) {
  const Json doc = ReadJsonFile(path);
  return ParseSynthSpec(JsonReader(doc, path.string()), path.parent_path());
}

void ApplyOverrides(const SynthOverrides& o, SynthSpec* spec) {
  if (o.samples_per_pixel) spec->trace.samples_per_pixel = *o.samples_per_pixel;
  if (o.max_bounces) spec->trace.max_bounces = *o.max_bounces;
  if (o.seed) spec->trace.seed = *o.seed;
  if (o.resolution_scale != 1.0) {
    Camera& c = spec->camera;
    const double s = o.resolution_scale;
    const int w = std::max(1, static_cast<int>(std::lround(c.width * s)));
    const int h = std::max(1, static_cast<int>(std::lround(c.height * s)));
    const double sx = static_cast<double>(w) / c.width, sy = static_cast<double>(h) / c.height;
    // Pixel centres at integers: the image edge sits at -0.5.
    c.fx *= sx;
    c.fy *= sy;
    c.cx = (c.cx + 0.5) * sx - 0.5;
    c.cy = (c.cy + 0.5) * sy - 0.5;
    c.width = w;
    c.height = h;
  }
}

SynthResult RunSynthStage(const SynthSpec& spec, const fs::path& out_dir, const StageContext& ctx) {
  std::string error;
  if (!spec.trace.IsValid(&error)) throw InputError("synth options", error);
  EnsureOutputDir(out_dir);
  EnsureOutputDir(out_dir / "geometry");

  Scene scene;
  scene.name = out_dir.filename().string();
  scene.camera = spec.camera;
  scene.plane = spec.plane;
  for (const auto& o : spec.objects) {
    SceneObject so;
    so.mesh_path = "geometry/" + o.name + ".obj";
    so.sph_path = "geometry/" + o.name + "_sphere.sph";
    so.mesh = o.mesh;
    so.o2w = o.o2w;
    so.diffuse = o.diffuse;
    so.is_train = o.is_train;
    WriteObj(out_dir / so.mesh_path, so.mesh);
    scene.objects.push_back(std::move(so));
  }
  if (scene.plane.albedo_texture) {
    const fs::path tex = out_dir / spec.texture_file;
    if (tex.extension() == ".exr") {
      WriteExr(tex, *scene.plane.albedo_texture);
    } else {
      // 8-bit sRGB on disk; render with what a reader will get back.
      Image encoded = *scene.plane.albedo_texture;
      for (float& v : encoded.data) v = SrgbEncode(v);
      WriteLdr(tex, encoded);
    }
    scene.plane.albedo_texture = ReadPlaneTexture(tex);
  }

  SynthResult result;
  result.scene_dir = out_dir;
  result.has_virtual_objects = !scene.VirtualObjects().empty();
  const Stopwatch clock;
  PathTraceOptions trace = spec.trace;
  trace.objects = RenderObjects::kCasters;
  WriteExrWithPreview(out_dir / "image.exr", RenderPathTraced(scene, spec.lights, trace, ctx.Progress("render image")));
  const fs::path virt = out_dir / "image_virtual_objs.exr";
  if (result.has_virtual_objects) {
    trace.objects = RenderObjects::kAll;  // same seed: noise correlated with image.exr
    WriteExrWithPreview(virt, RenderPathTraced(scene, spec.lights, trace, ctx.Progress("render with virtual objects")));
  } else {
    std::error_code ec;  // a stale one from an earlier spec would be read as ground truth
    fs::remove(virt, ec);
    fs::remove(fs::path(virt).replace_extension(".png"), ec);
  }
  result.render_seconds = clock.Seconds();

  LightEnvMapOptions env_options;
  env_options.height = spec.env_gt_height;
  const Image env_gt = LightSetToEnvMap(spec.lights, env_options);
  WriteExrWithPreview(out_dir / "env_gt.exr", env_gt);
  if (spec.lights.env) WriteExr(out_dir / "lights_env.exr", *spec.lights.env);
  WriteJsonFile(out_dir / "lights.json", LightsToJson(spec.lights, spec.lights.env ? "lights_env.exr" : ""));

  // scene.json last: a folder that has one is complete.
  Json doc = SceneToJson(scene);
  doc["env_gt"] = "env_gt.exr";
  if (result.has_virtual_objects) doc["image_virtual_objs"] = "image_virtual_objs.exr";
  WriteJsonFile(out_dir / "scene.json", doc);
  return result;
}

}  // namespace shadowsg
