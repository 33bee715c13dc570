#include "stages/plane_stage.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <exception>
#include <map>

#include "calib/apriltag_detect.h"
#include "calib/error.h"
#include "calib/image_warp.h"
#include "calib/tag_refine.h"
#include "stages/io/capture_io.h"
#include "stages/io/image_io.h"
#include "stages/io/json_util.h"
#include "stages/stage_util.h"

namespace shadowsg {
namespace fs = std::filesystem;

namespace {

// Rays of a tag corner seen from directions closer than this are not
// triangulated: the corners are intersected with the plane instead.
constexpr double kMinTriangulationAngleDeg = 2.0;
// A reconstructed tag whose diagonals differ by more than this share is
// reported (misdetection or a tag not lying flat).
constexpr double kMaxTagSquareness = 0.05;
// Names listed in an error message at most.
constexpr size_t kMaxNamesListed = 8;

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

std::string Fmt(const char* fmt, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, fmt, v);
  return buf;
}

std::string NameList(std::vector<std::string> names) {
  std::sort(names.begin(), names.end());
  std::string s;
  for (size_t i = 0; i < names.size() && i < kMaxNamesListed; ++i) s += (i ? ", " : "") + names[i];
  if (names.size() > kMaxNamesListed) s += ", ... (" + std::to_string(names.size()) + " in all)";
  return s;
}

// The hero's name as COLMAP knows it: a path's file name.
std::string HeroName(const std::string& hero) { return fs::path(hero).filename().string(); }

struct RayT {
  Eigen::Vector3d origin, dir;
};

// Least-squares point closest to all rays (midpoint method).
Eigen::Vector3d TriangulateRays(const std::vector<RayT>& rays) {
  Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  for (const auto& r : rays) {
    const Eigen::Matrix3d P = Eigen::Matrix3d::Identity() - r.dir * r.dir.transpose();
    A += P;
    b += P * r.origin;
  }
  return A.ldlt().solve(b);
}

double MaxRayAngleDeg(const std::vector<RayT>& rays) {
  double best = 0;
  for (size_t i = 0; i < rays.size(); ++i)
    for (size_t j = i + 1; j < rays.size(); ++j)
      best = std::max(best, std::acos(std::clamp(rays[i].dir.dot(rays[j].dir), -1.0, 1.0)));
  return best * 180.0 / M_PI;
}

std::optional<Eigen::Vector3d> IntersectFit(const PlaneFitResult& fit, const RayT& ray) {
  const double denom = fit.normal.dot(ray.dir);
  if (std::abs(denom) < 1e-12) return std::nullopt;
  const double t = fit.normal.dot(fit.point - ray.origin) / denom;
  if (t <= 0) return std::nullopt;
  return ray.origin + t * ray.dir;
}

// Tag corners seen in the registered photos, triangulated in the model frame.
std::vector<TagScaleReport> MeasureTags(const ColmapModel& model, const PlaneStageOptions& o,
                                        const PlaneFitResult& fit, const StageContext& ctx) {
  std::vector<const ColmapImage*> images;
  for (const auto& [id, im] : model.images) images.push_back(&im);
  std::sort(images.begin(), images.end(), [](auto* a, auto* b) { return a->name < b->name; });
  // Per image: detections as rays (model frame), by tag id and corner.
  using CornerRays = std::array<std::vector<RayT>, 4>;
  std::vector<std::map<int, std::array<RayT, 4>>> per_image(images.size());
  std::vector<std::string> problems(images.size());
  std::vector<std::exception_ptr> errors(images.size());
  TagDetectorOptions detector;
  detector.family = o.tag_family;
  const ProgressFn progress = ctx.Progress("tags");
  int done = 0;
  // One photo: its detections as rays; InputError for an unreadable photo.
  auto detect_in = [&](long i) {
    const ColmapImage& im = *images[i];
    const fs::path path = o.images / im.name;
    std::error_code ec;
    if (!fs::is_regular_file(path, ec)) {
      problems[i] = path.string() + ": not found (tags not searched)";
    } else {
      // Detection on the display-referred photo, corners refined in linear
      // intensity (tag_refine.h: the detector's edges sit ~1 % inside).
      Image display = ReadImage(path), linear = display;
      if (Lower(path.extension().string()) == ".exr")
        display = ToneMap(display);
      else
        for (float& v : linear.data) v = SrgbDecode(v);
      Camera cam = ColmapImageCamera(model, im);
      if (cam.width != display.width || cam.height != display.height) {
        problems[i] = path.string() + ": size differs from COLMAP's camera (tags not searched)";
      } else {
        for (const TagDetection& d : DetectTags(display, detector)) {
          if (o.tag_id >= 0 && d.id != o.tag_id) continue;
          if (per_image[i].count(d.id)) continue;  // the strongest detection comes first
          std::array<Eigen::Vector2d, 4> corners = d.corners;
          if (const auto refined = RefineTagCorners(linear, d, MakeTagPattern(o.tag_family, d.id)))
            corners = *refined;
          std::array<RayT, 4> rays;
          for (int k = 0; k < 4; ++k) {
            const Ray r = PixelRay(cam, corners[k].x(), corners[k].y());
            rays[k] = {r.origin, r.dir};
          }
          per_image[i][d.id] = rays;
        }
      }
    }
  };
#pragma omp parallel for schedule(dynamic) num_threads(std::max(1, ctx.threads))
  for (long i = 0; i < static_cast<long>(images.size()); ++i) {
    try {
      try {
        detect_in(i);
      } catch (const InputError& e) {
        problems[i] = e.what();
      }
#pragma omp critical(plane_tags_progress)
      Report(progress, static_cast<double>(++done) / images.size(), "detecting " + o.tag_family + " tags");
    } catch (...) {
      errors[i] = std::current_exception();  // e.g. Interrupted from the progress callback
    }
  }
  for (const auto& e : errors)
    if (e) std::rethrow_exception(e);
  for (const auto& p : problems)
    if (!p.empty()) ctx.Warn(p);

  std::map<int, CornerRays> by_tag;
  for (const auto& m : per_image)
    for (const auto& [id, rays] : m)
      for (int k = 0; k < 4; ++k) by_tag[id][k].push_back(rays[k]);

  std::vector<TagScaleReport> reports;
  for (const auto& [id, corners] : by_tag) {
    TagScaleReport rep;
    rep.tag_id = id;
    rep.views = static_cast<int>(corners[0].size());
    rep.triangulated = rep.views >= 2 && MaxRayAngleDeg(corners[0]) >= kMinTriangulationAngleDeg;
    std::array<Eigen::Vector3d, 4> X;
    bool ok = true;
    for (int k = 0; k < 4 && ok; ++k) {
      if (rep.triangulated) {
        X[k] = TriangulateRays(corners[k]);
      } else {
        Eigen::Vector3d sum = Eigen::Vector3d::Zero();
        int n = 0;
        for (const auto& ray : corners[k])
          if (const auto p = IntersectFit(fit, ray)) sum += *p, ++n;
        ok = n > 0;
        if (ok) X[k] = sum / n;
      }
    }
    if (!ok) continue;
    double edge = 0;
    for (int k = 0; k < 4; ++k) edge += (X[k] - X[(k + 1) % 4]).norm() / 4;
    rep.edge_model = edge;
    rep.squareness = std::abs((X[0] - X[2]).norm() / (X[1] - X[3]).norm() - 1);
    if (!(edge > 0)) continue;
    if (rep.squareness > kMaxTagSquareness)
      ctx.Warn("tag " + std::to_string(id) + ": reconstructed square is skewed (diagonals differ by " +
               Fmt("%.1f", 100 * rep.squareness) + " %); is it flat and rigid?");
    reports.push_back(rep);
  }
  return reports;
}

double Median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

double Quantile(std::vector<double> v, double q) {
  std::sort(v.begin(), v.end());
  const double pos = q * (v.size() - 1);
  const size_t i = static_cast<size_t>(pos);
  const double f = pos - i;
  return i + 1 < v.size() ? v[i] * (1 - f) + v[i + 1] * f : v[i];
}

}  // namespace

