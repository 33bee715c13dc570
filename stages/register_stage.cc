#include "stages/register_stage.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cctype>
#include <cmath>

#include "calib/apriltag_detect.h"
#include "calib/error.h"
#include "calib/image_warp.h"
#include "calib/tag_refine.h"
#include "solver/ray_caster.h"
#include "stages/io/capture_io.h"
#include "stages/io/image_io.h"
#include "stages/io/json_util.h"
#include "stages/io/mesh_io.h"
#include "stages/io/scene_io.h"
#include "stages/stage_util.h"

namespace shadowsg {
namespace fs = std::filesystem;

namespace {

// Camera heights from plane_c and plane.json that differ by more than this
// share mean the two files do not share units (or one of them is off).
constexpr double kMaxUnitDisagreement = 0.05;
// plane_c's normal and plane.json's (both in the hero camera) further apart
// than this are reported.
constexpr double kMaxNormalDisagreementDeg = 5.0;
// An object whose lowest vertex is further from the plane than this share of
// its height is reported (it should rest on the plane).
constexpr double kMaxContactGapFraction = 0.02;
// Without a rectangle in plane.json, the plane spans this many camera heights.
constexpr double kFallbackExtentHeights = 20.0;
// Masked-out pixels in mask_preview.png keep this share of their brightness.
constexpr float kPreviewDim = 0.25f;

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

std::string Fmt(const char* fmt, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, fmt, v);
  return buf;
}

Eigen::Vector2d Apply(const Eigen::Matrix3d& H, const Eigen::Vector2d& p) {
  const Eigen::Vector3d q = H * p.homogeneous();
  return q.hnormalized();
}

// Bilinear sample at (u, v) (pixel centres at integers), clamped to the frame.
Eigen::Vector3f Sample(const Image& img, double u, double v) {
  const double x = std::clamp(u, 0.0, img.width - 1.0), y = std::clamp(v, 0.0, img.height - 1.0);
  const int x0 = std::min(static_cast<int>(x), img.width - 2 < 0 ? 0 : img.width - 2);
  const int y0 = std::min(static_cast<int>(y), img.height - 2 < 0 ? 0 : img.height - 2);
  const int x1 = std::min(x0 + 1, img.width - 1), y1 = std::min(y0 + 1, img.height - 1);
  const float fx = static_cast<float>(x - x0), fy = static_cast<float>(y - y0);
  return (1 - fy) * ((1 - fx) * img.rgb(img.index(x0, y0)) + fx * img.rgb(img.index(x1, y0))) +
         fy * ((1 - fx) * img.rgb(img.index(x0, y1)) + fx * img.rgb(img.index(x1, y1)));
}

float Luminance(const Eigen::Vector3f& c) { return 0.2126f * c.x() + 0.7152f * c.y() + 0.0722f * c.z(); }

// True when p lies inside the convex quadrilateral q (either winding).
bool InsideQuad(const std::array<Eigen::Vector2d, 4>& q, const Eigen::Vector2d& p) {
  int sign = 0;
  for (int k = 0; k < 4; ++k) {
    const Eigen::Vector2d e = q[(k + 1) % 4] - q[k], w = p - q[k];
    const double c = e.x() * w.y() - e.y() * w.x();
    const int s = c > 0 ? 1 : (c < 0 ? -1 : 0);
    if (s == 0) continue;
    if (sign == 0) sign = s;
    else if (s != sign) return false;
  }
  return true;
}

// A detected tag's pattern-to-image homography: pattern coordinates in cells,
// x right and y down from the top-left corner of the upright pattern.
struct TagInImage {
  TagDetection det;
  TagPattern pattern;
  Eigen::Matrix3d H;
  double cell_px = 0;  // black-border edge in pixels / border cells
};

TagInImage LocateTag(const TagDetection& d, const std::string& family) {
  TagInImage t;
  t.det = d;
  t.pattern = MakeTagPattern(family, d.id);
  t.H = TagPatternToImage(d, t.pattern);
  double edge = 0;
  for (int k = 0; k < 4; ++k) edge += (d.corners[k] - d.corners[(k + 1) % 4]).norm() / 4;
  t.cell_px = edge / t.pattern.border_width;
  return t;
}

// Square dilation of a 0/1 mask by `radius` pixels (separable max filter).
std::vector<char> Dilate(const std::vector<char>& in, int w, int h, int radius) {
  if (radius <= 0) return in;
  std::vector<char> tmp(in.size(), 0), out(in.size(), 0);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      char v = 0;
      for (int dx = std::max(0, x - radius); dx <= std::min(w - 1, x + radius) && !v; ++dx) v = in[y * w + dx];
      tmp[y * w + x] = v;
    }
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      char v = 0;
      for (int dy = std::max(0, y - radius); dy <= std::min(h - 1, y + radius) && !v; ++dy) v = tmp[dy * w + x];
      out[y * w + x] = v;
    }
  return out;
}

