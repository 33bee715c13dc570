#include "calib/colmap_model.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>

#include "calib/error.h"

namespace shadowsg {
namespace fs = std::filesystem;

namespace {

static_assert(std::endian::native == std::endian::little, "COLMAP's binary models are little-endian");

struct ModelInfo {
  int id;
  const char* name;
  int params;
};
// camera_models.h @3.8.
constexpr ModelInfo kModels[] = {
    {0, "SIMPLE_PINHOLE", 3},        {1, "PINHOLE", 4},           {2, "SIMPLE_RADIAL", 4},
    {3, "RADIAL", 5},                {4, "OPENCV", 8},            {5, "OPENCV_FISHEYE", 8},
    {6, "FULL_OPENCV", 12},          {7, "FOV", 5},               {8, "SIMPLE_RADIAL_FISHEYE", 4},
    {9, "RADIAL_FISHEYE", 5},        {10, "THIN_PRISM_FISHEYE", 12},
};

// Guards against absurd counts in a corrupt file before allocating.
constexpr uint64_t kMaxCount = uint64_t{1} << 31;

template <typename T>
T ReadBinary(std::istream& in, const std::string& name, const char* what) {
  T v{};
  in.read(reinterpret_cast<char*>(&v), sizeof(T));
  if (!in) throw InputError(name, std::string("truncated file (reading ") + what + ")");
  return v;
}

template <typename T>
void WriteBinary(std::ostream& out, T v) {
  out.write(reinterpret_cast<const char*>(&v), sizeof(T));
}

uint64_t ReadCount(std::istream& in, const std::string& name, const char* what) {
  const uint64_t n = ReadBinary<uint64_t>(in, name, what);
  if (n > kMaxCount) throw InputError(name, std::string("implausible ") + what + " " + std::to_string(n));
  return n;
}

// Text lines without comments and blank lines; `line_no` follows the file.
bool NextContentLine(std::istream& in, std::string* line, int* line_no) {
  while (std::getline(in, *line)) {
    ++*line_no;
    const size_t start = line->find_first_not_of(" \t\r");
    if (start == std::string::npos || (*line)[start] == '#') continue;
    return true;
  }
  return false;
}

std::string Trim(const std::string& s) {
  const size_t a = s.find_first_not_of(" \t\r\n");
  if (a == std::string::npos) return "";
  const size_t b = s.find_last_not_of(" \t\r\n");
  return s.substr(a, b - a + 1);
}

[[noreturn]] void TextFail(const std::string& name, int line_no, const std::string& problem) {
  throw InputError(name + ":" + std::to_string(line_no), problem);
}

void CheckParams(const ColmapCamera& c, const std::string& where) {
  const int n = ColmapModelParamCount(c.model);
  if (n < 0) throw InputError(where, "unknown camera model \"" + c.model + "\"");
  if (static_cast<int>(c.params.size()) != n)
    throw InputError(where, c.model + " takes " + std::to_string(n) + " parameters, got " +
                                std::to_string(c.params.size()));
}

// What a reader accepts beyond the layout: a camera with a sensible size and
// finite parameters, a pose with a finite, non-zero quaternion, a finite point.
constexpr uint64_t kMaxSide = 1 << 20;

void CheckCamera(const ColmapCamera& c, const std::string& where) {
  const std::string cam = "camera " + std::to_string(c.id) + ": ";
  if (c.width < 1 || c.height < 1 || c.width > kMaxSide || c.height > kMaxSide)
    throw InputError(where, cam + "image size " + std::to_string(c.width) + "x" + std::to_string(c.height) +
                                " is not between 1 and 1048576");
  for (double p : c.params)
    if (!std::isfinite(p)) throw InputError(where, cam + "non-finite parameter");
}

void CheckPose(const ColmapImage& im, const std::string& where) {
  const std::string what = "image " + std::to_string(im.id) + ": ";
  if (!im.pose.qvec.allFinite() || !im.pose.tvec.allFinite())
    throw InputError(where, what + "non-finite quaternion or translation");
  if (im.pose.qvec.norm() < 1e-12) throw InputError(where, what + "zero quaternion");
}

}  // namespace

int ColmapModelParamCount(const std::string& model) {
  for (const auto& m : kModels)
    if (model == m.name) return m.params;
  return -1;
}

int ColmapModelId(const std::string& model) {
  for (const auto& m : kModels)
    if (model == m.name) return m.id;
  return -1;
}

std::string ColmapModelName(int model_id) {
  for (const auto& m : kModels)
    if (model_id == m.id) return m.name;
  return "";
}

const ColmapImage* ColmapModel::FindImage(const std::string& name) const {
  for (const auto& [id, image] : images)
    if (image.name == name) return &image;
  const ColmapImage* found = nullptr;
  for (const auto& [id, image] : images)
    if (fs::path(image.name).filename() == fs::path(name).filename()) {
      if (found) return nullptr;  // ambiguous
      found = &image;
    }
  return found;
}

const ColmapPoint3D* ColmapModel::FindPoint(colmap_point3D_t id) const {
  const auto it = std::lower_bound(points.begin(), points.end(), id,
                                   [](const ColmapPoint3D& p, colmap_point3D_t v) { return p.id < v; });
  if (it != points.end() && it->id == id) return &*it;
  for (const auto& p : points)  // not sorted
    if (p.id == id) return &p;
  return nullptr;
}

// ---- Binary -------------------------------------------------------------------

void ReadColmapCamerasBinary(std::istream& in, const std::string& name, ColmapModel* model) {
  const uint64_t n = ReadCount(in, name, "camera count");
  for (uint64_t i = 0; i < n; ++i) {
    ColmapCamera c;
    c.id = ReadBinary<uint32_t>(in, name, "camera id");
    const int model_id = ReadBinary<int32_t>(in, name, "camera model");
    c.model = ColmapModelName(model_id);
    if (c.model.empty())
      throw InputError(name, "camera " + std::to_string(c.id) + ": unknown model id " + std::to_string(model_id));
    c.width = ReadBinary<uint64_t>(in, name, "camera width");
    c.height = ReadBinary<uint64_t>(in, name, "camera height");
    c.params.resize(ColmapModelParamCount(c.model));
    for (double& p : c.params) p = ReadBinary<double>(in, name, "camera parameters");
    CheckCamera(c, name);
    model->cameras[c.id] = std::move(c);
  }
}

void ReadColmapImagesBinary(std::istream& in, const std::string& name, ColmapModel* model) {
  const uint64_t n = ReadCount(in, name, "image count");
  for (uint64_t i = 0; i < n; ++i) {
    ColmapImage im;
    im.id = ReadBinary<uint32_t>(in, name, "image id");
    for (int k = 0; k < 4; ++k) im.pose.qvec[k] = ReadBinary<double>(in, name, "qvec");
    for (int k = 0; k < 3; ++k) im.pose.tvec[k] = ReadBinary<double>(in, name, "tvec");
    im.camera_id = ReadBinary<uint32_t>(in, name, "camera id");
    CheckPose(im, name);
    char ch;
    while ((ch = ReadBinary<char>(in, name, "image name")) != '\0') im.name += ch;
    const uint64_t np = ReadCount(in, name, "2D point count");
    im.points2D.reserve(std::min<uint64_t>(np, 1 << 20));
    im.point3D_ids.reserve(std::min<uint64_t>(np, 1 << 20));
    for (uint64_t k = 0; k < np; ++k) {
      const double x = ReadBinary<double>(in, name, "2D points");
      const double y = ReadBinary<double>(in, name, "2D points");
      im.points2D.emplace_back(x, y);
      im.point3D_ids.push_back(ReadBinary<uint64_t>(in, name, "2D points"));
    }
    model->images[im.id] = std::move(im);
  }
}

void ReadColmapPointsBinary(std::istream& in, const std::string& name, ColmapModel* model) {
  const uint64_t n = ReadCount(in, name, "point count");
  // The count is not trusted for memory: a corrupt one fails at the file's end.
  model->points.reserve(model->points.size() + std::min<uint64_t>(n, 1 << 20));
  for (uint64_t i = 0; i < n; ++i) {
    ColmapPoint3D p;
    p.id = ReadBinary<uint64_t>(in, name, "point id");
    for (int k = 0; k < 3; ++k) p.xyz[k] = ReadBinary<double>(in, name, "point xyz");
    if (!p.xyz.allFinite()) throw InputError(name, "point " + std::to_string(p.id) + ": non-finite position");
    for (int k = 0; k < 3; ++k) p.rgb[k] = ReadBinary<uint8_t>(in, name, "point colour");
    p.error = ReadBinary<double>(in, name, "point error");
    const uint64_t nt = ReadCount(in, name, "track length");
    p.track.reserve(std::min<uint64_t>(nt, 1 << 16));
    for (uint64_t k = 0; k < nt; ++k) {
      ColmapTrackElement e;
      e.image_id = ReadBinary<uint32_t>(in, name, "track");
      e.point2D_idx = ReadBinary<uint32_t>(in, name, "track");
      p.track.push_back(e);
    }
    model->points.push_back(std::move(p));
  }
}

void WriteColmapCamerasBinary(std::ostream& out, const ColmapModel& model) {
  WriteBinary<uint64_t>(out, model.cameras.size());
  for (const auto& [id, c] : model.cameras) {
    CheckParams(c, "camera " + std::to_string(id));
    WriteBinary<uint32_t>(out, c.id);
    WriteBinary<int32_t>(out, ColmapModelId(c.model));
    WriteBinary<uint64_t>(out, c.width);
    WriteBinary<uint64_t>(out, c.height);
    for (double p : c.params) WriteBinary<double>(out, p);
  }
}

void WriteColmapImagesBinary(std::ostream& out, const ColmapModel& model) {
  WriteBinary<uint64_t>(out, model.images.size());
  for (const auto& [id, im] : model.images) {
    WriteBinary<uint32_t>(out, im.id);
    for (int k = 0; k < 4; ++k) WriteBinary<double>(out, im.pose.qvec[k]);
    for (int k = 0; k < 3; ++k) WriteBinary<double>(out, im.pose.tvec[k]);
    WriteBinary<uint32_t>(out, im.camera_id);
    out.write(im.name.c_str(), static_cast<std::streamsize>(im.name.size() + 1));
    WriteBinary<uint64_t>(out, im.points2D.size());
    for (size_t k = 0; k < im.points2D.size(); ++k) {
      WriteBinary<double>(out, im.points2D[k].x());
      WriteBinary<double>(out, im.points2D[k].y());
      WriteBinary<uint64_t>(out, im.point3D_ids[k]);
    }
  }
}

void WriteColmapPointsBinary(std::ostream& out, const ColmapModel& model) {
  WriteBinary<uint64_t>(out, model.points.size());
  for (const auto& p : model.points) {
    WriteBinary<uint64_t>(out, p.id);
    for (int k = 0; k < 3; ++k) WriteBinary<double>(out, p.xyz[k]);
    for (int k = 0; k < 3; ++k) WriteBinary<uint8_t>(out, p.rgb[k]);
    WriteBinary<double>(out, p.error);
    WriteBinary<uint64_t>(out, p.track.size());
    for (const auto& e : p.track) {
      WriteBinary<uint32_t>(out, e.image_id);
      WriteBinary<uint32_t>(out, e.point2D_idx);
    }
  }
}

// ---- Text ---------------------------------------------------------------------

void ReadColmapCamerasText(std::istream& in, const std::string& name, ColmapModel* model) {
  std::string line;
  int line_no = 0;
  while (NextContentLine(in, &line, &line_no)) {
    std::istringstream ss(line);
    ColmapCamera c;
    long long width = 0, height = 0;
    if (!(ss >> c.id >> c.model >> width >> height))
      TextFail(name, line_no, "expected CAMERA_ID MODEL WIDTH HEIGHT PARAMS[]");
    c.width = static_cast<uint64_t>(std::max(0LL, width));
    c.height = static_cast<uint64_t>(std::max(0LL, height));
    double p;
    while (ss >> p) c.params.push_back(p);
    if (!ss.eof()) TextFail(name, line_no, "camera parameters must be numbers");
    CheckParams(c, name + ":" + std::to_string(line_no));
    CheckCamera(c, name + ":" + std::to_string(line_no));
    model->cameras[c.id] = std::move(c);
  }
}

void ReadColmapImagesText(std::istream& in, const std::string& name, ColmapModel* model) {
  std::string line;
  int line_no = 0;
  while (NextContentLine(in, &line, &line_no)) {
    std::istringstream ss(line);
    ColmapImage im;
    Eigen::Vector4d& q = im.pose.qvec;
    Eigen::Vector3d& t = im.pose.tvec;
    if (!(ss >> im.id >> q[0] >> q[1] >> q[2] >> q[3] >> t[0] >> t[1] >> t[2] >> im.camera_id))
      TextFail(name, line_no, "expected IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME");
    std::string rest;
    std::getline(ss, rest);
    im.name = Trim(rest);
    if (im.name.empty()) TextFail(name, line_no, "image name missing");
    CheckPose(im, name + ":" + std::to_string(line_no));
    // The next line holds the 2D points (X, Y, POINT3D_ID)*, possibly empty.
    std::string points;
    if (std::getline(in, points)) {
      ++line_no;
      std::istringstream ps(points);
      double x, y;
      std::string id;
      while (ps >> x >> y >> id) {
        im.points2D.emplace_back(x, y);
        if (id == "-1") {
          im.point3D_ids.push_back(kColmapInvalidPoint3D);
        } else {
          try {
            size_t used = 0;
            im.point3D_ids.push_back(std::stoull(id, &used));
            if (used != id.size()) throw std::invalid_argument(id);
          } catch (const std::exception&) {
            TextFail(name, line_no, "bad POINT3D_ID \"" + id + "\"");
          }
        }
      }
      if (!ps.eof()) TextFail(name, line_no, "expected triples X Y POINT3D_ID");
    }
    model->images[im.id] = std::move(im);
  }
}

void ReadColmapPointsText(std::istream& in, const std::string& name, ColmapModel* model) {
  std::string line;
  int line_no = 0;
  while (NextContentLine(in, &line, &line_no)) {
    std::istringstream ss(line);
    ColmapPoint3D p;
    int r, g, b;
    if (!(ss >> p.id >> p.xyz[0] >> p.xyz[1] >> p.xyz[2] >> r >> g >> b >> p.error))
      TextFail(name, line_no, "expected POINT3D_ID X Y Z R G B ERROR TRACK[]");
    if (r < 0 || r > 255 || g < 0 || g > 255 || b < 0 || b > 255) TextFail(name, line_no, "colour outside 0..255");
    p.rgb = {static_cast<uint8_t>(r), static_cast<uint8_t>(g), static_cast<uint8_t>(b)};
    if (!p.xyz.allFinite()) TextFail(name, line_no, "non-finite position");
    std::vector<long long> ids;
    long long v;
    while (ss >> v) ids.push_back(v);
    if (!ss.eof() || ids.size() % 2 != 0) TextFail(name, line_no, "expected pairs IMAGE_ID POINT2D_IDX");
    for (size_t k = 0; k < ids.size(); k += 2) {
      if (ids[k] < 0 || ids[k] > 0xFFFFFFFFLL || ids[k + 1] < 0 || ids[k + 1] > 0xFFFFFFFFLL)
        TextFail(name, line_no, "track ids out of range");
      p.track.push_back({static_cast<colmap_image_t>(ids[k]), static_cast<uint32_t>(ids[k + 1])});
    }
    model->points.push_back(std::move(p));
  }
}

void WriteColmapCamerasText(std::ostream& out, const ColmapModel& model) {
  out.precision(std::numeric_limits<double>::max_digits10);
  out << "# Camera list with one line of data per camera:\n"
      << "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n"
      << "# Number of cameras: " << model.cameras.size() << "\n";
  for (const auto& [id, c] : model.cameras) {
    CheckParams(c, "camera " + std::to_string(id));
    out << c.id << ' ' << c.model << ' ' << c.width << ' ' << c.height;
    for (double p : c.params) out << ' ' << p;
    out << '\n';
  }
}

void WriteColmapImagesText(std::ostream& out, const ColmapModel& model) {
  out.precision(std::numeric_limits<double>::max_digits10);
  out << "# Image list with two lines of data per image:\n"
      << "#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n"
      << "#   POINTS2D[] as (X, Y, POINT3D_ID)\n"
      << "# Number of images: " << model.images.size() << "\n";
  for (const auto& [id, im] : model.images) {
    out << im.id;
    for (int k = 0; k < 4; ++k) out << ' ' << im.pose.qvec[k];
    for (int k = 0; k < 3; ++k) out << ' ' << im.pose.tvec[k];
    out << ' ' << im.camera_id << ' ' << im.name << '\n';
    for (size_t k = 0; k < im.points2D.size(); ++k) {
      if (k) out << ' ';
      out << im.points2D[k].x() << ' ' << im.points2D[k].y() << ' ';
      if (im.point3D_ids[k] == kColmapInvalidPoint3D)
        out << -1;
      else
        out << im.point3D_ids[k];
    }
    out << '\n';
  }
}

void WriteColmapPointsText(std::ostream& out, const ColmapModel& model) {
  out.precision(std::numeric_limits<double>::max_digits10);
  out << "# 3D point list with one line of data per point:\n"
      << "#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)\n"
      << "# Number of points: " << model.points.size() << "\n";
  for (const auto& p : model.points) {
    out << p.id << ' ' << p.xyz[0] << ' ' << p.xyz[1] << ' ' << p.xyz[2] << ' ' << int(p.rgb[0]) << ' '
        << int(p.rgb[1]) << ' ' << int(p.rgb[2]) << ' ' << p.error;
    for (const auto& e : p.track) out << ' ' << e.image_id << ' ' << e.point2D_idx;
    out << '\n';
  }
}

// ---- Folders ------------------------------------------------------------------

namespace {

bool HasAll(const fs::path& dir, const char* ext) {
  std::error_code ec;
  for (const char* stem : {"cameras", "images", "points3D"})
    if (!fs::is_regular_file(dir / (std::string(stem) + ext), ec)) return false;
  return true;
}

template <typename Fn>
void ReadFile(const fs::path& path, bool binary, Fn read) {
  std::ifstream in(path, binary ? std::ios::binary : std::ios::in);
  if (!in) throw InputError(path.string(), "cannot open file");
  read(in, path.string());
}

template <typename Fn>
void WriteFile(const fs::path& path, bool binary, Fn write) {
  std::ofstream out(path, binary ? std::ios::binary | std::ios::trunc : std::ios::trunc);
  if (!out) throw InputError(path.string(), "cannot write file");
  write(out);
  out.flush();
  if (!out) throw InputError(path.string(), "write failed");
}

}  // namespace

bool IsColmapModelDir(const fs::path& dir) { return HasAll(dir, ".bin") || HasAll(dir, ".txt"); }

ColmapModel ReadColmapModel(const fs::path& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw InputError(dir.string(), "COLMAP model folder not found");
  for (const char* rig : {"rigs.bin", "frames.bin", "rigs.txt", "frames.txt"})
    if (fs::exists(dir / rig, ec))
      throw InputError(dir.string(), std::string("holds ") + rig +
                                         ": a COLMAP >= 3.12 rig model, which is not supported (write the model "
                                         "with COLMAP 3.8-3.11, or reconstruct with Debian's colmap 3.8)");
  ColmapModel model;
  if (HasAll(dir, ".bin")) {
    ReadFile(dir / "cameras.bin", true, [&](std::istream& in, const std::string& n) {
      ReadColmapCamerasBinary(in, n, &model);
    });
    ReadFile(dir / "images.bin", true, [&](std::istream& in, const std::string& n) {
      ReadColmapImagesBinary(in, n, &model);
    });
    ReadFile(dir / "points3D.bin", true, [&](std::istream& in, const std::string& n) {
      ReadColmapPointsBinary(in, n, &model);
    });
  } else if (HasAll(dir, ".txt")) {
    ReadFile(dir / "cameras.txt", false, [&](std::istream& in, const std::string& n) {
      ReadColmapCamerasText(in, n, &model);
    });
    ReadFile(dir / "images.txt", false, [&](std::istream& in, const std::string& n) {
      ReadColmapImagesText(in, n, &model);
    });
    ReadFile(dir / "points3D.txt", false, [&](std::istream& in, const std::string& n) {
      ReadColmapPointsText(in, n, &model);
    });
  } else {
    throw InputError(dir.string(),
                     "no COLMAP model here (expected cameras, images and points3D, all .bin or all .txt)");
  }
  for (const auto& [id, im] : model.images) {
    if (model.cameras.count(im.camera_id) == 0)
      throw InputError(dir.string(), "image " + im.name + " refers to camera " + std::to_string(im.camera_id) +
                                         ", which is not in the model");
    if (im.points2D.size() != im.point3D_ids.size()) throw InputError(dir.string(), "inconsistent 2D points");
  }
  std::sort(model.points.begin(), model.points.end(),
            [](const ColmapPoint3D& a, const ColmapPoint3D& b) { return a.id < b.id; });
  return model;
}

void WriteColmapModel(const fs::path& dir, const ColmapModel& model, ColmapFormat format) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (!fs::is_directory(dir, ec)) throw InputError(dir.string(), "cannot create folder");
  const bool bin = format == ColmapFormat::kBinary;
  const std::string ext = bin ? ".bin" : ".txt";
  WriteFile(dir / ("cameras" + ext), bin, [&](std::ostream& out) {
    bin ? WriteColmapCamerasBinary(out, model) : WriteColmapCamerasText(out, model);
  });
  WriteFile(dir / ("images" + ext), bin, [&](std::ostream& out) {
    bin ? WriteColmapImagesBinary(out, model) : WriteColmapImagesText(out, model);
  });
  WriteFile(dir / ("points3D" + ext), bin, [&](std::ostream& out) {
    bin ? WriteColmapPointsBinary(out, model) : WriteColmapPointsText(out, model);
  });
}

