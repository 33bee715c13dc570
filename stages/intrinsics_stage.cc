#include "stages/intrinsics_stage.h"

#include <algorithm>
#include <cstdio>
#include <exception>
#include <map>
#include <optional>

#include "calib/canvas.h"
#include "calib/error.h"
#include "stages/io/capture_io.h"
#include "stages/io/image_io.h"
#include "stages/stage_util.h"

namespace shadowsg {
namespace fs = std::filesystem;

namespace {

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

std::string Format(const char* fmt, double a, double b = 0, double c = 0, double d = 0) {
  char buf[256];
  std::snprintf(buf, sizeof buf, fmt, a, b, c, d);
  return buf;
}

// Photo as display-referred values: EXR (linear) through the sRGB curve.
Image ReadDisplayImage(const fs::path& path) {
  Image img = ReadImage(path);
  if (Lower(path.extension().string()) == ".exr")
    for (float& v : img.data) v = SrgbEncode(v);
  return img;
}

struct Detection {
  int width = 0, height = 0;
  std::optional<std::vector<Eigen::Vector2d>> corners;
  std::string error;  // unreadable image
};

Image CoveragePicture(const IntrinsicsResult& r, const std::vector<fs::path>& files, const IntrinsicsOptions& o) {
  const Camera& cam = r.camera;
  // Background: the first used photo, dimmed, so the frame reads as a photo.
  std::optional<Canvas> canvas;
  for (size_t i = 0; i < r.views.size() && !canvas; ++i) {
    if (!r.views[i].used) continue;
    try {
      const Image bg = ReadDisplayImage(files[i]);
      if (bg.width == cam.width && bg.height == cam.height) canvas.emplace(bg, 0.3f);
    } catch (const InputError&) {
    }
  }
  if (!canvas) canvas.emplace(cam.width, cam.height, Eigen::Vector3f::Constant(0.1f));
  const double scale = std::max(cam.width, cam.height) / 1000.0;  // line and text size for the frame size
  const int thick = std::max(1, static_cast<int>(std::lround(scale)));
  const int n_used = r.UsedViews();
  int k = 0;
  for (const auto& v : r.views) {
    if (v.corners.empty()) continue;
    const auto& c = v.corners;
    const std::vector<Eigen::Vector2d> outline = {c[0], c[o.cols - 1], c[c.size() - 1], c[c.size() - o.cols]};
    if (v.used) {
      const Eigen::Vector3f colour = CategoricalColour(k++, n_used);
      canvas->Polyline(outline, true, colour, thick);
      for (const auto& p : c) canvas->Disc(p, 2.5 * scale + 0.5, colour);
    } else {
      for (const auto& p : c) canvas->Cross(p, 3 * scale + 1, {1, 0, 0}, thick);
    }
  }
  canvas->Cross({cam.cx, cam.cy}, 12 * scale + 4, {1, 1, 1}, thick);
  const double ts = 0.5 * std::max(1.0, scale);
  const int rejected = static_cast<int>(r.views.size()) - n_used;
  canvas->Text({10 * ts, 30 * ts},
               std::to_string(n_used) + " views used, " + std::to_string(rejected) + " rejected (red), RMS " +
                   Format("%.3f px", r.rms_px),
               {1, 1, 1}, ts);
  canvas->Text({10 * ts, 60 * ts},
               Format("fx %.1f  fy %.1f  cx %.1f  cy %.1f", cam.fx, cam.fy, cam.cx, cam.cy) +
                   Format("  k1 %.3f k2 %.3f", cam.k1, cam.k2),
               {1, 1, 1}, ts);
  return canvas->ToImage();
}

}  // namespace

std::string IntrinsicsStageOptions::Validate() const {
  std::string why;
  if (images.empty()) return "--images: a folder of checkerboard photos is required";
  if (out.empty()) return "--out: an output file is required";
  if (!calibration.IsValid(&why)) return why;
  return "";
}

std::vector<fs::path> ListImages(const fs::path& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw InputError(dir.string(), "not a folder");
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    const std::string ext = Lower(e.path().extension().string());
    if (e.is_regular_file(ec) && (ext == ".jpg" || ext == ".jpeg" || ext == ".png" || ext == ".exr"))
      files.push_back(e.path());
  }
  std::sort(files.begin(), files.end());
  return files;
}

