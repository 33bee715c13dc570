#include "multiview_capture.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include "calib/apriltag_detect.h"
#include "solver/path_tracer.h"
#include "solver/primitives.h"
#include "stages/io/image_io.h"
#include "stages/io/json_util.h"
#include "stages/io/mesh_io.h"
#include "stages/synth_stage.h"

namespace shadowsg::testing {
namespace fs = std::filesystem;

namespace {

// Smooth value noise in [0, 1] on a square grid of `cells` per side over [0, 1]^2.
class ValueNoise {
 public:
  ValueNoise(int cells, uint64_t seed) : n_(cells), v_(static_cast<size_t>(cells + 1) * (cells + 1)) {
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> uni(0, 1);
    for (double& x : v_) x = uni(rng);
  }
  double operator()(double s, double t) const {
    const double x = std::clamp(s, 0.0, 1.0) * n_, y = std::clamp(t, 0.0, 1.0) * n_;
    const int i = std::min(static_cast<int>(x), n_ - 1), j = std::min(static_cast<int>(y), n_ - 1);
    auto smooth = [](double f) { return f * f * (3 - 2 * f); };
    const double fx = smooth(x - i), fy = smooth(y - j);
    auto at = [&](int a, int b) { return v_[static_cast<size_t>(b) * (n_ + 1) + a]; };
    return (1 - fy) * ((1 - fx) * at(i, j) + fx * at(i + 1, j)) + fy * ((1 - fx) * at(i, j + 1) + fx * at(i + 1, j + 1));
  }