// ---- Conventions ----------------------------------------------------------------

Camera ColmapCameraToCamera(const ColmapCamera& c, const std::string& where) {
  CheckParams(c, where);
  const std::vector<double>& p = c.params;
  Camera cam;
  cam.width = static_cast<int>(c.width);
  cam.height = static_cast<int>(c.height);
  Eigen::Vector2d centre;
  if (c.model == "SIMPLE_PINHOLE" || c.model == "SIMPLE_RADIAL" || c.model == "RADIAL") {
    cam.fx = cam.fy = p[0];
    centre = {p[1], p[2]};
    if (c.model == "SIMPLE_RADIAL") cam.k1 = p[3];
    if (c.model == "RADIAL") cam.k1 = p[3], cam.k2 = p[4];
  } else if (c.model == "PINHOLE" || c.model == "OPENCV" || c.model == "FULL_OPENCV") {
    cam.fx = p[0];
    cam.fy = p[1];
    centre = {p[2], p[3]};
    if (c.model != "PINHOLE") cam.k1 = p[4], cam.k2 = p[5], cam.p1 = p[6], cam.p2 = p[7];
    if (c.model == "FULL_OPENCV") {
      cam.k3 = p[8];
      if (p[9] != 0 || p[10] != 0 || p[11] != 0)
        throw InputError(where, "FULL_OPENCV camera " + std::to_string(c.id) +
                                    " has rational terms k4..k6, which the project's camera model lacks");
    }
  } else {
    throw InputError(where, "camera " + std::to_string(c.id) + " uses the " + c.model +
                                " model; supported: SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV, "
                                "FULL_OPENCV (mapper with --ImageReader.camera_model OPENCV)");
  }
  const Eigen::Vector2d cv = ColmapToOpenCvPixel(centre);
  cam.cx = cv.x();
  cam.cy = cv.y();
  return cam;
}

ColmapCamera CameraToColmapCamera(const Camera& cam) {
  ColmapCamera c;
  c.width = static_cast<uint64_t>(cam.width);
  c.height = static_cast<uint64_t>(cam.height);
  const Eigen::Vector2d centre = OpenCvToColmapPixel({cam.cx, cam.cy});
  c.params = {cam.fx, cam.fy, centre.x(), centre.y(), cam.k1, cam.k2, cam.p1, cam.p2};
  if (cam.k3 != 0) {
    c.model = "FULL_OPENCV";
    c.params.insert(c.params.end(), {cam.k3, 0.0, 0.0, 0.0});
  } else {
    c.model = "OPENCV";
  }
  return c;
}

Camera ColmapImageCamera(const ColmapModel& model, const ColmapImage& image) {
  const auto it = model.cameras.find(image.camera_id);
  if (it == model.cameras.end())
    throw InputError("COLMAP model", "image " + image.name + " has no camera " + std::to_string(image.camera_id));
  Camera cam = ColmapCameraToCamera(it->second);
  cam.c2w = ColmapPoseToC2w(image.pose);
  return cam;
}

}  // namespace shadowsg