std::vector<std::string> ListPhotos(const fs::path& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw InputError(dir.string(), "photo folder not found");
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    const std::string ext = Lower(e.path().extension().string());
    if (e.is_regular_file(ec) &&
        (ext == ".jpg" || ext == ".jpeg" || ext == ".png" || ext == ".tif" || ext == ".tiff" || ext == ".bmp"))
      names.push_back(e.path().filename().string());
  }
  std::sort(names.begin(), names.end());
  return names;
}

std::string PlaneStageOptions::Validate() const {
  if (colmap_model.empty() && images.empty()) return "--images: the photo folder is required (or --colmap-model)";
  if (hero.empty()) return "--hero: the hero photo's name is required";
  if (out.empty()) return "--out: an output file is required";
  if (matcher != "exhaustive" && matcher != "sequential")
    return "--matcher: expected exhaustive or sequential, got \"" + matcher + "\"";
  if (min_registered < 2) return "--min-registered must be at least 2";
  if (inlier_threshold < 0 || !std::isfinite(inlier_threshold)) return "--plane-threshold must be >= 0";
  if (!(threshold_fraction > 0 && threshold_fraction < 1)) return "--plane-threshold-fraction must lie in (0, 1)";
  if (ransac_iterations < 1) return "--ransac-iterations must be >= 1";
  if (!(min_inlier_fraction > 0 && min_inlier_fraction <= 1)) return "--min-inlier-fraction must lie in (0, 1]";
  if (tag_size < 0 || !std::isfinite(tag_size)) return "--tag-size must be positive";
  if (distance < 0 || !std::isfinite(distance)) return "--distance must be positive";
  if (tag_size > 0 && distance > 0) return "--tag-size and --distance: give one scale reference, not both";
  if (distance > 0 && distance_pixels.size() != 2 && distance_points.size() != 2)
    return "--distance needs its two points: --distance-pixels U1,V1,U2,V2 or --distance-points ID1,ID2";
  if (distance > 0 && !distance_pixels.empty() && !distance_points.empty())
    return "--distance-pixels and --distance-points: give one pair, not both";
  if (distance == 0 && (!distance_pixels.empty() || !distance_points.empty()))
    return "--distance-pixels/--distance-points need --distance";
  if (tag_size > 0 && images.empty()) return "--tag-size needs --images: the photos to find the tag in";
  if (colmap_model.empty()) {
    ColmapRunOptions run;
    run.executable = colmap;
    run.images = images;
    run.workspace = "workspace";
    run.matcher = matcher;
    run.camera_model = camera_model;
    run.max_image_size = max_image_size;
    run.max_features = max_features;
    const std::string bad = run.Validate();
    if (!bad.empty()) return bad;
  }
  return "";
}