Eigen::Vector3d MedianRgb(std::vector<Eigen::Vector3f>& samples) {
  Eigen::Vector3d m;
  std::vector<float> c(samples.size());
  for (int k = 0; k < 3; ++k) {
    for (size_t i = 0; i < samples.size(); ++i) c[i] = samples[i][k];
    std::nth_element(c.begin(), c.begin() + c.size() / 2, c.end());
    m[k] = c[c.size() / 2];
  }
  return m;
}

}  // namespace

std::string RegisterStageOptions::Validate() const {
  if (image.empty()) return "--image: the linear hero photo is required";
  if (plane.empty()) return "--plane: plane.json is required";
  if (pose.empty()) return "--pose: pose.json is required";
  if (mesh.empty()) return "--mesh: the object's mesh is required";
  if (out.empty()) return "--out: the scene folder is required";
  if (clip_level < 0 || !std::isfinite(clip_level)) return "--clip-level must be >= 0";
  if (plane_half_size && !(plane_half_size->x() > 0 && plane_half_size->y() > 0))
    return "--plane-half-size: half extents must be positive";
  if (object_margin_px < 0) return "--object-margin must be >= 0";
  if (albedo_mode == AlbedoMode::kGiven && ((albedo.array() < 0).any() || (albedo.array() > 1).any()))
    return "--albedo: values must lie in [0, 1]";
  if (!(paper_albedo > 0 && paper_albedo <= 1)) return "--paper-albedo must lie in (0, 1]";
  if ((object_albedo.array() < 0).any() || (object_albedo.array() > 1).any())
    return "--object-albedo: values must lie in [0, 1]";
  if (!(tag_exclude_scale >= 1)) return "--tag-exclude-scale must be >= 1";
  if (albedo_mode == AlbedoMode::kTag && !mask_tags) return "--albedo tag needs the tags (drop --no-tag-mask)";
  return "";
}