IntrinsicsStageResult RunIntrinsicsStage(const IntrinsicsStageOptions& o, const StageContext& ctx) {
  const std::string bad = o.Validate();
  if (!bad.empty()) throw InputError("intrinsics", bad);
  const std::vector<fs::path> files = ListImages(o.images);
  if (files.empty()) throw InputError(o.images.string(), "no .jpg, .png or .exr images in the folder");

  CheckerboardOptions detect;
  detect.cols = o.calibration.cols;
  detect.rows = o.calibration.rows;
  detect.detector = o.detector;
  std::vector<Detection> det(files.size());
  std::vector<std::exception_ptr> errors(files.size());
  const ProgressFn progress = ctx.Progress("corners");
  int done = 0;
#pragma omp parallel for schedule(dynamic) num_threads(std::max(1, ctx.threads))
  for (long i = 0; i < static_cast<long>(files.size()); ++i) {
    try {
      try {
        const Image img = ReadDisplayImage(files[i]);
        det[i].width = img.width;
        det[i].height = img.height;
        det[i].corners = DetectCheckerboard(img, detect);
      } catch (const InputError& e) {
        det[i].error = e.what();
      }
#pragma omp critical(intrinsics_progress)
      {
        ++done;
        Report(progress, static_cast<double>(done) / files.size(),
               files[i].filename().string() + (det[i].corners ? ": board found" : ": no board"));
      }
    } catch (...) {
      errors[i] = std::current_exception();  // e.g. Interrupted from the progress callback
    }
  }
  for (const auto& e : errors)
    if (e) std::rethrow_exception(e);

  // The camera's size is that of most detected views.
  std::map<std::pair<int, int>, int> sizes;
  for (const auto& d : det)
    if (d.corners) ++sizes[{d.width, d.height}];
  if (sizes.empty())
    throw InputError(o.images.string(), "no " + std::to_string(detect.cols) + "x" + std::to_string(detect.rows) +
                                            " checkerboard (inner corners) found in any of the " +
                                            std::to_string(files.size()) + " images");
  const auto size = std::max_element(sizes.begin(), sizes.end(), [](const auto& a, const auto& b) {
                      return a.second < b.second;
                    })->first;

  std::vector<CalibrationView> views;
  std::vector<size_t> view_file;
  for (size_t i = 0; i < files.size(); ++i)
    if (det[i].corners && det[i].width == size.first && det[i].height == size.second) {
      views.push_back({files[i].filename().string(), *det[i].corners});
      view_file.push_back(i);
    }
  ctx.Log("calibrating from " + std::to_string(views.size()) + " views of " + std::to_string(files.size()) +
          " images (" + std::to_string(size.first) + "x" + std::to_string(size.second) + ")");
  IntrinsicsResult fit = CalibrateIntrinsics(views, size.first, size.second, o.calibration);

  // Merge in the images that did not enter the fit, in file order.
  IntrinsicsStageResult result;
  IntrinsicsResult& r = result.calibration;
  r.camera = fit.camera;
  r.rms_px = fit.rms_px;
  r.std_dev = fit.std_dev;
  size_t next = 0;
  for (size_t i = 0; i < files.size(); ++i) {
    if (next < view_file.size() && view_file[next] == i) {
      r.views.push_back(fit.views[next++]);
      continue;
    }
    ViewReport v;
    v.name = files[i].filename().string();
    if (!det[i].error.empty())
      v.rejection = "unreadable: " + det[i].error;
    else if (!det[i].corners)
      v.rejection = "board not found";
    else
      v.rejection = "image is " + std::to_string(det[i].width) + "x" + std::to_string(det[i].height) + ", not " +
                    std::to_string(size.first) + "x" + std::to_string(size.second);
    r.views.push_back(std::move(v));
  }

  CameraFile file;
  file.camera = r.camera;
  file.rms_px = r.rms_px;
  Json per_view = Json::object(), reasons = Json::object();
  for (const auto& v : r.views) {
    (v.used ? file.views_used : file.views_rejected).push_back(v.name);
    if (v.used || v.rms_px > 0) per_view[v.name] = v.rms_px;
    if (!v.used) reasons[v.name] = v.rejection;
  }
  Json j = CameraFileToJson(file);
  j["view_rms_px"] = per_view;
  j["rejection_reasons"] = reasons;
  j["board"] = Json{{"inner_corners", {o.calibration.cols, o.calibration.rows}}, {"square", o.calibration.square}};
  j["model"] = Json{{"fix_aspect", o.calibration.fix_aspect},
                    {"fix_principal_point", o.calibration.fix_principal_point},
                    {"zero_tangential", o.calibration.zero_tangential},
                    {"fix_k3", o.calibration.fix_k3}};
  if (r.std_dev.size() == 9) {
    static const char* kNames[] = {"fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3"};
    Json sd;
    for (int i = 0; i < 9; ++i) sd[kNames[i]] = r.std_dev[i];
    j["std_dev"] = sd;
  }
  result.camera_json = o.out;
  if (result.camera_json.has_parent_path()) EnsureOutputDir(result.camera_json.parent_path());
  WriteJsonFile(result.camera_json, j);
  result.coverage_png =
      o.coverage.empty() ? o.out.parent_path() / (o.out.stem().string() + "_coverage.png") : o.coverage;
  if (result.coverage_png.has_parent_path()) EnsureOutputDir(result.coverage_png.parent_path());
  WriteLdr(result.coverage_png, CoveragePicture(r, files, o.calibration));
  for (const auto& v : r.views)
    ctx.Log("  " + v.name + ": " + (v.used ? Format("%.3f px", v.rms_px) : "rejected, " + v.rejection));
  return result;
}

}  // namespace shadowsg
