#include "stages/pose_stage.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>
#include <unordered_map>

#include "calib/canvas.h"
#include "calib/error.h"
#include "calib/image_warp.h"
#include "solver/mesh.h"
#include "stages/io/capture_io.h"
#include "stages/io/image_io.h"
#include "stages/io/mesh_io.h"
#include "stages/stage_util.h"

namespace shadowsg {
namespace fs = std::filesystem;

namespace {

// Meshes up to this many faces get all their edges drawn (faintly); larger
// ones only silhouette, crease and boundary edges, which stay readable.
constexpr size_t kAllEdgesMaxFaces = 20000;
// Dihedral angle above which an edge counts as a crease.
constexpr double kCreaseDeg = 30.0;
// Straight 3D edges bend under lens distortion: one sub-segment per this many pixels.
constexpr double kSegmentPx = 8.0;

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

std::string Fmt(const char* fmt, double v) {
  char buf[64];
  std::snprintf(buf, sizeof buf, fmt, v);
  return buf;
}

Eigen::Vector3d Apply(const Eigen::Matrix4d& T, const Eigen::Vector3d& p) {
  return T.topLeftCorner<3, 3>() * p + T.topRightCorner<3, 1>();
}

std::string IdList(const std::vector<int>& ids) {
  std::string s;
  for (int id : ids) s += (s.empty() ? "" : ", ") + std::to_string(id);
  return s;
}

// Draws the 3D segment a-b (object coordinates) as a curve through the lens.
void DrawSegment(Canvas& canvas, const Camera& cam, const Eigen::Matrix4d& o2c, const Eigen::Vector3d& a,
                 const Eigen::Vector3d& b, const Eigen::Vector3f& colour, int thickness) {
  const auto ends = ProjectPoints({a, b}, o2c, cam);
  double len = (ends[1] - ends[0]).norm();
  if (!std::isfinite(len)) len = 64 * kSegmentPx;
  const int n = std::clamp(static_cast<int>(len / kSegmentPx), 1, 64);
  std::vector<Eigen::Vector3d> pts;
  for (int i = 0; i <= n; ++i) pts.push_back(a + (b - a) * (static_cast<double>(i) / n));
  const auto px = ProjectPoints(pts, o2c, cam);
  for (int i = 0; i < n; ++i)
    if (px[i].allFinite() && px[i + 1].allFinite()) canvas.Line(px[i], px[i + 1], colour, thickness);
}

void DrawMesh(Canvas& canvas, const Image& background, const Camera& cam, const Eigen::Matrix4d& o2c,
              const TriangleMesh& mesh, int thick) {
  const auto& V = mesh.vertices;
  const auto& F = mesh.faces;
  const Eigen::Matrix3d R = o2c.topLeftCorner<3, 3>();
  const Eigen::Vector3d eye = -R.transpose() * o2c.topRightCorner<3, 1>();  // camera centre, object coords
  std::vector<Eigen::Vector3d> normal(F.size());
  std::vector<char> front(F.size());
  struct EdgeFaces {
    int f0 = -1, f1 = -1, count = 0;
  };
  std::unordered_map<uint64_t, EdgeFaces> edges;
  edges.reserve(F.size() * 2);
  for (size_t f = 0; f < F.size(); ++f) {
    const Eigen::Vector3d &a = V[F[f][0]], &b = V[F[f][1]], &c = V[F[f][2]];
    normal[f] = (b - a).cross(c - a).normalized();
    front[f] = normal[f].dot(eye - a) > 0;
    for (int k = 0; k < 3; ++k) {
      const uint32_t i = F[f][k], j = F[f][(k + 1) % 3];
      const uint64_t key = static_cast<uint64_t>(std::min(i, j)) << 32 | std::max(i, j);
      EdgeFaces& e = edges[key];
      (e.count == 0 ? e.f0 : e.f1) = static_cast<int>(f);
      ++e.count;
    }
  }
  const double cos_crease = std::cos(kCreaseDeg * M_PI / 180.0);
  const Eigen::Vector3f green(0.2f, 1.0f, 0.3f);
  if (F.size() <= kAllEdgesMaxFaces) {
    Canvas faint(background);
    for (const auto& [key, e] : edges) DrawSegment(faint, cam, o2c, V[key >> 32], V[key & 0xffffffffu], green, 1);
    canvas.BlendFrom(faint, 0.35f);
  }
  for (const auto& [key, e] : edges) {
    const bool feature = e.count != 2 || front[e.f0] != front[e.f1] || normal[e.f0].dot(normal[e.f1]) < cos_crease;
    if (feature) DrawSegment(canvas, cam, o2c, V[key >> 32], V[key & 0xffffffffu], green, thick);
  }
}

void DrawAxes(Canvas& canvas, const Camera& cam, const Eigen::Matrix4d& o2c, double length, int thick) {
  const Eigen::Vector3f colours[3] = {{1, 0.2f, 0.2f}, {0.2f, 1, 0.2f}, {0.3f, 0.5f, 1}};
  for (int k = 0; k < 3; ++k)
    DrawSegment(canvas, cam, o2c, Eigen::Vector3d::Zero(), length * Eigen::Vector3d::Unit(k), colours[k], thick + 1);
}

void DrawPlaneGrid(Canvas& canvas, const Camera& cam, const Eigen::Vector3d& xyz, const Eigen::Vector3d& n, double half,
                   int thick) {
  const Eigen::Vector3d u = n.unitOrthogonal(), v = n.cross(u);
  constexpr int kLines = 8;
  const Eigen::Vector3f magenta(1.0f, 0.3f, 1.0f);
  for (int i = 0; i <= kLines; ++i) {
    const double s = -half + 2 * half * i / kLines;
    DrawSegment(canvas, cam, Eigen::Matrix4d::Identity(), xyz + s * u - half * v, xyz + s * u + half * v, magenta,
                thick);
    DrawSegment(canvas, cam, Eigen::Matrix4d::Identity(), xyz + s * v - half * u, xyz + s * v + half * u, magenta,
                thick);
  }
}

Camera CameraForImage(Camera cam, int w, int h, const fs::path& camera_path, const StageContext& ctx) {
  if (cam.projection != Projection::kPerspective) throw InputError(camera_path.string(), "not a perspective camera");
  if (cam.width == w && cam.height == h) return cam;
  if (std::abs(static_cast<double>(w) / cam.width - static_cast<double>(h) / cam.height) > 1e-3)
    throw InputError(camera_path.string(), "camera is " + std::to_string(cam.width) + "x" + std::to_string(cam.height) +
                                               " but the image is " + std::to_string(w) + "x" + std::to_string(h));
  ctx.Warn(camera_path.string() + ": camera rescaled to the image's " + std::to_string(w) + "x" + std::to_string(h));
  return ResizeCamera(cam, w, h);
}

}  // namespace

std::string PoseStageOptions::Validate() const {
  std::string why;
  if (image.empty()) return "--image: the photo is required";
  if (camera.empty()) return "--camera: camera.json is required";
  if (out.empty()) return "--out: an output file is required";
  if (method == PoseMethod::kAprilTag) {
    if (tag_layout.empty() && !(tag_size > 0)) return "--tag-size: the tag's black-border edge length is required";
    if (tag_size < 0) return "--tag-size must be positive";
    if (!detector.IsValid(&why)) return why;
    if (!offset.allFinite()) return "--offset must be finite";
  } else {
    if (points.empty()) return "--points: a CSV of u, v, x, y, z correspondences is required";
    if (!pnp.IsValid(&why)) return why;
  }
  return "";
}

std::vector<TagPlacement> ParseTagLayout(const Json& json, const std::string& name, double default_size,
                                         std::string* family) {
  const JsonReader root(json, name);
  if (root.Has("family")) *family = root.String("family");
  const double size = root.Number("size", default_size);
  const JsonReader tags = root.Child("tags");
  if (tags.Size() == 0) root.Fail("tags", "empty list");
  std::vector<TagPlacement> out;
  std::set<int> seen;
  for (size_t i = 0; i < tags.Size(); ++i) {
    const JsonReader t = tags.Element(i);
    TagPlacement p;
    p.id = t.Int("id");
    if (!seen.insert(p.id).second) t.Fail("id", "tag " + std::to_string(p.id) + " placed twice");
    p.size = t.Number("size", size);
    if (!(p.size > 0)) t.Fail("size", "missing or not positive (give it here, at the top, or with --tag-size)");
    if (t.Has("t2o")) {
      p.t2o = t.Mat4("t2o");
      const Eigen::Matrix3d R = p.t2o.topLeftCorner<3, 3>();
      if ((R.transpose() * R - Eigen::Matrix3d::Identity()).norm() > 1e-3 || R.determinant() < 0)
        t.Fail("t2o", "upper-left 3x3 is not a rotation");
    } else {
      const JsonReader c = t.Child("center");
      if (c.Size() != 2 && c.Size() != 3) t.Fail("center", "expected [x, y] or [x, y, z]");
      Eigen::Vector3d centre = Eigen::Vector3d::Zero();
      for (size_t k = 0; k < c.Size(); ++k) {
        const Json& v = c.Element(k).node();
        if (!v.is_number()) c.Element(k).Fail("", "expected a number");
        centre[static_cast<int>(k)] = v.get<double>();
      }
      p.t2o = TagOnGround(centre, t.Number("yaw_deg", 0.0) * M_PI / 180.0);
    }
    out.push_back(p);
  }
  return out;
}

PoseStageResult RunPoseStage(const PoseStageOptions& o, const StageContext& ctx) {
  const std::string bad = o.Validate();
  if (!bad.empty()) throw InputError("pose", bad);
  const CameraFile camera_file = ReadCameraFile(o.camera);
  Image display = ReadImage(o.image);
  if (Lower(o.image.extension().string()) == ".exr") display = ToneMap(display);
  const Camera cam = CameraForImage(camera_file.camera, display.width, display.height, o.camera, ctx);
  std::optional<TriangleMesh> mesh;
  if (!o.mesh.empty()) mesh = ReadMesh(o.mesh);

  PoseStageResult r;
  Json extra;
  std::vector<Eigen::Vector3d> pnp_obj;
  std::vector<Eigen::Vector2d> pnp_img;
  double axis_length = 0;
  const ProgressFn progress = ctx.Progress("pose");
  if (o.method == PoseMethod::kAprilTag) {
    r.method = "apriltag";
    TagDetectorOptions detector = o.detector;
    detector.threads = std::max(1, ctx.threads);
    std::vector<TagPlacement> placements;
    if (!o.tag_layout.empty())
      placements = ParseTagLayout(ReadJsonFile(o.tag_layout), o.tag_layout.string(), o.tag_size, &detector.family);
    Report(progress, 0.1, "detecting " + detector.family + " tags");
    r.detections = DetectTags(display, detector);
    std::vector<int> seen;
    for (const auto& d : r.detections) seen.push_back(d.id);
    seen.erase(std::unique(seen.begin(), seen.end()), seen.end());
    ctx.Log(std::to_string(r.detections.size()) + " " + detector.family + " tag(s) detected" +
            (seen.empty() ? "" : " (ids " + IdList(seen) + ")"));
    if (r.detections.empty())
      throw InputError(o.image.string(), "no " + detector.family +
                                             " tag found (check --tag-family; small or "
                                             "blurred tags: --tag-decimate 1)");
    if (placements.empty()) {
      int id = o.tag_id;
      if (id >= 0 && std::find(seen.begin(), seen.end(), id) == seen.end())
        throw InputError(o.image.string(), "tag " + std::to_string(id) + " not found (seen: " + IdList(seen) + ")");
      if (id < 0 && seen.size() > 1)
        throw InputError(o.image.string(), std::to_string(seen.size()) + " tags found (ids " + IdList(seen) +
                                               "): choose one with --tag-id, or place them all with --tag-layout");
      if (id < 0) id = seen[0];
      placements.push_back({id, o.tag_size, TagToObjectOnPlane(o.offset, o.mesh_up)});
    }
    Report(progress, 0.5, "fitting the pose");
    TagPoseResult tp = EstimatePoseFromTags(r.detections, placements, cam);
    r.pose = tp.pose;
    r.used_ids = tp.used_ids;
    r.plane = tp.plane;
    if (!tp.unknown_ids.empty()) ctx.Warn("tags without a placement ignored: " + IdList(tp.unknown_ids));
    if (!tp.duplicate_ids.empty()) {
      std::map<int, int> times;
      for (int id : tp.duplicate_ids) ++times[id];
      std::string list;
      for (const auto& [id, n] : times)
        list += (list.empty() ? "" : ", ") + std::to_string(id) + " (" + std::to_string(n + 1) + " times)";
      ctx.Warn("tags seen more than once, the strongest detection used: " + list);
    }
    Json tags = Json::array();
    double min_size = 1e300;
    for (size_t t = 0; t < tp.used_ids.size(); ++t) {
      const auto& det = *std::find_if(r.detections.begin(), r.detections.end(),
                                      [&](const TagDetection& d) { return d.id == tp.used_ids[t]; });
      const auto& pl = *std::find_if(placements.begin(), placements.end(),
                                     [&](const TagPlacement& p) { return p.id == tp.used_ids[t]; });
      min_size = std::min(min_size, pl.size);
      Json corners = Json::array();
      for (const auto& c : det.corners) corners.push_back({c.x(), c.y()});
      tags.push_back({{"id", det.id},
                      {"size", pl.size},
                      {"rms_px", tp.tag_rms_px[t]},
                      {"hamming", det.hamming},
                      {"decision_margin", det.decision_margin},
                      {"corners_px", corners}});
    }
    extra["family"] = detector.family;
    extra["tags"] = tags;
    extra["ignored_tags"] = tp.unknown_ids;
    extra["duplicate_tags"] = tp.duplicate_ids;
    axis_length = 0.75 * min_size;
  } else {
    r.method = "pnp";
    const Correspondences c = ReadCorrespondencesFile(o.points);
    pnp_obj = c.object;
    pnp_img = c.image;
    if (pnp_obj.size() < 6)
      ctx.Warn(o.points.string() + ": only " + std::to_string(pnp_obj.size()) +
               " correspondences; 6 or more make RANSAC meaningful");
    Report(progress, 0.5, "RANSAC PnP");
    r.pose = SolvePnp(pnp_obj, pnp_img, cam, o.pnp);
    extra["num_points"] = pnp_obj.size();
    extra["num_inliers"] = r.pose.num_inliers;
    Json outliers = Json::array();
    for (size_t i = 0; i < r.pose.inliers.size(); ++i)
      if (!r.pose.inliers[i]) outliers.push_back(i);
    extra["outliers"] = outliers;
    if (o.ground_z) {
      const Eigen::Vector3d xyz = Apply(r.pose.o2c, Eigen::Vector3d(0, 0, *o.ground_z));
      Eigen::Vector3d n = r.pose.o2c.topLeftCorner<3, 3>() * Eigen::Vector3d::UnitZ();
      if (n.dot(-xyz) < 0) {
        ctx.Warn("the object's +z points away from the camera; the plane normal was flipped towards it");
        n = -n;
      }
      r.plane = std::make_pair(xyz, n);
    }
    Eigen::Vector3d lo = pnp_obj[0], hi = pnp_obj[0];
    for (const auto& p : pnp_obj) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
    axis_length = 0.25 * (hi - lo).norm();
  }
  if (mesh && !mesh->vertices.empty()) {
    Eigen::Vector3d lo, hi;
    MeshBounds(*mesh, &lo, &hi);
    axis_length = 0.5 * (hi - lo).norm();
  }

  PoseFile file;
  file.o2c = r.pose.o2c;
  file.rms_px = r.pose.rms_px;
  file.method = r.method;
  if (r.plane) file.plane_c = PlaneInCamera{r.plane->first, r.plane->second};
  Json j = PoseFileToJson(file);
  for (auto it = extra.begin(); it != extra.end(); ++it) j[it.key()] = it.value();
  j["image"] = o.image.string();
  j["camera"] = o.camera.string();
  j["distance"] = r.pose.o2c.topRightCorner<3, 1>().norm();
  r.pose_json = o.out;
  if (o.out.has_parent_path()) EnsureOutputDir(o.out.parent_path());
  WriteJsonFile(r.pose_json, j);

  // The overlay.
  Report(progress, 0.8, "drawing the overlay");
  Canvas canvas(display);
  const double scale = std::max(cam.width, cam.height) / 1000.0;
  const int thick = std::max(1, static_cast<int>(std::lround(scale)));
  if (r.plane) DrawPlaneGrid(canvas, cam, r.plane->first, r.plane->second, 2 * axis_length, thick);
  if (mesh) DrawMesh(canvas, display, cam, r.pose.o2c, *mesh, thick);
  DrawAxes(canvas, cam, r.pose.o2c, axis_length, thick);
  const Eigen::Vector3f yellow(1, 0.9f, 0.1f), cyan(0.1f, 0.9f, 1), red(1, 0.15f, 0.15f);
  if (o.method == PoseMethod::kAprilTag) {
    size_t k = 0;
    for (const auto& d : r.detections) {
      const bool used = std::find(r.used_ids.begin(), r.used_ids.end(), d.id) != r.used_ids.end();
      std::vector<Eigen::Vector2d> poly(d.corners.begin(), d.corners.end());
      canvas.Polyline(poly, true, used ? yellow : red, thick);
      canvas.Text(d.centre, std::to_string(d.id), used ? yellow : red, 0.5 * std::max(1.0, scale));
    }
    for (int id : r.used_ids) {
      (void)id;
      for (int c = 0; c < 4; ++c, ++k) canvas.Cross(r.pose.reprojected[k], 3 * scale + 2, cyan, thick);
    }
  } else {
    for (size_t i = 0; i < pnp_img.size(); ++i) {
      const bool in = r.pose.inliers[i];
      canvas.Circle(pnp_img[i], 4 * scale + 2, in ? yellow : red, thick);
      canvas.Line(pnp_img[i], r.pose.reprojected[i], cyan, thick);
      canvas.Cross(r.pose.reprojected[i], 3 * scale + 2, cyan, thick);
    }
  }
  const double ts = 0.5 * std::max(1.0, scale);
  std::string label = r.method + ": RMS " + Fmt("%.2f px", r.pose.rms_px) + ", distance " +
                      Fmt("%.3g", r.pose.o2c.topRightCorner<3, 1>().norm());
  if (o.method == PoseMethod::kAprilTag)
    label += ", tags " + IdList(r.used_ids);
  else
    label += ", " + std::to_string(r.pose.num_inliers) + "/" + std::to_string(pnp_img.size()) + " inliers";
  canvas.Text({10 * ts, 30 * ts}, label, {1, 1, 1}, ts);
  r.overlay_png = o.overlay.empty() ? o.out.parent_path() / (o.out.stem().string() + "_overlay.png") : o.overlay;
  if (r.overlay_png.has_parent_path()) EnsureOutputDir(r.overlay_png.parent_path());
  WriteLdr(r.overlay_png, canvas.ToImage());
  Report(progress, 1.0, "done");
  return r;
}

}  // namespace shadowsg
