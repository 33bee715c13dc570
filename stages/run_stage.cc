#include "stages/run_stage.h"

#include <algorithm>
#include <cstdio>
#include <functional>
#include <optional>
#include <sstream>

#include "calib/error.h"
#include "stages/composite_stage.h"
#include "stages/intrinsics_stage.h"
#include "stages/io/atomic_file.h"
#include "stages/io/capture_manifest_io.h"
#include "stages/linearize_stage.h"
#include "stages/plane_stage.h"
#include "stages/pose_stage.h"
#include "stages/register_stage.h"
#include "stages/solve_stage.h"
#include "stages/stage_util.h"

namespace shadowsg {
namespace fs = std::filesystem;

namespace {

// One stage as RunCapture sees it: what decides whether it is up to date,
// what it reads from, and how to run it.
struct PlannedStage {
  std::string name;
  std::string off_status;  // non-empty: not run ("given": capture.json names the file; "off")
  std::string off_reason;
  StageRecord record;
  std::vector<std::string> reads_from;  // earlier stages whose outputs are inputs
  std::vector<std::pair<std::string, fs::path>> artifacts;
  std::function<void()> run;
};

// The keys of a capture.json section that configure a stage (absent keys stay absent).
Json Pick(const Json& doc, const std::string& section, std::initializer_list<const char*> keys) {
  Json out = Json::object();
  if (!doc.contains(section) || !doc[section].is_object()) return out;
  for (const char* k : keys)
    if (doc[section].contains(k)) out[k] = doc[section][k];
  return out;
}

Json Section(const Json& doc, const std::string& section) {
  return doc.contains(section) ? doc[section] : Json::object();
}

// Paths in the stamp are relative to the capture folder, so that a run from
// another working directory (or a moved capture) still matches.
Json RelativeNames(const std::vector<fs::path>& files, const fs::path& base) {
  Json out = Json::array();
  for (const auto& f : files) {
    const fs::path rel = fs::absolute(f).lexically_normal().lexically_relative(fs::absolute(base).lexically_normal());
    out.push_back(rel.empty() ? f.generic_string() : rel.generic_string());
  }
  return out;
}

std::vector<fs::path> FilesUnder(const fs::path& dir) {
  std::vector<fs::path> out;
  std::error_code ec;
  for (const auto& e : fs::recursive_directory_iterator(dir, ec))
    if (e.is_regular_file(ec)) out.push_back(e.path());
  std::sort(out.begin(), out.end());
  return out;
}

// The meshes an objects file names (best effort: a bad file is the composite
// stage's to report).
std::vector<fs::path> ObjectsFileMeshes(const fs::path& objects) {
  std::vector<fs::path> out;
  try {
    const Json j = ReadJsonFile(objects);
    if (j.contains("objects") && j["objects"].is_array())
      for (const auto& o : j["objects"])
        if (o.is_object() && o.contains("path_to_mesh") && o["path_to_mesh"].is_string())
          out.push_back(objects.parent_path() / o["path_to_mesh"].get<std::string>());
  } catch (const InputError&) {
  }
  return out;
}

std::string Fixed(double v, int digits) {
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.*f", digits, v);
  return buf;
}

}  // namespace

// ---- Resuming ----------------------------------------------------------------

std::string StaleReason(const StageRecord& record, const fs::path& stamp) {
  std::error_code ec;
  if (!fs::is_regular_file(stamp, ec)) return "not run before";
  Json old;
  try {
    old = ReadJsonFile(stamp);
  } catch (const InputError&) {
    return "its stamp is unreadable";
  }
  if (!old.contains("settings") || old["settings"] != record.settings) {
    std::string changed;
    if (old.contains("settings") && old["settings"].is_object() && record.settings.is_object()) {
      for (const auto& [k, v] : record.settings.items())
        if (!old["settings"].contains(k) || old["settings"][k] != v) changed += (changed.empty() ? "" : ", ") + k;
      for (const auto& [k, v] : old["settings"].items())
        if (!record.settings.contains(k)) changed += (changed.empty() ? "" : ", ") + k;
    }
    return "settings changed" + (changed.empty() ? std::string() : " (" + changed + ")");
  }
  std::optional<fs::file_time_type> oldest_output;
  for (const auto& out : record.outputs) {
    const auto t = fs::last_write_time(out, ec);
    if (ec) return "output missing: " + out.string();
    if (!oldest_output || t < *oldest_output) oldest_output = t;
  }
  for (const auto& in : record.inputs) {
    const auto t = fs::last_write_time(in, ec);
    if (ec) return "input missing: " + in.string();
    if (oldest_output && t > *oldest_output) return "input changed: " + in.string();
  }
  return "";
}

void WriteStamp(const StageRecord& record, const fs::path& stamp, double seconds) {
  Json outputs = Json::array();
  for (const auto& o : record.outputs) outputs.push_back(o.string());
  if (stamp.has_parent_path()) EnsureOutputDir(stamp.parent_path());
  WriteJsonFile(stamp, Json{{"settings", record.settings}, {"outputs", outputs}, {"seconds", seconds}});
}

// ---- The run ---------------------------------------------------------------------

std::string RunCaptureOptions::Validate() const {
  if (capture.empty()) return "CAPTURE_DIR: the capture folder is required";
  for (const auto& f : force) {
    const auto& names = RunStageNames();
    if (f != "all" && std::find(names.begin(), names.end(), f) == names.end()) {
      std::string list;
      for (const auto& n : names) list += n + ", ";
      return "--force: unknown stage \"" + f + "\" (" + list + "or all)";
    }
  }
  return "";
}

const RunStageReport& RunCaptureResult::Stage(const std::string& name) const {
  const auto it = std::find_if(stages.begin(), stages.end(), [&](const RunStageReport& s) { return s.name == name; });
  SHADOWSG_CHECK(it != stages.end());
  return *it;
}

RunCaptureResult RunCapture(const RunCaptureOptions& options, const StageContext& ctx) {
  const Stopwatch clock;
  if (const std::string e = options.Validate(); !e.empty()) throw InputError("", e);
  const CaptureManifest m = ReadCaptureManifest(options.capture);
  const Json& doc = m.json;
  const fs::path out = options.out.empty() ? m.dir / "shadowsg" : options.out;
  EnsureOutputDir(out);
  const fs::path stamps = out / "stamps";
  const Json seed = std::to_string(ctx.seed);  // a string: any 64-bit seed compares exactly

  // Where everything goes.
  const fs::path camera_json = m.intrinsics.camera.empty() ? out / "camera.json" : m.intrinsics.camera;
  const fs::path linear = out / "linear.exr";
  const fs::path linear_camera = out / "linear_camera.json";
  const fs::path register_camera = m.hero.undistort ? linear_camera : camera_json;
  const fs::path plane_json = out / "plane.json", pose_json = out / "pose.json";
  const fs::path scene = out / "scene", solve = out / "solve", composite = out / "composite";
  const std::vector<fs::path> scene_files = {scene / "scene.json", scene / "image.exr", scene / "mask.png",
                                             scene / "geometry" / "mesh.obj"};
  const std::string method = m.solve.method.empty() ? SolveOptions().method : m.solve.method;
  const bool sg_lighting = method == "sg" || method == "sg-paper";
  const fs::path lighting = solve / (sg_lighting ? "lighting.json" : "envmap.exr");

  std::vector<PlannedStage> plan;
  auto add = [&](PlannedStage s) {
    // The list of inputs is a setting too: a photo added or removed changes it.
    if (s.off_status.empty()) s.record.settings["inputs"] = RelativeNames(s.record.inputs, m.dir);
    plan.push_back(std::move(s));
  };

  {  // intrinsics
    PlannedStage s;
    s.name = "intrinsics";
    if (!m.intrinsics.camera.empty()) {
      s.off_status = "given";
      s.off_reason = "capture.json names a camera.json";
      s.artifacts = {{"camera", camera_json}};
    } else {
      const fs::path coverage = out / "camera_coverage.png";
      s.record.settings = {{"intrinsics", Section(doc, "intrinsics")}};
      s.record.inputs = ListImages(m.intrinsics.images);
      s.record.outputs = {camera_json, coverage};
      s.artifacts = {{"camera", camera_json}, {"coverage", coverage}};
      s.run = [&m, camera_json, &ctx] {
        IntrinsicsStageOptions o;
        o.images = m.intrinsics.images;
        o.out = camera_json;
        o.calibration.cols = m.intrinsics.cols;
        o.calibration.rows = m.intrinsics.rows;
        if (m.intrinsics.square) o.calibration.square = *m.intrinsics.square;
        if (m.intrinsics.max_view_rms) o.calibration.max_view_rms_px = *m.intrinsics.max_view_rms;
        if (m.intrinsics.min_views) o.calibration.min_views = *m.intrinsics.min_views;
        o.calibration.fix_aspect = m.intrinsics.fix_aspect;
        o.calibration.fix_principal_point = m.intrinsics.fix_principal_point;
        o.calibration.zero_tangential = m.intrinsics.zero_tangential;
        o.calibration.fix_k3 = m.intrinsics.fix_k3;
        if (m.intrinsics.detector == "classic") o.detector = CornerDetector::kClassic;
        if (m.intrinsics.detector == "sb") o.detector = CornerDetector::kSectorBased;
        RunIntrinsicsStage(o, ctx);
      };
    }
    add(std::move(s));
  }

  {  // linearize
    PlannedStage s;
    s.name = "linearize";
    const std::vector<fs::path> inputs = m.hero.linear.empty() ? std::vector<fs::path>{m.hero.photo} : m.hero.linear;
    s.record.settings = {{"hero", Pick(doc, "hero", {"linear", "times", "response", "colour", "wb", "half_size",
                                                     "align", "undistort"})}};
    s.record.inputs = inputs;
    s.record.outputs = {linear, out / "linear_clipped.png", out / "linear_preview.png",
                        out / "linear_linearize.json"};
    if (m.hero.undistort) {
      s.record.inputs.push_back(camera_json);
      s.record.outputs.push_back(linear_camera);
      s.reads_from = {"intrinsics"};
    }
    s.artifacts = {{"linear", linear}, {"clipped", out / "linear_clipped.png"}, {"preview", out / "linear_preview.png"},
                   {"report", out / "linear_linearize.json"}};
    if (m.hero.undistort) s.artifacts.push_back({"camera", linear_camera});
    s.run = [&m, inputs, linear, camera_json, &ctx] {
      LinearizeStageOptions o;
      o.inputs = inputs;
      o.out = linear;
      o.times = m.hero.times;
      o.align = m.hero.align;
      o.raw.half_size = m.hero.half_size;
      if (m.hero.undistort) o.undistort = camera_json;
      if (m.hero.colour == "camera") o.raw.colour = RawColourSpace::kCamera;
      if (m.hero.colour == "srgb") o.raw.colour = RawColourSpace::kSrgb;
      if (m.hero.response == "debevec") o.stack.method = ResponseMethod::kDebevec;
      if (m.hero.response == "robertson") o.stack.method = ResponseMethod::kRobertson;
      if (m.hero.response == "srgb") o.stack.method = ResponseMethod::kSrgb;
      if (!m.hero.wb.empty()) {
        const std::string& wb = m.hero.wb;
        if (wb == "as-shot") {
          o.raw.white_balance = WhiteBalanceMode::kAsShot;
        } else if (wb == "daylight") {
          o.raw.white_balance = WhiteBalanceMode::kDaylight;
        } else if (wb == "none") {
          o.raw.white_balance = WhiteBalanceMode::kNone;
        } else {
          double r = 0, g = 0, b = 0;
          char extra = 0;
          if (std::sscanf(wb.c_str(), "%lf,%lf,%lf%c", &r, &g, &b, &extra) != 3 || !(r > 0 && g > 0 && b > 0))
            throw InputError(m.file.string(), "hero.wb: expected as-shot, daylight, none or \"R,G,B\", got \"" + wb +
                                                  "\"");
          o.raw.white_balance = WhiteBalanceMode::kUser;
          o.raw.user_wb[0] = r;
          o.raw.user_wb[1] = g;
          o.raw.user_wb[2] = b;
        }
      }
      RunLinearizeStage(o, ctx);
    };
    add(std::move(s));
  }

  {  // plane
    PlannedStage s;
    s.name = "plane";
    s.record.settings = {{"walkaround", Section(doc, "walkaround")},
                         {"hero", Pick(doc, "hero", {"photo"})},
                         {"tags", Pick(doc, "tags", {"size", "family", "id"})},
                         {"seed", seed}};
    if (m.walkaround.colmap_model.empty())
      for (const auto& name : ListPhotos(m.walkaround.images)) s.record.inputs.push_back(m.walkaround.images / name);
    else
      s.record.inputs = FilesUnder(m.walkaround.colmap_model);
    s.record.inputs.push_back(camera_json);
    s.record.outputs = {plane_json};
    s.reads_from = {"intrinsics"};
    s.artifacts = {{"plane", plane_json}, {"colmap", out / "plane_colmap"}};
    s.run = [&m, plane_json, camera_json, &ctx] {
      PlaneStageOptions o;
      o.images = m.walkaround.images;
      o.colmap_model = m.walkaround.colmap_model;
      o.hero = m.hero.photo.filename().string();
      o.out = plane_json;
      o.camera = camera_json;
      if (!m.walkaround.matcher.empty()) o.matcher = m.walkaround.matcher;
      if (!m.walkaround.camera_model.empty()) o.camera_model = m.walkaround.camera_model;
      if (m.walkaround.max_image_size) o.max_image_size = *m.walkaround.max_image_size;
      if (m.walkaround.max_features) o.max_features = *m.walkaround.max_features;
      if (m.walkaround.min_registered) o.min_registered = *m.walkaround.min_registered;
      if (m.walkaround.plane_threshold_fraction) o.threshold_fraction = *m.walkaround.plane_threshold_fraction;
      o.tag_size = m.tags.size;
      if (!m.tags.family.empty()) o.tag_family = m.tags.family;
      o.tag_id = m.tags.id;
      RunPlaneStage(o, ctx);
    };
    add(std::move(s));
  }

  {  // pose
    PlannedStage s;
    s.name = "pose";
    const fs::path overlay = out / "pose_overlay.png";
    s.record.settings = {{"hero", Pick(doc, "hero", {"photo"})},
                         {"tags", Section(doc, "tags")},
                         {"object", Pick(doc, "object", {"mesh", "up"})}};
    s.record.inputs = {m.hero.photo, camera_json, m.object.mesh};
    if (!m.tags.layout.empty()) s.record.inputs.push_back(m.tags.layout);
    s.record.outputs = {pose_json, overlay};
    s.reads_from = {"intrinsics"};
    s.artifacts = {{"pose", pose_json}, {"overlay", overlay}};
    s.run = [&m, pose_json, camera_json, &ctx] {
      PoseStageOptions o;
      o.image = m.hero.photo;
      o.camera = camera_json;
      o.out = pose_json;
      o.mesh = m.object.mesh;
      o.method = PoseMethod::kAprilTag;
      if (!m.tags.family.empty()) o.detector.family = m.tags.family;
      o.tag_size = m.tags.size;
      o.tag_id = m.tags.id;
      o.tag_layout = m.tags.layout;
      if (m.tags.offset) o.offset = *m.tags.offset;
      o.mesh_up = m.object.up == "y" ? MeshUp::kY : MeshUp::kZ;
      RunPoseStage(o, ctx);
    };
    add(std::move(s));
  }

  {  // register
    PlannedStage s;
    s.name = "register";
    s.record.settings = {{"object", Section(doc, "object")},
                         {"plane", Section(doc, "plane")},
                         {"tags", Pick(doc, "tags", {"family"})},
                         {"hero", Pick(doc, "hero", {"undistort"})}};
    s.record.inputs = {register_camera, linear, out / "linear_clipped.png", plane_json, pose_json, m.object.mesh};
    s.record.outputs = scene_files;
    s.reads_from = {"intrinsics", "linearize", "plane", "pose"};
    s.artifacts = {{"scene", scene / "scene.json"}, {"image", scene / "image.exr"}, {"mask", scene / "mask.png"},
                   {"mask preview", scene / "mask_preview.png"}};
    s.run = [&m, register_camera, linear, plane_json, pose_json, scene, &ctx] {
      RegisterStageOptions o;
      o.camera = register_camera;
      o.image = linear;
      o.plane = plane_json;
      o.pose = pose_json;
      o.mesh = m.object.mesh;
      o.out = scene;
      const std::string& a = m.plane.albedo;
      o.albedo_mode = a == "tag"          ? AlbedoMode::kTag
                      : a == "convention" ? AlbedoMode::kConvention
                      : a == "given"      ? AlbedoMode::kGiven
                                          : AlbedoMode::kAuto;
      if (a == "given") o.albedo = m.plane.albedo_rgb;
      if (m.plane.paper_albedo) o.paper_albedo = *m.plane.paper_albedo;
      o.plane_half_size = m.plane.half_size;
      if (m.object.albedo) o.object_albedo = *m.object.albedo;
      if (!m.tags.family.empty()) o.tag_family = m.tags.family;
      o.snap_to_plane = m.object.snap_to_plane;
      RunRegisterStage(o, ctx);
    };
    add(std::move(s));
  }

  {  // solve
    PlannedStage s;
    s.name = "solve";
    s.record.settings = {{"solve", Section(doc, "solve")}, {"seed", seed}};
    s.record.inputs = scene_files;
    s.record.outputs = {solve / "render.exr", solve / "metrics.json"};
    if (sg_lighting) s.record.outputs.push_back(lighting);
    s.reads_from = {"register"};
    s.artifacts = {{"lighting", lighting},
                   {"render", solve / "render.exr"},
                   {"error", solve / "error.png"},
                   {"metrics", solve / "metrics.json"}};
    if (sg_lighting) s.artifacts.push_back({"envmap", solve / "envmap.exr"});
    s.run = [&m, scene, solve, method, &ctx] {
      SolveOptions o;
      o.method = method;
      if (!m.solve.budget.empty()) o.budget = m.solve.budget;
      if (!m.solve.ssdf.empty()) o.ssdf = m.solve.ssdf;
      if (m.solve.lobes) o.lobes = *m.solve.lobes;
      if (m.solve.steps) o.steps = *m.solve.steps;
      if (m.solve.map_height) o.map_height = *m.solve.map_height;
      RunSolve(scene, solve, o, ctx);
    };
    add(std::move(s));
  }

  {  // composite
    PlannedStage s;
    s.name = "composite";
    if (m.composite.objects.empty()) {
      s.off_status = "off";
      s.off_reason = "no virtual objects (capture.json: composite.objects)";
    } else {
      s.record.settings = {{"composite", Section(doc, "composite")}, {"seed", seed}};
      s.record.inputs = scene_files;
      s.record.inputs.push_back(lighting);
      s.record.inputs.push_back(m.composite.objects);
      for (const auto& mesh : ObjectsFileMeshes(m.composite.objects)) s.record.inputs.push_back(mesh);
      s.record.outputs = {composite / "composite.exr", composite / "metrics.json"};
      s.reads_from = {"register", "solve"};
      s.artifacts = {{"composite", composite / "composite.exr"},
                     {"composite png", composite / "composite.png"},
                     {"shadow layer", composite / "shadow.exr"},
                     {"objects layer", composite / "objects.exr"},
                     {"side by side", composite / "side_by_side.png"},
                     {"metrics", composite / "metrics.json"}};
      s.run = [&m, scene, composite, lighting, &ctx] {
        CompositeStageOptions o;
        o.lighting = lighting;
        o.objects = m.composite.objects;
        if (m.composite.quality == "preview") o.composite.quality = CompositeQuality::kPreview;
        if (m.composite.quality == "final") o.composite.quality = CompositeQuality::kFinal;
        if (m.composite.spp) o.composite.samples_per_pixel = *m.composite.spp;
        if (m.composite.bounces) o.composite.max_bounces = *m.composite.bounces;
        if (m.composite.supersampling) o.composite.supersampling = *m.composite.supersampling;
        RunComposite(scene, composite, o, ctx);
      };
    }
    add(std::move(s));
  }

  // Run, skip or leave off each stage in order.
  RunCaptureResult result;
  result.out_dir = out;
  result.summary_json = out / "run_summary.json";
  auto forced = [&](const std::string& name) {
    return std::find(options.force.begin(), options.force.end(), name) != options.force.end() ||
           std::find(options.force.begin(), options.force.end(), "all") != options.force.end();
  };
  auto write_summary = [&] {
    Json stages = Json::array();
    for (const auto& s : result.stages) {
      Json artifacts = Json::object();
      for (const auto& [what, path] : s.artifacts) artifacts[what] = path.string();
      stages.push_back({{"stage", s.name},
                        {"status", s.status},
                        {"reason", s.reason},
                        {"seconds", s.seconds},
                        {"artifacts", artifacts}});
    }
    WriteJsonFile(result.summary_json, Json{{"format", "run-summary/1"},
                                            {"capture", m.file.string()},
                                            {"out", out.string()},
                                            {"seconds", clock.Seconds()},
                                            {"stages", stages}});
  };
  std::vector<std::string> redone;
  const int total = static_cast<int>(plan.size());
  for (int i = 0; i < total; ++i) {
    PlannedStage& s = plan[i];
    RunStageReport report;
    report.name = s.name;
    report.artifacts = s.artifacts;
    const std::string step = "[" + std::to_string(i + 1) + "/" + std::to_string(total) + "] " + s.name + ": ";
    if (!s.off_status.empty()) {
      report.status = s.off_status;
      report.reason = s.off_reason;
      ctx.Log(step + s.off_status + ", " + s.off_reason);
      result.stages.push_back(report);
      continue;
    }
    const fs::path stamp = stamps / (s.name + ".json");
    std::string why = forced(s.name) ? "forced (--force)" : StaleReason(s.record, stamp);
    for (const auto& up : s.reads_from)
      if (why.empty() && std::find(redone.begin(), redone.end(), up) != redone.end()) why = up + " was redone";
    if (why.empty()) {
      report.status = "skipped";
      report.reason = "up to date";
      ctx.Log(step + "up to date, skipped");
      result.stages.push_back(report);
      continue;
    }
    ctx.Log(step + "running (" + why + ")");
    // Without its stamp, a stage interrupted half-way is redone next time.
    std::error_code ec;
    fs::remove(stamp, ec);
    const Stopwatch stage_clock;
    try {
      s.run();
    } catch (const std::exception& e) {
      report.status = "failed";
      report.reason = e.what();
      report.seconds = stage_clock.Seconds();
      result.stages.push_back(report);
      write_summary();
      throw;
    }
    report.status = "ran";
    report.reason = why;
    report.seconds = stage_clock.Seconds();
    WriteStamp(s.record, stamp, report.seconds);
    redone.push_back(s.name);
    ctx.Log(step + "done in " + Fixed(report.seconds, 1) + " s");
    result.stages.push_back(report);
  }
  result.seconds = clock.Seconds();
  write_summary();
  return result;
}

std::string FormatRunSummary(const RunCaptureResult& r) {
  std::ostringstream s;
  char line[512];
  std::snprintf(line, sizeof line, "%-11s %-8s %8s  %s\n", "stage", "status", "seconds", "artifacts");
  s << line;
  for (const auto& st : r.stages) {
    const std::string secs = st.status == "ran" ? Fixed(st.seconds, 1) : "-";
    if (st.artifacts.empty()) {
      std::snprintf(line, sizeof line, "%-11s %-8s %8s  (%s)\n", st.name.c_str(), st.status.c_str(), secs.c_str(),
                    st.reason.c_str());
      s << line;
      continue;
    }
    for (size_t k = 0; k < st.artifacts.size(); ++k) {
      const std::string what = st.artifacts[k].first + ":";
      std::snprintf(line, sizeof line, "%-11s %-8s %8s  %-14s %s\n", k ? "" : st.name.c_str(),
                    k ? "" : st.status.c_str(), k ? "" : secs.c_str(), what.c_str(),
                    st.artifacts[k].second.string().c_str());
      s << line;
    }
  }
  std::snprintf(line, sizeof line, "total %.1f s; summary in %s\n", r.seconds, r.summary_json.string().c_str());
  s << line;
  return s.str();
}

}  // namespace shadowsg
