#include "stages/io/capture_manifest_io.h"

#include <cmath>
#include <cstdio>
#include <initializer_list>

#include "calib/error.h"

namespace shadowsg {
namespace fs = std::filesystem;

namespace {

enum class Kind { kFile, kFolder };

// A misspelt key would otherwise be ignored silently and its default used.
void CheckKeys(const JsonReader& r, std::initializer_list<const char*> allowed) {
  if (!r.node().is_object()) r.Fail("", "expected an object");
  for (const auto& [key, value] : r.node().items()) {
    bool known = false;
    for (const char* a : allowed) known |= key == a;
    if (known) continue;
    std::string list;
    for (const char* a : allowed) list += (list.empty() ? "" : ", ") + std::string(a);
    r.Fail(key, "unknown key (known: " + list + ")");
  }
}

fs::path Resolve(const fs::path& dir, const std::string& text) {
  const fs::path p(text);
  return p.is_absolute() ? p : (dir / p).lexically_normal();
}

// A path that must exist; the error names the key and the resolved path.
fs::path ExistingPath(const JsonReader& r, const std::string& key, const fs::path& dir, Kind kind) {
  const std::string text = r.String(key);
  if (text.empty()) r.Fail(key, "empty path");
  const fs::path p = Resolve(dir, text);
  std::error_code ec;
  if (kind == Kind::kFolder && !fs::is_directory(p, ec)) r.Fail(key, "folder not found: " + p.string());
  if (kind == Kind::kFile && !fs::is_regular_file(p, ec)) r.Fail(key, "file not found: " + p.string());
  return p;
}

std::optional<int> OptionalInt(const JsonReader& r, const std::string& key, int min) {
  if (!r.Has(key)) return std::nullopt;
  const int v = r.Int(key);
  if (v < min) r.Fail(key, "must be at least " + std::to_string(min));
  return v;
}

std::optional<double> OptionalPositive(const JsonReader& r, const std::string& key) {
  if (!r.Has(key)) return std::nullopt;
  const double v = r.Number(key);
  if (!(v > 0)) r.Fail(key, "must be positive");
  return v;
}

std::string OneOf(const JsonReader& r, const std::string& key, std::initializer_list<const char*> values) {
  if (!r.Has(key)) return "";
  const std::string v = r.String(key);
  std::string list;
  for (const char* a : values) {
    if (v == a) return v;
    list += (list.empty() ? "" : ", ") + std::string(a);
  }
  r.Fail(key, "expected one of " + list + ", got \"" + v + "\"");
}

// [r, g, b] or one grey value.
Eigen::Vector3d Rgb(const JsonReader& r, const std::string& key) {
  const Json& j = r.node().at(key);
  if (j.is_number()) {
    const double v = j.get<double>();
    if (!(v > 0 && v <= 1)) r.Fail(key, "albedo must be in (0, 1]");
    return Eigen::Vector3d::Constant(v);
  }
  const Eigen::Vector3d v = r.Vec3(key);
  if (!(v.minCoeff() > 0 && v.maxCoeff() <= 1)) r.Fail(key, "albedo must be in (0, 1]");
  return v;
}

// "0.5", 0.5 or "1/250" -> seconds; `key` names the element ("times[2]").
double Seconds(const JsonReader& r, const Json& j, const std::string& key) {
  if (j.is_number() && j.get<double>() > 0) return j.get<double>();
  if (j.is_string()) {
    double num = 0, den = 1;
    char slash = 0, extra = 0;
    const std::string s = j.get<std::string>();
    const int n = std::sscanf(s.c_str(), "%lf%c%lf%c", &num, &slash, &den, &extra);
    if ((n == 1 || (n == 3 && slash == '/')) && num > 0 && den > 0) return num / den;
  }
  r.Fail(key, "expected a positive time in seconds (a number, or a string like \"1/250\")");
}

void ParseIntrinsics(const JsonReader& r, const fs::path& dir, CaptureManifest::Intrinsics* o) {
  CheckKeys(r, {"camera", "images", "board", "square", "detector", "fix_aspect", "fix_principal_point",
                "zero_tangential", "fix_k3", "max_view_rms", "min_views"});
  if (r.Has("camera")) {
    if (r.Has("images")) r.Fail("images", "give either a camera.json (\"camera\") or checkerboard photos, not both");
    o->camera = ExistingPath(r, "camera", dir, Kind::kFile);
    return;
  }
  if (!r.Has("images")) r.Fail("images", "missing key (checkerboard photos, or \"camera\": a camera.json)");
  o->images = ExistingPath(r, "images", dir, Kind::kFolder);
  if (!r.Has("board")) r.Fail("board", "missing key (inner corners, e.g. \"9x6\")");
  const Json& b = r.node().at("board");
  int cols = 0, rows = 0;
  if (b.is_string()) {
    char x = 0, extra = 0;
    const std::string s = b.get<std::string>();
    if (std::sscanf(s.c_str(), "%d%c%d%c", &cols, &x, &rows, &extra) != 3 || (x != 'x' && x != 'X')) cols = 0;
  } else if (b.is_array() && b.size() == 2 && b[0].is_number_integer() && b[1].is_number_integer()) {
    cols = b[0].get<int>();
    rows = b[1].get<int>();
  }
  if (cols < 2 || rows < 2) r.Fail("board", "expected inner corners \"COLSxROWS\" or [COLS, ROWS], each at least 2");
  o->cols = cols;
  o->rows = rows;
  o->square = OptionalPositive(r, "square");
  o->max_view_rms = r.Has("max_view_rms") ? std::optional<double>(r.Number("max_view_rms")) : std::nullopt;
  if (o->max_view_rms && *o->max_view_rms < 0) r.Fail("max_view_rms", "must be 0 (automatic) or positive");
  o->min_views = OptionalInt(r, "min_views", 1);
  o->detector = OneOf(r, "detector", {"sb", "classic"});
  o->fix_aspect = r.Bool("fix_aspect", false);
  o->fix_principal_point = r.Bool("fix_principal_point", false);
  o->zero_tangential = r.Bool("zero_tangential", false);
  o->fix_k3 = r.Bool("fix_k3", false);
}

void ParseWalkaround(const JsonReader& r, const fs::path& dir, CaptureManifest::Walkaround* o) {
  CheckKeys(r, {"images", "colmap_model", "matcher", "camera_model", "max_image_size", "max_features",
                "min_registered", "plane_threshold_fraction"});
  o->images = ExistingPath(r, "images", dir, Kind::kFolder);
  if (r.Has("colmap_model")) o->colmap_model = ExistingPath(r, "colmap_model", dir, Kind::kFolder);
  o->matcher = OneOf(r, "matcher", {"exhaustive", "sequential"});
  o->camera_model = r.String("camera_model", "");
  o->max_image_size = OptionalInt(r, "max_image_size", 1);
  o->max_features = OptionalInt(r, "max_features", 1);
  o->min_registered = OptionalInt(r, "min_registered", 2);
  o->plane_threshold_fraction = OptionalPositive(r, "plane_threshold_fraction");
}

void ParseHero(const JsonReader& r, const fs::path& dir, const fs::path& walkaround, CaptureManifest::Hero* o) {
  CheckKeys(r, {"photo", "linear", "times", "response", "colour", "wb", "half_size", "align", "undistort"});
  o->photo = ExistingPath(r, "photo", dir, Kind::kFile);
  std::error_code ec;
  if (!fs::equivalent(o->photo.parent_path(), walkaround, ec))
    r.Fail("photo", "must be one of walkaround.images' photos (COLMAP registers the hero among them), got " +
                        o->photo.string());
  if (r.Has("linear")) {
    if (r.node().at("linear").is_string()) {
      o->linear.push_back(ExistingPath(r, "linear", dir, Kind::kFile));
    } else {
      const JsonReader list = r.Child("linear");
      if (!list.node().is_array()) r.Fail("linear", "expected a path or a list of paths");
      if (list.Size() == 0) r.Fail("linear", "empty list");
      for (size_t i = 0; i < list.Size(); ++i) {
        const Json& e = list.node()[i];
        const std::string key = "linear[" + std::to_string(i) + "]";
        if (!e.is_string()) r.Fail(key, "expected a path");
        const fs::path p = Resolve(dir, e.get<std::string>());
        if (!fs::is_regular_file(p, ec)) r.Fail(key, "file not found: " + p.string());
        o->linear.push_back(p);
      }
    }
  }
  if (r.Has("times")) {
    const JsonReader list = r.Child("times");
    if (!list.node().is_array()) r.Fail("times", "expected a list of times, one per linear input");
    for (size_t i = 0; i < list.Size(); ++i)
      o->times.push_back(Seconds(r, list.node()[i], "times[" + std::to_string(i) + "]"));
    const size_t inputs = o->linear.empty() ? 1 : o->linear.size();
    if (o->times.size() != inputs)
      r.Fail("times", std::to_string(o->times.size()) + " times for " + std::to_string(inputs) + " linear input(s)");
  }
  o->response = OneOf(r, "response", {"debevec", "robertson", "srgb"});
  o->colour = OneOf(r, "colour", {"srgb", "camera"});
  o->wb = r.String("wb", "");
  o->half_size = r.Bool("half_size", false);
  o->align = r.Bool("align", false);
  o->undistort = r.Bool("undistort", false);
}

void ParseObject(const JsonReader& r, const fs::path& dir, CaptureManifest::Object* o) {
  CheckKeys(r, {"mesh", "up", "albedo", "snap_to_plane"});
  o->mesh = ExistingPath(r, "mesh", dir, Kind::kFile);
  if (r.Has("up")) o->up = OneOf(r, "up", {"z", "y"});
  if (r.Has("albedo")) o->albedo = Rgb(r, "albedo");
  o->snap_to_plane = r.Bool("snap_to_plane", false);
}

void ParseTags(const JsonReader& r, const fs::path& dir, CaptureManifest::Tags* o) {
  CheckKeys(r, {"family", "size", "id", "offset", "layout"});
  o->family = r.String("family", "");
  if (r.Has("layout")) {
    if (r.Has("offset")) r.Fail("offset", "give either one tag's \"offset\" or a \"layout\", not both");
    o->layout = ExistingPath(r, "layout", dir, Kind::kFile);
  }
  if (r.Has("size")) {
    o->size = r.Number("size");
    if (!(o->size > 0)) r.Fail("size", "must be positive");
  } else if (!o->layout.empty()) {
    // The plane stage scales with one edge for all tags: the layout's default.
    const Json layout = ReadJsonFile(o->layout);
    const JsonReader l(layout, o->layout.string());
    o->size = l.Number("size", 0.0);
  }
  if (!(o->size > 0))
    r.Fail("size", "missing key (the edge of the tags' black border square, for the pose and the plane's scale)");
  o->id = r.Int("id", -1);
  if (r.Has("offset")) o->offset = r.Vec3("offset");
}

void ParsePlane(const JsonReader& r, CaptureManifest::PlaneSettings* o) {
  CheckKeys(r, {"albedo", "paper_albedo", "half_size"});
  if (r.Has("albedo")) {
    const Json& a = r.node().at("albedo");
    if (a.is_string()) {
      o->albedo = OneOf(r, "albedo", {"auto", "tag", "convention"});
    } else {
      o->albedo = "given";
      o->albedo_rgb = Rgb(r, "albedo");
    }
  }
  o->paper_albedo = OptionalPositive(r, "paper_albedo");
  if (r.Has("half_size")) {
    const Eigen::MatrixXd h = r.Matrix("half_size", 1, 2);
    if (!(h.minCoeff() > 0)) r.Fail("half_size", "must be positive");
    o->half_size = Eigen::Vector2d(h(0, 0), h(0, 1));
  }
}

void ParseSolve(const JsonReader& r, CaptureManifest::Solve* o) {
  CheckKeys(r, {"method", "budget", "lobes", "steps", "map_height", "ssdf"});
  o->method = OneOf(r, "method", {"sg", "sg-paper", "ss03", "ss03+", "sh21"});
  o->budget = OneOf(r, "budget", {"fast", "balanced", "best"});
  o->ssdf = OneOf(r, "ssdf", {"exact", "c2f"});
  o->lobes = OptionalInt(r, "lobes", 0);
  o->steps = OptionalInt(r, "steps", 1);
  o->map_height = OptionalInt(r, "map_height", 2);
}

void ParseComposite(const JsonReader& r, const fs::path& dir, CaptureManifest::Composite* o) {
  CheckKeys(r, {"objects", "quality", "spp", "bounces", "supersampling"});
  if (r.Has("objects")) o->objects = ExistingPath(r, "objects", dir, Kind::kFile);
  o->quality = OneOf(r, "quality", {"final", "preview"});
  o->spp = OptionalInt(r, "spp", 1);
  o->bounces = OptionalInt(r, "bounces", 0);
  o->supersampling = OptionalInt(r, "supersampling", 1);
}

// A section of the document: an object.
JsonReader SectionOf(const JsonReader& root, const std::string& key) {
  const JsonReader r = root.Child(key);
  if (!r.node().is_object()) root.Fail(key, "expected an object");
  return r;
}

}  // namespace

CaptureManifest ParseCaptureManifest(const Json& json, const std::string& name, const fs::path& dir) {
  const JsonReader root(json, name);
  if (!json.is_object()) root.Fail("", "expected a JSON object");
  CheckKeys(root, {"format", "intrinsics", "walkaround", "hero", "object", "tags", "plane", "solve", "composite"});
  const std::string format = root.String("format");
  if (format != kCaptureFormat)
    root.Fail("format", "expected \"" + std::string(kCaptureFormat) + "\", got \"" + format + "\"");
  CaptureManifest m;
  m.file = name;
  m.dir = dir;
  m.json = json;
  ParseIntrinsics(SectionOf(root, "intrinsics"), dir, &m.intrinsics);
  ParseWalkaround(SectionOf(root, "walkaround"), dir, &m.walkaround);
  ParseHero(SectionOf(root, "hero"), dir, m.walkaround.images, &m.hero);
  ParseObject(SectionOf(root, "object"), dir, &m.object);
  ParseTags(SectionOf(root, "tags"), dir, &m.tags);
  if (root.Has("plane")) ParsePlane(SectionOf(root, "plane"), &m.plane);
  if (root.Has("solve")) ParseSolve(SectionOf(root, "solve"), &m.solve);
  if (root.Has("composite")) ParseComposite(SectionOf(root, "composite"), dir, &m.composite);
  return m;
}

CaptureManifest ReadCaptureManifest(const fs::path& capture) {
  std::error_code ec;
  if (!fs::exists(capture, ec))
    throw InputError(capture.string(), "not found (a capture folder holding capture.json, or the capture.json)");
  const fs::path file = fs::is_directory(capture, ec) ? capture / "capture.json" : capture;
  return ParseCaptureManifest(ReadJsonFile(file), file.string(), file.parent_path());
}

}  // namespace shadowsg