 private:
  int n_;
  std::vector<double> v_;
};

// Texel (col, row) of a texture of side `size` over the plane rectangle
// +-half: column 0 at x = -half, row 0 at y = +half (solver/scene.h).
Eigen::Vector2d TexelToPlane(int col, int row, int size, double half) {
  return {-half + (col + 0.5) * 2 * half / size, half - (row + 0.5) * 2 * half / size};
}

}  // namespace

MultiviewCapture MakeMultiviewCapture(const MultiviewSpec& spec, int ring_views) {
  MultiviewCapture cap;
  cap.spec = spec;
  Camera lens;
  lens.width = spec.width;
  lens.height = spec.height;
  lens.fx = spec.fx;
  lens.fy = spec.fy;
  lens.cx = (spec.width - 1) / 2.0 + 3.0;
  lens.cy = (spec.height - 1) / 2.0 - 2.0;
  lens.k1 = spec.k1;
  cap.lens = lens;

  // The plane's albedo: noise (three octaves, slightly coloured) or uniform,
  // and the tag on a sheet of paper.
  const int S = spec.texture_size;
  Image tex(S, S, 3);
  const ValueNoise coarse(24, spec.seed), mid(64, spec.seed + 1), fine(160, spec.seed + 2), tint(12, spec.seed + 3);
  const TagPattern pattern = MakeTagPattern("tag36h11", spec.tag_id);
  const double cell = spec.tag_size / pattern.border_width;
  const double pattern_half = 0.5 * cell * pattern.total_width;
  const double paper_half = 1.3 * pattern_half;
  for (int row = 0; row < S; ++row)
    for (int col = 0; col < S; ++col) {
      const Eigen::Vector2d p = TexelToPlane(col, row, S, spec.plane_half);
      const double s = (p.x() / spec.plane_half + 1) / 2, t = (p.y() / spec.plane_half + 1) / 2;
      Eigen::Vector3d a = spec.plane_albedo;
      if (spec.noise > 0) {
        const double v = 0.45 * coarse(s, t) + 0.35 * mid(s, t) + 0.2 * fine(s, t);
        const double grey = std::clamp(0.1 + 0.8 * ((v - 0.5) * 1.8 + 0.5), 0.08, 0.85);
        const double w = tint(s, t) - 0.5;
        a = Eigen::Vector3d(grey * (1 + 0.3 * w), grey, grey * (1 - 0.3 * w)) * spec.noise +
            spec.plane_albedo * (1 - spec.noise);
      }
      const Eigen::Vector2d d = p - spec.tag_centre;
      if (std::abs(d.x()) <= paper_half && std::abs(d.y()) <= paper_half) {
        a = Eigen::Vector3d::Constant(spec.paper_albedo);
        const int pc = static_cast<int>(std::floor((d.x() + pattern_half) / cell));
        const int pr = static_cast<int>(std::floor((pattern_half - d.y()) / cell));
        if (pc >= 0 && pr >= 0 && pc < pattern.total_width && pr < pattern.total_width && !pattern.at(pc, pr))
          a = Eigen::Vector3d::Constant(0.04);
      }
      tex.set_rgb(tex.index(col, row), a.cast<float>());
    }

  Scene& scene = cap.scene;
  scene.plane.xyz = Eigen::Vector3d::Zero();
  scene.plane.normal = Eigen::Vector3d::UnitZ();
  scene.plane.scale = Eigen::Vector3d(spec.plane_half, spec.plane_half, 1);
  scene.plane.diffuse = Eigen::Vector3d::Ones();
  scene.plane.albedo_texture = std::move(tex);
  SceneObject box;
  box.mesh = MakeBox(spec.box_half);
  box.mesh_path = "geometry/mesh.obj";
  box.o2w = Eigen::Matrix4d::Identity();
  box.o2w.block<3, 3>(0, 0) = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  box.o2w(2, 3) = spec.box_half.z();
  box.diffuse = Eigen::Vector3d(0.6, 0.5, 0.4);
  scene.objects.push_back(std::move(box));

  SunLight sun;
  sun.direction = Eigen::Vector3d(0.4, 0.25, 0.88).normalized();
  sun.irradiance = Eigen::Vector3d(2.5, 2.4, 2.2);
  cap.lights.suns.push_back(sun);
  SgLighting sky;
  sky.lobes.push_back({Eigen::Vector3d::UnitZ(), 1.0, Eigen::Vector3d(0.3, 0.35, 0.45)});
  cap.lights.sg = sky;

  // A ring of views around the object at two heights, and the hero.
  const Eigen::Vector3d at(0, 0, 0.05);
  for (int i = 0; i < ring_views; ++i) {
    const double az = 2 * M_PI * i / ring_views;
    const double radius = i % 2 ? 1.25 : 1.45, height = i % 2 ? 1.05 : 0.8;
    const Eigen::Vector3d from(radius * std::cos(az), radius * std::sin(az), height);
    cap.ring.push_back(LookAt(from, at + Eigen::Vector3d(0.1 * std::sin(3 * az), 0.1 * std::cos(2 * az), 0),
                              Eigen::Vector3d::UnitZ()));
  }
  cap.hero_c2w = LookAt(Eigen::Vector3d(0.35, -1.3, 1.0), Eigen::Vector3d(0.1, -0.05, 0.05), Eigen::Vector3d::UnitZ());
  scene.camera = lens;
  scene.camera.c2w = cap.hero_c2w;
  cap.exposure = 1.0;
  return cap;
}

Image RenderView(const MultiviewCapture& cap, const Eigen::Matrix4d& c2w, uint64_t seed) {
  Scene scene;
  scene.camera = cap.lens;
  scene.camera.c2w = c2w;
  scene.plane = cap.scene.plane;
  scene.objects = cap.scene.objects;
  PathTraceOptions o;
  o.samples_per_pixel = cap.spec.spp;
  o.max_bounces = 1;
  o.seed = seed;
  return RenderPathTraced(scene, cap.lights, o);
}

Image ToPhoto(const Image& linear, double exposure) {
  Image out = linear;
  for (float& v : out.data) v = SrgbEncode(std::clamp(static_cast<float>(v * exposure), 0.0f, 1.0f));
  return out;
}

void RenderCheckerboardSet(const Camera& lens, int cols, int rows, double square, int views, const fs::path& dir,
                           int spp, uint64_t seed) {
  // The board: (cols + 1) x (rows + 1) squares and one square of white margin,
  // centred at the origin of the plane z = 0.
  const int sq_x = cols + 1, sq_y = rows + 1;
  const double half_x = (sq_x + 2) * square / 2, half_y = (sq_y + 2) * square / 2;
  const double half = std::max(half_x, half_y);
  const int px_per_square = 24;
  const int size = static_cast<int>(std::ceil(2 * half / square * px_per_square));
  Image tex(size, size, 3);
  for (int row = 0; row < size; ++row)
    for (int col = 0; col < size; ++col) {
      const Eigen::Vector2d p = TexelToPlane(col, row, size, half);
      const double u = (p.x() + sq_x * square / 2) / square, v = (p.y() + sq_y * square / 2) / square;
      float a = 0.8f;
      if (u >= 0 && v >= 0 && u < sq_x && v < sq_y && ((static_cast<int>(u) + static_cast<int>(v)) % 2 == 0))
        a = 0.05f;
      if (std::abs(p.x()) > half_x || std::abs(p.y()) > half_y) a = 0.3f;
      tex.set_rgb(tex.index(col, row), Eigen::Vector3f::Constant(a));
    }
  Scene scene;
  scene.camera = lens;
  scene.plane.scale = Eigen::Vector3d(half, half, 1);
  scene.plane.diffuse = Eigen::Vector3d::Ones();
  scene.plane.albedo_texture = std::move(tex);
  LightSet lights;
  SgLighting sky;
  sky.lobes.push_back({Eigen::Vector3d::UnitZ(), 0.5, Eigen::Vector3d::Constant(0.8)});
  lights.sg = sky;
  PathTraceOptions o;
  o.samples_per_pixel = spp;
  o.max_bounces = 0;
  o.objects = RenderObjects::kNone;

  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uni(0, 1);
  fs::create_directories(dir);
  int written = 0;
  // Boards spread over the frame (their centre anywhere in the middle 60 %),
  // tilted 15-45 degrees about a random axis and turned about their normal:
  // the variety that pins down the focal length and the distortion.
  for (int attempt = 0; written < views && attempt < 5000; ++attempt) {
    const double u = lens.width * (0.2 + 0.6 * uni(rng)), v = lens.height * (0.2 + 0.6 * uni(rng));
    const double dist = 0.45 + 0.3 * uni(rng);
    const double tilt = (15 + 30 * uni(rng)) * M_PI / 180, axis_angle = 2 * M_PI * uni(rng);
    const double roll = (uni(rng) - 0.5) * 1.0;
    const Eigen::Vector3d centre =
        dist * Eigen::Vector3d((u - lens.cx) / lens.fx, (v - lens.cy) / lens.fy, 1).normalized();
    // Board to camera: facing the camera (board z -> camera -z), then tilted and turned.
    const Eigen::Matrix3d facing = Eigen::Vector3d(1, -1, -1).asDiagonal();
    const Eigen::Matrix3d R =
        Eigen::AngleAxisd(tilt, Eigen::Vector3d(std::cos(axis_angle), std::sin(axis_angle), 0)).toRotationMatrix() *
        facing * Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    Eigen::Matrix4d c2w = Eigen::Matrix4d::Identity();
    c2w.topLeftCorner<3, 3>() = R.transpose();
    c2w.topRightCorner<3, 1>() = -R.transpose() * centre;
    scene.camera.c2w = c2w;
    bool inside = true;
    for (double sx : {-1.0, 1.0})
      for (double sy : {-1.0, 1.0}) {
        const auto px = ProjectToPixel(scene.camera, Eigen::Vector3d(sx * half_x, sy * half_y, 0));
        inside &= px && px->x() > 4 && px->y() > 4 && px->x() < lens.width - 5 && px->y() < lens.height - 5;
      }
    if (!inside) continue;
    o.seed = seed + written;
    const Image img = RenderPathTraced(scene, lights, o);
    char name[32];
    std::snprintf(name, sizeof name, "board_%02d.png", written);
    WriteLdr(dir / name, ToPhoto(img, 1.0));
    ++written;
  }
}

nlohmann::json WriteCaptureFolder(const MultiviewCapture& cap, const fs::path& dir, const CaptureFolderOptions& o) {
  const MultiviewSpec& spec = cap.spec;
  RenderCheckerboardSet(cap.lens, o.board_cols, o.board_rows, o.board_square, o.board_views, dir / "boards", 4, 100);
  fs::create_directories(dir / "images");
  for (size_t i = 0; i < cap.ring.size(); ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "view_%02zu.png", i);
    WriteLdr(dir / "images" / name, ToPhoto(RenderView(cap, cap.ring[i], 10 + i), cap.exposure));
  }
  const Image hero_linear = RenderView(cap, cap.hero_c2w, 1);
  WriteExr(dir / "hero.exr", hero_linear);
  WriteLdr(dir / "images" / "hero.png", ToPhoto(hero_linear, cap.exposure));
  const SceneObject& box = cap.scene.objects[0];
  TriangleMesh mesh = box.mesh;
  for (auto& v : mesh.vertices) v = box.o2w.topLeftCorner<3, 3>() * v;
  WriteObj(dir / "box.obj", mesh);