fs::path SelectColmapModel(const fs::path& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw InputError(dir.string(), "COLMAP model folder not found");
  if (IsColmapModelDir(dir)) return dir;
  fs::path best;
  size_t best_images = 0;
  std::vector<fs::path> subdirs;
  for (const auto& e : fs::directory_iterator(dir, ec))
    if (e.is_directory(ec) && IsColmapModelDir(e.path())) subdirs.push_back(e.path());
  std::sort(subdirs.begin(), subdirs.end());
  for (const auto& d : subdirs) {
    const size_t n = ReadColmapModel(d).images.size();
    if (best.empty() || n > best_images) best = d, best_images = n;
  }
  if (best.empty())
    throw InputError(dir.string(),
                     "no COLMAP model here or in its numbered sub-folders (cameras, images, points3D as .bin or .txt)");
  return best;
}

PlaneStageResult RegisterPlane(const ColmapModel& model, const PlaneStageOptions& o, const StageContext& ctx) {
  const std::string bad = o.Validate();
  if (!bad.empty()) throw InputError("plane", bad);
  PlaneStageResult r;
  r.registered_images = static_cast<int>(model.images.size());
  r.points = model.points.size();
  std::vector<std::string> registered;
  for (const auto& [id, im] : model.images) registered.push_back(im.name);
  if (r.registered_images < o.min_registered)
    throw InputError("COLMAP", "registered only " + std::to_string(r.registered_images) + " image(s) (at least " +
                                   std::to_string(o.min_registered) +
                                   " needed): the photos need more overlap, texture or sharpness");

  // The hero.
  r.hero_name = HeroName(o.hero);
  const ColmapImage* hero = model.FindImage(o.hero);
  if (!hero) hero = model.FindImage(r.hero_name);
  if (!hero)
    throw InputError(o.hero, "the hero photo was not registered by COLMAP (registered: " + NameList(registered) + ")");
  r.hero_name = hero->name;
  Camera hero_cam;
  if (!o.camera.empty()) {
    hero_cam = ReadCameraFile(o.camera).camera;
    const ColmapCamera& cc = model.cameras.at(hero->camera_id);
    const int w = static_cast<int>(cc.width), h = static_cast<int>(cc.height);
    if (hero_cam.width != w || hero_cam.height != h) {
      if (std::abs(static_cast<double>(w) / hero_cam.width - static_cast<double>(h) / hero_cam.height) > 1e-3)
        throw InputError(o.camera.string(), "camera is " + std::to_string(hero_cam.width) + "x" +
                                                std::to_string(hero_cam.height) + " but the hero photo is " +
                                                std::to_string(w) + "x" + std::to_string(h));
      ctx.Warn(o.camera.string() + ": camera rescaled to the hero photo's " + std::to_string(w) + "x" +
               std::to_string(h));
      hero_cam = ResizeCamera(hero_cam, w, h);
    }
    r.hero_intrinsics = "camera.json";
  } else {
    hero_cam = ColmapCameraToCamera(model.cameras.at(hero->camera_id), "COLMAP camera of " + hero->name);
    r.hero_intrinsics = "colmap";
  }
  const Eigen::Matrix4d hero_c2w_model = ColmapPoseToC2w(hero->pose);

  // The plane.
  std::vector<Eigen::Vector3d> points, centres;
  points.reserve(model.points.size());
  for (const auto& p : model.points) points.push_back(p.xyz);
  for (const auto& [id, im] : model.images) centres.push_back(ColmapPoseToC2w(im.pose).block<3, 1>(0, 3));
  if (static_cast<int>(points.size()) < kMinPlaneInliers)
    throw InputError("COLMAP", "the reconstruction has only " + std::to_string(points.size()) +
                                   " 3D points: too few to find the ground plane");
  r.threshold = o.inlier_threshold > 0 ? o.inlier_threshold
                                       : PlaneInlierThreshold(points, centres, o.threshold_fraction);
  PlaneRansacOptions ransac;
  ransac.inlier_threshold = r.threshold;
  ransac.max_iterations = o.ransac_iterations;
  ransac.seed = ctx.seed;
  std::string why;
  if (!ransac.IsValid(&why)) throw InputError("plane", why);
  const std::optional<PlaneFitResult> fit = FitPlaneRansac(points, ransac);
  const int needed = std::max(kMinPlaneInliers, static_cast<int>(std::ceil(o.min_inlier_fraction * points.size())));
  if (!fit || fit->num_inliers < needed)
    throw InputError("COLMAP", "no dominant plane: the best plane holds " + std::to_string(fit ? fit->num_inliers : 0) +
                                   " of " + std::to_string(points.size()) + " points within " +
                                   Fmt("%.3g", r.threshold) + " (" + std::to_string(needed) +
                                   " needed); is the ground textured and in most photos? (--plane-threshold, "
                                   "--min-inlier-fraction)");
  r.fit = *fit;
  r.cameras_below = OrientPlaneNormal(centres, &r.fit);
  if (r.cameras_below > 0)
    ctx.Warn(std::to_string(r.cameras_below) + " of " + std::to_string(centres.size()) +
             " cameras lie below the fitted plane: is it the ground?");
  ctx.Log("plane: " + std::to_string(r.fit.num_inliers) + " of " + std::to_string(points.size()) + " points (" +
          Fmt("%.0f", 100.0 * r.fit.num_inliers / points.size()) + " %) within " + Fmt("%.3g", r.threshold) +
          ", rms " + Fmt("%.3g", r.fit.rms) + " (model units)");

  // World axes: z the normal, x the hero camera's right edge laid onto the plane.
  const Eigen::Vector3d ez = r.fit.normal;
  Eigen::Vector3d ex = hero_c2w_model.block<3, 1>(0, 0);
  ex -= ez * ez.dot(ex);
  ex = ex.norm() > 1e-6 ? ex.normalized() : Eigen::Vector3d(ez.unitOrthogonal());
  const Eigen::Vector3d ey = ez.cross(ex);
  Eigen::Matrix3d R;  // model -> world rotation (rows: world axes in model coordinates)
  R.row(0) = ex.transpose();
  R.row(1) = ey.transpose();
  R.row(2) = ez.transpose();
  std::vector<double> xs, ys;
  for (size_t i = 0; i < points.size(); ++i)
    if (r.fit.inliers[i]) {
      xs.push_back(ex.dot(points[i] - r.fit.point));
      ys.push_back(ey.dot(points[i] - r.fit.point));
    }
  const double x0 = Quantile(xs, kExtentPercentile), x1 = Quantile(xs, 1 - kExtentPercentile);
  const double y0 = Quantile(ys, kExtentPercentile), y1 = Quantile(ys, 1 - kExtentPercentile);
  const Eigen::Vector3d origin = r.fit.point + 0.5 * (x0 + x1) * ex + 0.5 * (y0 + y1) * ey;

  // Scale.
  if (o.tag_size > 0) {
    r.tags = MeasureTags(model, o, r.fit, ctx);
    if (r.tags.empty())
      throw InputError(o.images.string(), "no " + o.tag_family + " tag" +
                                              (o.tag_id >= 0 ? " with id " + std::to_string(o.tag_id) : "") +
                                              " found in the " + std::to_string(r.registered_images) +
                                              " registered photos (check --tag-family, --tag-id)");
    std::vector<double> scales;
    for (const auto& t : r.tags) {
      scales.push_back(o.tag_size / t.edge_model);
      ctx.Log("tag " + std::to_string(t.tag_id) + ": " + std::to_string(t.views) + " view(s), " +
              (t.triangulated ? "triangulated" : "on the plane") + ", edge " + Fmt("%.5g", t.edge_model) +
              " model units -> " + Fmt("%.5g", scales.back()) + " per unit");
    }
    r.scale = Median(scales);
    r.scale_source = "apriltag";
  } else if (o.distance > 0) {
    double model_distance = 0;
    if (!o.distance_points.empty()) {
      const ColmapPoint3D* a = model.FindPoint(o.distance_points[0]);
      const ColmapPoint3D* b = model.FindPoint(o.distance_points[1]);
      if (!a || !b)
        throw InputError("--distance-points", "point " + std::to_string(!a ? o.distance_points[0]
                                                                            : o.distance_points[1]) +
                                                  " is not in the COLMAP model");
      model_distance = (a->xyz - b->xyz).norm();
    } else {
      Camera cam = hero_cam;
      cam.c2w = hero_c2w_model;
      Eigen::Vector3d p[2];
      for (int k = 0; k < 2; ++k) {
        const Ray ray = PixelRay(cam, o.distance_pixels[k].x(), o.distance_pixels[k].y());
        const auto hit = IntersectFit(r.fit, {ray.origin, ray.dir});
        if (!hit) throw InputError("--distance-pixels", "pixel " + std::to_string(k + 1) + " does not see the plane");
        p[k] = *hit;
      }
      model_distance = (p[0] - p[1]).norm();
    }
    if (!(model_distance > 0)) throw InputError("--distance", "the two points coincide in the model");
    r.scale = o.distance / model_distance;
    r.scale_source = "distance";
  }

  r.colmap_to_world.setIdentity();
  r.colmap_to_world.topLeftCorner<3, 3>() = r.scale * R;
  r.colmap_to_world.topRightCorner<3, 1>() = -r.scale * R * origin;
  auto to_world = [&](const Eigen::Matrix4d& c2w_model) {
    Eigen::Matrix4d c2w = Eigen::Matrix4d::Identity();
    c2w.topLeftCorner<3, 3>() = R * c2w_model.topLeftCorner<3, 3>();
    c2w.topRightCorner<3, 1>() = r.scale * R * (c2w_model.topRightCorner<3, 1>() - origin);
    return c2w;
  };
  r.hero = hero_cam;
  r.hero.c2w = to_world(hero_c2w_model);
  r.half_extent = 0.5 * r.scale * Eigen::Vector2d(x1 - x0, y1 - y0);
  std::vector<const ColmapImage*> sorted;
  for (const auto& [id, im] : model.images) sorted.push_back(&im);
  std::sort(sorted.begin(), sorted.end(), [](auto* a, auto* b) { return a->name < b->name; });
  for (const ColmapImage* im : sorted) r.cameras.emplace_back(im->name, to_world(ColmapPoseToC2w(im->pose)));
  return r;
}