RegisterStageResult RunRegisterStage(const RegisterStageOptions& o, const StageContext& ctx) {
  const std::string bad = o.Validate();
  if (!bad.empty()) throw InputError("register", bad);
  const ProgressFn progress = ctx.Progress("register");
  Report(progress, 0.0, "reading inputs");

  // ---- Inputs --------------------------------------------------------------
  const PlaneFile pf = ReadPlaneFile(o.plane);
  if (pf.xyz.norm() > 1e-9 || (pf.normal - Eigen::Vector3d::UnitZ()).norm() > 1e-6)
    throw InputError(o.plane.string(), "plane must be at xyz [0, 0, 0] with normal [0, 0, 1] (the registered frame)");
  const PoseFile pose = ReadPoseFile(o.pose);
  if (!(pose.o2c(2, 3) > 0))
    throw InputError(o.pose.string(), "o2c: the object is not in front of the camera (its origin is at camera z = " +
                                          Fmt("%.4g", pose.o2c(2, 3)) + ")");
  const TriangleMesh mesh = ReadMesh(o.mesh);
  if (mesh.vertices.empty()) throw InputError(o.mesh.string(), "mesh has no vertices");
  Image image = ReadImage(o.image);
  if (Lower(o.image.extension().string()) != ".exr")
    ctx.Warn(o.image.string() + ": not an EXR; register expects a linear image (shadowsg linearize)");
  if (image.channels < 3) {
    Image rgb(image.width, image.height, 3);
    for (size_t p = 0; p < rgb.pixels(); ++p) rgb.set_rgb(p, image.rgb(p));
    image = std::move(rgb);
  } else if (image.channels > 3) {
    Image rgb(image.width, image.height, 3);
    for (size_t p = 0; p < rgb.pixels(); ++p) rgb.set_rgb(p, image.rgb(p));
    image = std::move(rgb);
  }
  CheckObservation(image, o.image);

  Camera cam;
  std::string camera_name;
  if (!o.camera.empty()) {
    cam = ReadCameraFile(o.camera).camera;
    camera_name = o.camera.string();
  } else if (pf.hero_camera) {
    cam = *pf.hero_camera;
    camera_name = o.plane.string() + " (hero.camera)";
  } else {
    throw InputError("--camera", "camera.json is required: " + o.plane.string() + " carries no hero camera");
  }
  if (cam.projection != Projection::kPerspective) throw InputError(camera_name, "not a perspective camera");
  if (cam.width != image.width || cam.height != image.height) {
    if (std::abs(static_cast<double>(image.width) / cam.width - static_cast<double>(image.height) / cam.height) > 1e-3)
      throw InputError(camera_name, "camera is " + std::to_string(cam.width) + "x" + std::to_string(cam.height) +
                                        " but the image is " + std::to_string(image.width) + "x" +
                                        std::to_string(image.height));
    ctx.Warn(camera_name + ": camera rescaled to the image's " + std::to_string(image.width) + "x" +
             std::to_string(image.height));
    cam = ResizeCamera(cam, image.width, image.height);
  }

  // ---- Units: world (plane.json) against pose.json / the mesh ----------------
  RegisterStageResult r;
  Eigen::Matrix4d c2w = pf.hero_c2w;
  const double h_world = c2w(2, 3);
  if (!(h_world > 0))
    throw InputError(o.plane.string(), "hero camera is not above the plane (z = " + Fmt("%.4g", h_world) + ")");
  const Eigen::Matrix3d Rcw = c2w.topLeftCorner<3, 3>();
  const Eigen::Vector3d n_cam = Rcw.transpose() * Eigen::Vector3d::UnitZ();  // plane normal, camera axes
  std::optional<double> h_plane_c;
  if (pose.plane_c) {
    h_plane_c = -pose.plane_c->normal.dot(pose.plane_c->xyz);
    const double angle =
        std::acos(std::clamp(pose.plane_c->normal.normalized().dot(n_cam), -1.0, 1.0)) * 180.0 / M_PI;
    if (angle > kMaxNormalDisagreementDeg)
      ctx.Warn("pose.json's plane_c and plane.json disagree on the plane's tilt by " + Fmt("%.1f", angle) + " deg");
  }
  const Eigen::Matrix3d Roc = pose.o2c.topLeftCorner<3, 3>();
  const Eigen::Vector3d toc = pose.o2c.topRightCorner<3, 1>();
  double lowest = std::numeric_limits<double>::infinity();
  for (const auto& v : mesh.vertices) lowest = std::min(lowest, n_cam.dot(Roc * v + toc));
  const double h_contact = -lowest;  // camera height if the lowest vertex touches the plane
  if (pf.scale_source != "none") {
    r.pose_units_per_world_unit = 1.0;
    r.units_from = "plane.json";
    if (h_plane_c) {
      r.plane_c_ratio = *h_plane_c / h_world;
      if (std::abs(*r.plane_c_ratio - 1) > kMaxUnitDisagreement)
        ctx.Warn("pose.json puts the camera " + Fmt("%.4g", *h_plane_c) + " above the plane, plane.json " +
                 Fmt("%.4g", h_world) + " (ratio " + Fmt("%.4f", *r.plane_c_ratio) +
                 "): are the tag sizes in the same unit?");
    }
  } else if (h_plane_c && *h_plane_c > 0) {
    r.pose_units_per_world_unit = *h_plane_c / h_world;
    r.units_from = "plane_c";
  } else {
    if (!(h_contact > 0))
      throw InputError(o.pose.string(), "the object is not in front of the plane: cannot fix the scale (plane.json "
                                        "has scale_source \"none\" and pose.json no plane_c)");
    r.pose_units_per_world_unit = h_contact / h_world;
    r.units_from = "contact";
    ctx.Warn("plane.json has no metric scale and pose.json no plane_c: scale set by assuming the object rests on "
             "the plane");
  }
  const double k = r.pose_units_per_world_unit;
  c2w.topRightCorner<3, 1>() *= k;
  cam.c2w = c2w;
  if (r.units_from != "plane.json")
    ctx.Log("world rescaled to pose.json's units: x" + Fmt("%.6g", k) + " (from " + r.units_from + ")");

  Eigen::Matrix4d o2w = c2w * pose.o2c;
  double zmin = std::numeric_limits<double>::infinity(), zmax = -zmin;
  for (const auto& v : mesh.vertices) {
    const double z = (o2w.topLeftCorner<3, 3>() * v + o2w.topRightCorner<3, 1>()).z();
    zmin = std::min(zmin, z);
    zmax = std::max(zmax, z);
  }
  r.object_gap = zmin;
  const double height = std::max(zmax - zmin, 1e-12);
  if (o.snap_to_plane) {
    o2w(2, 3) -= zmin;
    ctx.Log("object moved " + Fmt("%.4g", -zmin) + " along the normal to rest on the plane");
  } else if (std::abs(zmin) > kMaxContactGapFraction * height) {
    ctx.Warn(std::string("the object's lowest point is ") + Fmt("%.4g", std::abs(zmin)) +
             (zmin > 0 ? " above" : " below") + " the plane (" + Fmt("%.1f", 100 * std::abs(zmin) / height) +
             " % of its height; --snap-to-plane moves it)");
  }

  Plane plane;
  if (o.plane_half_size) {
    plane.scale = Eigen::Vector3d(o.plane_half_size->x(), o.plane_half_size->y(), 1.0);
  } else if (pf.half_extent) {
    plane.scale = Eigen::Vector3d(k * pf.half_extent->x(), k * pf.half_extent->y(), 1.0);
  } else {
    const double half = kFallbackExtentHeights * k * h_world;
    plane.scale = Eigen::Vector3d(half, half, 1.0);
    ctx.Warn(o.plane.string() + " has no plane rectangle: using +-" + Fmt("%.4g", half) + " (--plane-half-size)");
  }

  // ---- Mask ------------------------------------------------------------------
  Report(progress, 0.2, "masking");
  const int W = image.width, H = image.height;
  const size_t N = image.pixels();
  std::vector<char> on_plane(N, 0), excluded(N, 0);
  TriangleMesh world_mesh = TransformMesh(mesh, o2w);
  RayCaster caster;
  caster.AddMesh(world_mesh);
  caster.Commit();
#pragma omp parallel for schedule(dynamic, 8) num_threads(std::max(1, ctx.threads))
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const Ray ray = PixelRay(cam, x, y);
      const size_t i = static_cast<size_t>(y) * W + x;
      double t_plane = std::numeric_limits<double>::infinity();
      if (ray.dir.z() < 0) {
        t_plane = -ray.origin.z() / ray.dir.z();
        const Eigen::Vector3d p = ray.origin + t_plane * ray.dir;
        on_plane[i] = PlaneRectContains(plane, p);
      }
      if (caster.Intersect(ray.origin, ray.dir, 0, t_plane)) excluded[i] = 1, on_plane[i] = 0;
    }

  // Clipped pixels.
  std::vector<char> clipped(N, 0);
  fs::path clipped_path = o.clipped;
  if (clipped_path.empty()) {
    const fs::path sibling = o.image.parent_path() / (o.image.stem().string() + "_clipped.png");
    std::error_code ec;
    if (fs::is_regular_file(sibling, ec)) clipped_path = sibling;
  }
  if (!clipped_path.empty()) {
    const Image m = ReadMask(clipped_path);
    if (m.width != W || m.height != H)
      throw InputError(clipped_path.string(), "mask is " + std::to_string(m.width) + "x" + std::to_string(m.height) +
                                                  " but the image is " + std::to_string(W) + "x" + std::to_string(H));
    for (size_t i = 0; i < N; ++i) clipped[i] |= m.data[i] > 0;
    ctx.Log("clipped pixels from " + clipped_path.string());
  }
  double level = o.clip_level;
  if (level == 0) {  // automatic: a plateau at the image's maximum is saturation
    float vmax = 0;
    for (float v : image.data) vmax = std::max(vmax, v);
    size_t at_max = 0;
    for (size_t i = 0; i < N; ++i) at_max += image.rgb(i).maxCoeff() >= vmax;
    if (vmax > 0 && at_max >= static_cast<size_t>(kMinSaturatedPixels)) level = vmax;
  }
  if (level > 0)
    for (size_t i = 0; i < N; ++i) clipped[i] |= image.rgb(i).maxCoeff() >= level;
  for (size_t i = 0; i < N; ++i) {
    r.clipped_pixels += clipped[i] != 0;
    excluded[i] |= clipped[i];
  }

  // AprilTags and their paper.
  std::vector<TagInImage> tags;
  if (o.mask_tags) {
    TagDetectorOptions detector;
    detector.family = o.tag_family;
    detector.threads = std::max(1, ctx.threads);
    for (const TagDetection& d : DetectTags(ToneMap(image), detector)) tags.push_back(LocateTag(d, o.tag_family));
    for (const auto& t : tags) {
      const double c = 0.5 * t.pattern.total_width, half = 0.5 * t.pattern.total_width * o.tag_exclude_scale;
      std::array<Eigen::Vector2d, 4> quad;
      const double sx[4] = {-1, 1, 1, -1}, sy[4] = {-1, -1, 1, 1};
      for (int q = 0; q < 4; ++q) quad[q] = Apply(t.H, Eigen::Vector2d(c + sx[q] * half, c + sy[q] * half));
      Eigen::Vector2d lo = quad[0], hi = quad[0];
      for (const auto& p : quad) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
      const int x0 = std::max(0, static_cast<int>(std::floor(lo.x()))), x1 = std::min(W - 1, static_cast<int>(hi.x()) + 1);
      const int y0 = std::max(0, static_cast<int>(std::floor(lo.y()))), y1 = std::min(H - 1, static_cast<int>(hi.y()) + 1);
      for (int y = y0; y <= y1; ++y)
        for (int x = x0; x <= x1; ++x)
          if (InsideQuad(quad, Eigen::Vector2d(x, y))) excluded[static_cast<size_t>(y) * W + x] = 1;
    }
    r.tags_masked = static_cast<int>(tags.size());
    if (!tags.empty()) ctx.Log(std::to_string(tags.size()) + " " + o.tag_family + " tag(s) masked out");
  }
  const std::vector<char> excluded_wide = Dilate(excluded, W, H, o.object_margin_px);
  Image mask(W, H, 1, 0.0f);
  for (size_t i = 0; i < N; ++i)
    if (on_plane[i] && !excluded_wide[i]) {
      mask.data[i] = 1.0f;
      ++r.mask_pixels;
    }
  if (r.mask_pixels == 0) throw InputError(o.image.string(), "no usable plane pixels: the mask is empty");

  // ---- Albedo ----------------------------------------------------------------
  Report(progress, 0.6, "albedo");
  plane.diffuse = Eigen::Vector3d::Constant(kConventionAlbedo);
  r.albedo_source = "convention";
  std::string albedo_note;
  if (o.albedo_mode == AlbedoMode::kGiven) {
    plane.diffuse = o.albedo;
    r.albedo_source = "given";
    albedo_note = "plane albedo given on the command line";
  } else if (o.albedo_mode != AlbedoMode::kConvention) {
    std::vector<Eigen::Vector3f> paper, ground;
    for (const auto& t : tags) {
      if (t.cell_px < kMinTagCellPx) continue;
      for (int row = 0; row < t.pattern.total_width; ++row)
        for (int col = 0; col < t.pattern.total_width; ++col) {
          if (!t.pattern.at(col, row)) continue;
          const Eigen::Vector2d p = Apply(t.H, Eigen::Vector2d(col + 0.5, row + 0.5));
          const int px = static_cast<int>(std::lround(p.x())), py = static_cast<int>(std::lround(p.y()));
          if (px < 0 || py < 0 || px >= W || py >= H || clipped[static_cast<size_t>(py) * W + px]) continue;
          paper.push_back(Sample(image, p.x(), p.y()));
        }
    }
    std::vector<float> lum;
    for (size_t i = 0; i < N; ++i)
      if (mask.data[i] > 0) lum.push_back(Luminance(image.rgb(i)));
    std::vector<float> sorted = lum;
    std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
    const float median_lum = sorted[sorted.size() / 2];
    for (size_t i = 0; i < N; ++i)
      if (mask.data[i] > 0 && Luminance(image.rgb(i)) >= median_lum) ground.push_back(image.rgb(i));
    std::string why;
    if (static_cast<int>(paper.size()) < kMinPaperSamples) {
      why = tags.empty() ? "no AprilTag in the photo"
                         : "the tags' white cells are too small or clipped (" + std::to_string(paper.size()) +
                               " samples)";
    } else {
      const Eigen::Vector3d paper_rgb = MedianRgb(paper), ground_rgb = MedianRgb(ground);
      const Eigen::Vector3d est = o.paper_albedo * ground_rgb.cwiseQuotient(paper_rgb.cwiseMax(1e-12));
      if ((paper_rgb.array() <= 0).any() || (est.array() > 1).any() || (est.array() <= 0).any()) {
        why = "the estimate [" + Fmt("%.3f", est.x()) + ", " + Fmt("%.3f", est.y()) + ", " + Fmt("%.3f", est.z()) +
              "] is implausible (a tag in shadow?)";
      } else {
        plane.diffuse = est;
        r.albedo_source = "apriltag";
        albedo_note = "plane albedo = paper albedo " + Fmt("%.3g", o.paper_albedo) +
                      " x (median of the brighter half of the plane pixels) / (median of the tags' white cells)";
        ctx.Log("plane albedo from the tag's paper: " + Fmt("%.3f", est.x()) + " " + Fmt("%.3f", est.y()) + " " +
                Fmt("%.3f", est.z()));
      }
    }
    if (r.albedo_source == "convention") {
      if (o.albedo_mode == AlbedoMode::kTag) throw InputError(o.image.string(), "no albedo from the tags: " + why);
      ctx.Warn("plane albedo unknown (" + why + "): set to " + Fmt("%.2f", kConventionAlbedo) +
               " by convention; the lighting absorbs the true albedo's scale and colour (--albedo R,G,B if known)");
    }
  }
  if (r.albedo_source == "convention")
    albedo_note = "plane albedo unknown, set to " + Fmt("%.2f", kConventionAlbedo) +
                  " grey by convention: lighting is recovered relative to it (true lighting = recovered x " +
                  Fmt("%.2f", kConventionAlbedo) + " / true albedo, per channel)";

  // ---- Scene -----------------------------------------------------------------
  Report(progress, 0.8, "writing");
  Scene scene;
  scene.camera = cam;
  scene.plane = plane;
  SceneObject obj;
  obj.mesh_path = "geometry/mesh.obj";
  obj.sph_path = "geometry/mesh_sphere.sph";
  obj.mesh = mesh;
  obj.o2w = o2w;
  obj.diffuse = o.object_albedo;
  obj.is_train = true;
  scene.objects.push_back(std::move(obj));
  scene.image = image;
  scene.mask = mask;

  EnsureOutputDir(o.out);
  EnsureOutputDir(o.out / "geometry");
  WriteObj(o.out / "geometry" / "mesh.obj", mesh);
  WriteExr(o.out / "image.exr", image);
  Image mask8(W, H, 1);
  for (size_t i = 0; i < N; ++i) mask8.data[i] = mask.data[i];
  WriteLdr(o.out / "mask.png", mask8);
  Image preview = ToneMap(image);
  for (size_t i = 0; i < N; ++i)
    if (mask.data[i] == 0) preview.set_rgb(i, preview.rgb(i) * kPreviewDim);
  WriteLdr(o.out / "mask_preview.png", preview);

  Json j = SceneToJson(scene);
  j["mask"] = "mask.png";
  Json reg{{"plane_json", fs::absolute(o.plane).lexically_normal().string()},
           {"pose_json", fs::absolute(o.pose).lexically_normal().string()},
           {"hero_image", pf.hero_image},
           {"scale_source", pf.scale_source},
           {"pose_units_per_world_unit", k},
           {"units_from", r.units_from},
           {"albedo_source", r.albedo_source},
           {"albedo_note", albedo_note},
           {"object_gap", r.object_gap},
           {"snapped_to_plane", o.snap_to_plane},
           {"mask_pixels", r.mask_pixels},
           {"clipped_pixels", r.clipped_pixels},
           {"tags_masked", r.tags_masked}};
  if (r.plane_c_ratio) reg["plane_c_height_ratio"] = *r.plane_c_ratio;
  j["registration"] = reg;
  WriteJsonFile(o.out / "scene.json", j);
  Report(progress, 1.0, "done");

  r.scene = std::move(scene);
  r.scene_dir = o.out;
  return r;
}

}  // namespace shadowsg