  const std::string board = std::to_string(o.board_cols) + "x" + std::to_string(o.board_rows);
  const nlohmann::json doc = {
      {"format", "capture/1"},
      {"intrinsics",
       {{"images", "boards"},
        {"board", board},
        {"square", o.board_square},
        {"fix_k3", true},
        {"zero_tangential", true}}},
      {"walkaround", {{"images", "images"}, {"max_features", o.max_features}}},
      {"hero", {{"photo", "images/hero.png"}, {"linear", "hero.exr"}}},
      {"object", {{"mesh", "box.obj"}}},
      {"tags",
       {{"size", spec.tag_size},
        {"id", spec.tag_id},
        {"offset", {-spec.tag_centre.x(), -spec.tag_centre.y(), spec.box_half.z()}}}}};
  WriteJsonFile(dir / "capture.json", doc);
  return doc;
}

double RotationAngleDeg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  const Eigen::AngleAxisd aa(Eigen::Matrix3d(a.transpose() * b));
  return std::abs(aa.angle()) * 180.0 / M_PI;
}

Eigen::Matrix4d AlignAboutZ(const std::vector<Eigen::Vector3d>& from, const std::vector<Eigen::Vector3d>& to) {
  Eigen::Vector2d cf = Eigen::Vector2d::Zero(), ct = Eigen::Vector2d::Zero();
  for (size_t i = 0; i < from.size(); ++i) cf += from[i].head<2>(), ct += to[i].head<2>();
  cf /= static_cast<double>(from.size());
  ct /= static_cast<double>(to.size());
  double sin_sum = 0, cos_sum = 0;
  for (size_t i = 0; i < from.size(); ++i) {
    const Eigen::Vector2d a = from[i].head<2>() - cf, b = to[i].head<2>() - ct;
    cos_sum += a.dot(b);
    sin_sum += a.x() * b.y() - a.y() * b.x();
  }
  const double theta = std::atan2(sin_sum, cos_sum);
  Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
  T.topLeftCorner<3, 3>() = Eigen::AngleAxisd(theta, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.block<2, 1>(0, 3) = ct - T.topLeftCorner<2, 2>() * cf;
  return T;
}

}  // namespace shadowsg::testing