PlaneStageResult RunPlaneStage(const PlaneStageOptions& o, const StageContext& ctx) {
  const std::string bad = o.Validate();
  if (!bad.empty()) throw InputError("plane", bad);
  fs::path model_dir;
  int input_images = 0;
  double colmap_seconds = 0;
  if (!o.colmap_model.empty()) {
    model_dir = SelectColmapModel(o.colmap_model);
    ctx.Log("reading the COLMAP model in " + model_dir.string());
  } else {
    const std::vector<std::string> photos = ListPhotos(o.images);
    input_images = static_cast<int>(photos.size());
    if (photos.empty()) throw InputError(o.images.string(), "no .jpg, .png or .tif photos in the folder");
    const std::string hero = HeroName(o.hero);
    if (std::find(photos.begin(), photos.end(), hero) == photos.end())
      throw InputError(o.hero, "the hero photo is not among the " + std::to_string(photos.size()) + " photos in " +
                                   o.images.string() + " (" + NameList(photos) + ")");
    ColmapRunOptions run;
    run.executable = o.colmap;
    run.images = o.images;
    run.image_names = photos;
    run.workspace = o.workspace.empty()
                        ? (o.out.parent_path() / (o.out.stem().string() + "_colmap"))
                        : o.workspace;
    run.matcher = o.matcher;
    run.camera_model = o.camera_model;
    run.max_image_size = o.max_image_size;
    run.max_features = o.max_features;
    run.threads = std::max(1, ctx.threads);
    run.seed = ctx.seed;
    if (!o.camera.empty()) {
      Camera cam = ReadCameraFile(o.camera).camera;
      const Image hero_img = ReadImage(o.images / hero);
      if (cam.width != hero_img.width || cam.height != hero_img.height) {
        if (std::abs(static_cast<double>(hero_img.width) / cam.width -
                     static_cast<double>(hero_img.height) / cam.height) > 1e-3)
          throw InputError(o.camera.string(), "camera is " + std::to_string(cam.width) + "x" +
                                                  std::to_string(cam.height) + " but the photos are " +
                                                  std::to_string(hero_img.width) + "x" +
                                                  std::to_string(hero_img.height));
        cam = ResizeCamera(cam, hero_img.width, hero_img.height);
      }
      run.camera = cam;
    }
    ctx.Log("running COLMAP on " + std::to_string(photos.size()) + " photos (workspace " + run.workspace.string() +
            ")");
    const ColmapRunResult cr = RunColmap(run, ctx);
    colmap_seconds = cr.seconds;
    ctx.Log("COLMAP took " + Fmt("%.1f", cr.seconds) + " s");
    std::error_code ec;
    bool any = false;
    for (const auto& e : fs::directory_iterator(cr.sparse_dir, ec)) any |= IsColmapModelDir(e.path());
    if (!any)
      throw InputError("COLMAP", "registered no images (no model in " + cr.sparse_dir.string() +
                                     "): the photos need more overlap, texture or sharpness; log: " +
                                     cr.log.string());
    model_dir = SelectColmapModel(cr.sparse_dir);
  }
  const ColmapModel model = ReadColmapModel(model_dir);
  PlaneStageResult r = RegisterPlane(model, o, ctx);
  r.model_dir = model_dir;
  r.input_images = input_images;
  r.colmap_seconds = colmap_seconds;
  if (input_images > 0 && r.registered_images < input_images)
    ctx.Warn("COLMAP registered " + std::to_string(r.registered_images) + " of " + std::to_string(input_images) +
             " photos");

  PlaneFile f;
  f.half_extent = r.half_extent;
  f.hero_image = r.hero_name;
  f.hero_c2w = r.hero.c2w;
  f.hero_camera = r.hero;
  f.scale_source = r.scale_source;
  f.registered_images = r.registered_images;
  f.plane_inliers = r.fit.num_inliers;
  Json& x = f.extra;
  x["units"] = r.scale_source == "none" ? "COLMAP's arbitrary units" : "the unit of the scale reference";
  x["world_units_per_colmap_unit"] = r.scale;
  x["colmap_to_world"] = ToJson(r.colmap_to_world);
  x["colmap_model"] = fs::absolute(model_dir).lexically_normal().string();
  x["hero_intrinsics"] = r.hero_intrinsics;
  x["points"] = r.points;
  x["input_images"] = r.input_images;
  x["inlier_threshold"] = r.threshold * r.scale;
  x["plane_rms"] = r.fit.rms * r.scale;
  x["cameras_below_plane"] = r.cameras_below;
  x["colmap_seconds"] = r.colmap_seconds;
  if (!r.tags.empty()) {
    Json tags = Json::array();
    for (const auto& t : r.tags)
      tags.push_back({{"id", t.tag_id},
                      {"views", t.views},
                      {"triangulated", t.triangulated},
                      {"edge_colmap_units", t.edge_model},
                      {"squareness", t.squareness}});
    x["tags"] = tags;
    x["tag_size"] = o.tag_size;
    x["tag_family"] = o.tag_family;
  }
  if (o.distance > 0) x["distance"] = o.distance;
  Json images = Json::array();
  for (const auto& [name, c2w] : r.cameras) images.push_back({{"name", name}, {"c2w", ToJson(c2w)}});
  x["images"] = images;
  const fs::path parent = o.out.parent_path();
  if (!parent.empty()) EnsureOutputDir(parent);
  WriteJsonFile(o.out, PlaneFileToJson(f));
  r.plane_json = o.out;
  return r;
}

}  // namespace shadowsg
