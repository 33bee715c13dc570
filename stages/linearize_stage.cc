#include "stages/linearize_stage.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "calib/canvas.h"
#include "calib/error.h"
#include "calib/exif.h"
#include "calib/image_warp.h"
#include "stages/io/atomic_file.h"
#include "stages/io/capture_io.h"
#include "stages/io/json_util.h"
#include "stages/io/scene_io.h"
#include "stages/stage_util.h"

namespace shadowsg {
namespace fs = std::filesystem;

namespace {

enum class InputKind { kLdr, kExr, kRaw };

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

InputKind KindOf(const fs::path& p) {
  const std::string ext = Lower(p.extension().string());
  if (ext == ".jpg" || ext == ".jpeg" || ext == ".png") return InputKind::kLdr;
  if (ext == ".exr") return InputKind::kExr;
  return InputKind::kRaw;  // LibRaw decides (DNG, CR2, CR3, NEF, ARW, RAF, ORF, RW2, KDC, ...)
}

fs::path Beside(const fs::path& out, const std::string& suffix) {
  return out.parent_path() / (out.stem().string() + suffix);
}

const char* ColourName(RawColourSpace c) { return c == RawColourSpace::kSrgb ? "linear sRGB" : "camera RGB"; }

// Response curves on log-exposure axes, one colour per channel.
Image ResponsePlot(const std::array<std::vector<double>, 3>& response) {
  constexpr int kW = 512, kH = 384, kMargin = 40;
  Canvas canvas(kW, kH, Eigen::Vector3f::Constant(0.08f));
  double lo = 1e30, hi = -1e30;
  for (const auto& ch : response)
    for (double v : ch)
      if (v > 0) {
        lo = std::min(lo, std::log10(v));
        hi = std::max(hi, std::log10(v));
      }
  if (!(hi > lo)) return canvas.ToImage();
  const auto to_px = [&](double logv, int z) {
    return Eigen::Vector2d(kMargin + (logv - lo) / (hi - lo) * (kW - 2 * kMargin),
                           kH - kMargin - z / 255.0 * (kH - 2 * kMargin));
  };
  canvas.Line({kMargin, kH - kMargin}, {kW - kMargin, kH - kMargin}, {0.6f, 0.6f, 0.6f});
  canvas.Line({kMargin, kH - kMargin}, {kMargin, kMargin}, {0.6f, 0.6f, 0.6f});
  const Eigen::Vector3f colours[3] = {{1, 0.3f, 0.3f}, {0.3f, 1, 0.3f}, {0.4f, 0.5f, 1}};
  for (int c = 0; c < 3; ++c) {
    std::vector<Eigen::Vector2d> pts;
    for (int z = 0; z < static_cast<int>(response[c].size()); ++z)
      if (response[c][z] > 0) pts.push_back(to_px(std::log10(response[c][z]), z));
    canvas.Polyline(pts, false, colours[c], 2);
  }
  char buf[96];
  std::snprintf(buf, sizeof buf, "code (up) vs log10 exposure (right) %.2f .. %.2f", lo, hi);
  canvas.Text({kMargin, 25}, buf, {1, 1, 1}, 0.45);
  return canvas.ToImage();
}

std::vector<double> ExposureTimes(const LinearizeStageOptions& o, const std::vector<double>& metadata,
                                  const std::vector<fs::path>& inputs) {
  if (!o.times.empty()) return o.times;
  for (size_t i = 0; i < inputs.size(); ++i)
    if (!(metadata[i] > 0))
      throw InputError(inputs[i].string(), "no exposure time in the file's metadata; give them all with --times");
  return metadata;
}

}  // namespace

std::string LinearizeStageOptions::Validate() const {
  std::string why;
  if (inputs.empty()) return "INPUT: at least one photo is required";
  if (out.empty()) return "--out: an output .exr is required";
  if (Lower(out.extension().string()) != ".exr") return "--out: the output must be an .exr file";
  if (!raw.IsValid(&why)) return why;
  if (!stack.IsValid(&why)) return why;
  if (!times.empty() && times.size() != inputs.size())
    return "--times: " + std::to_string(times.size()) + " times for " + std::to_string(inputs.size()) + " inputs";
  for (double t : times)
    if (!(t > 0)) return "--times: exposure times must be positive";
  for (const auto& in : inputs)
    if (fs::absolute(in).lexically_normal() == fs::absolute(out).lexically_normal())
      return "--out: would overwrite the input " + in.string();
  return "";
}

LinearizeStageResult RunLinearizeStage(const LinearizeStageOptions& o, const StageContext& ctx) {
  const std::string bad = o.Validate();
  if (!bad.empty()) throw InputError("linearize", bad);
  const InputKind kind = KindOf(o.inputs[0]);
  std::string guess_warning;  // shown once the image is known to be usable
  for (const auto& in : o.inputs) {
    if (KindOf(in) != kind)
      throw InputError(in.string(), "inputs mix kinds: give only raws, only 8-bit JPEG/PNG, or one EXR");
    std::error_code ec;
    if (!fs::is_regular_file(in, ec)) throw InputError(in.string(), "file not found");
  }
  if (kind == InputKind::kExr && o.inputs.size() > 1)
    throw InputError(o.inputs[1].string(), "EXR input is already linear: give one");

  LinearizeStageResult result;
  HdrResult hdr;
  Json report;
  report["inputs"] = Json::array();
  for (const auto& in : o.inputs) report["inputs"].push_back(in.string());
  const ProgressFn progress = ctx.Progress("linearize");
  const double steps = static_cast<double>(o.inputs.size()) + 1;

  if (kind == InputKind::kRaw) {
    std::vector<Image> images, masks;
    std::vector<double> meta_times;
    Json raws = Json::array();
    for (size_t i = 0; i < o.inputs.size(); ++i) {
      Report(progress, i / steps, "decoding " + o.inputs[i].filename().string());
      RawImage raw = DecodeRaw(o.inputs[i], o.raw);
      if (!raw.warning.empty()) ctx.Warn(o.inputs[i].string() + ": " + raw.warning);
      if (!images.empty() && (raw.rgb.width != images[0].width || raw.rgb.height != images[0].height))
        throw InputError(o.inputs[i].string(), "size differs from the first raw of the stack");
      raws.push_back({{"file", o.inputs[i].string()},
                      {"camera", raw.make + " " + raw.model},
                      {"black_level", raw.black_level},
                      {"white_level", raw.white_level},
                      {"wb_multipliers", ToJson(raw.wb_multipliers)},
                      {"has_colour_matrix", raw.has_colour_matrix},
                      {"exposure_time_s", raw.exposure_time_s},
                      {"iso", raw.iso},
                      {"f_number", raw.f_number}});
      ctx.Log(o.inputs[i].filename().string() + ": " + raw.make + " " + raw.model + ", " +
              std::to_string(raw.rgb.width) + "x" + std::to_string(raw.rgb.height) + ", black " +
              std::to_string(static_cast<int>(raw.black_level)) + ", white " +
              std::to_string(static_cast<int>(raw.white_level)));
      meta_times.push_back(raw.exposure_time_s);
      images.push_back(std::move(raw.rgb));
      masks.push_back(std::move(raw.clipped));
    }
    report["raw"] = raws;
    report["colour_space"] = ColourName(o.raw.colour);
    if (images.size() == 1) {
      result.kind = "raw";
      hdr.radiance = std::move(images[0]);
      hdr.clipped = std::move(masks[0]);
    } else {
      result.kind = "raw stack";
      const std::vector<double> times = ExposureTimes(o, meta_times, o.inputs);
      report["exposure_times_s"] = times;
      Report(progress, (steps - 1) / steps, "merging");
      hdr = MergeLinearStack(images, masks, times, o.align);
    }
  } else if (kind == InputKind::kLdr) {
    std::vector<Image> images;
    std::vector<double> meta_times;
    for (size_t i = 0; i < o.inputs.size(); ++i) {
      Report(progress, i / steps, "reading " + o.inputs[i].filename().string());
      images.push_back(ReadLdr(o.inputs[i]));
      meta_times.push_back(ReadExif(o.inputs[i]).exposure_time_s.value_or(0.0));
      if (images.back().width != images[0].width || images.back().height != images[0].height)
        throw InputError(o.inputs[i].string(), "size differs from the first image of the stack");
    }
    report["colour_space"] = "linear sRGB (8-bit input)";
    if (images.size() == 1) {
      result.kind = "8-bit sRGB";
      guess_warning = o.inputs[0].string() +
                      ": 8-bit input: the camera's tone curve is unknown, the inverse sRGB curve is a guess "
                      "(shoot raw, or an exposure stack for a recovered response)";
      hdr = LinearizeSrgb(images[0]);
      report["response"] = "inverse sRGB (assumed)";
    } else {
      result.kind = "8-bit stack";
      const std::vector<double> times = ExposureTimes(o, meta_times, o.inputs);
      report["exposure_times_s"] = times;
      LdrStackOptions stack = o.stack;
      stack.align = o.align;
      Report(progress, (steps - 1) / steps, "recovering the response and merging");
      hdr = MergeLdrStack(images, times, stack);
      static const char* kNames[] = {"debevec", "robertson", "srgb"};
      report["response"] = kNames[static_cast<int>(stack.method)];
    }
  } else {
    result.kind = "exr";
    hdr.radiance = ReadExr(o.inputs[0]);
    hdr.clipped = Image(hdr.radiance.width, hdr.radiance.height, 1);
    report["colour_space"] = "as the input";
  }

  // A frame with nothing usable is bad input, not an image to pass on.
  {
    const std::string first = o.inputs[0].string();
    size_t saturated = 0, black = 0;
    for (float v : hdr.clipped.data) saturated += v == kMaskSaturated, black += v == kMaskUnderexposed;
    const size_t n = hdr.clipped.pixels();
    float hi = 0;
    for (float v : hdr.radiance.data) {
      if (!std::isfinite(v)) throw InputError(first, "image has non-finite pixels");
      hi = std::max(hi, v);
    }
    if (n > 0 && saturated == n) throw InputError(first, "every pixel is saturated (over-exposed): no usable pixel");
    if (hi <= 0 || (n > 0 && black == n)) throw InputError(first, "image is black (under-exposed): no usable pixel");
  }
  if (!guess_warning.empty()) ctx.Warn(guess_warning);

  if (!o.undistort.empty()) {
    Report(progress, (steps - 0.5) / steps, "undistorting");
    Camera cam = ReadCameraFile(o.undistort).camera;
    if (cam.projection != Projection::kPerspective) throw InputError(o.undistort.string(), "not a perspective camera");
    const int w = hdr.radiance.width, h = hdr.radiance.height;
    if (cam.width != w || cam.height != h) {
      // Same aspect (e.g. a half-size raw of the calibrated camera): rescale.
      if (std::abs(static_cast<double>(w) / cam.width - static_cast<double>(h) / cam.height) > 1e-3)
        throw InputError(o.undistort.string(), "camera is " + std::to_string(cam.width) + "x" +
                                                   std::to_string(cam.height) + " but the image is " +
                                                   std::to_string(w) + "x" + std::to_string(h));
      ctx.Warn(o.undistort.string() + ": camera rescaled from " + std::to_string(cam.width) + "x" +
               std::to_string(cam.height) + " to the image's " + std::to_string(w) + "x" + std::to_string(h));
      cam = ResizeCamera(cam, w, h);
    }
    Image outside;
    hdr.radiance = UndistortImage(hdr.radiance, cam, WarpSampling::kBilinear, &outside);
    Image saturated(w, h, 1), black(w, h, 1);
    for (size_t p = 0; p < hdr.clipped.pixels(); ++p) {
      saturated.data[p] = hdr.clipped.data[p] == kMaskSaturated ? 1.0f : 0.0f;
      black.data[p] = hdr.clipped.data[p] == kMaskUnderexposed ? 1.0f : 0.0f;
    }
    saturated = UndistortImage(saturated, cam, WarpSampling::kAnyNonZero);
    black = UndistortImage(black, cam, WarpSampling::kAnyNonZero);
    for (size_t p = 0; p < hdr.clipped.pixels(); ++p)
      hdr.clipped.data[p] = saturated.data[p] > 0 ? kMaskSaturated
                            : black.data[p] > 0   ? kMaskUnderexposed
                            : outside.data[p] > 0 ? kMaskOutside
                                                  : 0.0f;
    CameraFile undistorted;
    undistorted.camera = PinholeOf(cam);
    undistorted.camera.c2w = Eigen::Matrix4d::Identity();
    Json cj = CameraFileToJson(undistorted);
    cj["undistorted_from"] = o.undistort.string();
    result.camera_json = Beside(o.out, "_camera.json");
    if (result.camera_json.has_parent_path()) EnsureOutputDir(result.camera_json.parent_path());
    WriteJsonFile(result.camera_json, cj);
    report["undistorted_with"] = o.undistort.string();
  }

  result.width = hdr.radiance.width;
  result.height = hdr.radiance.height;
  size_t flagged = 0;
  Image mask_png(result.width, result.height, 1);
  for (size_t p = 0; p < hdr.clipped.pixels(); ++p) {
    flagged += hdr.clipped.data[p] > 0;
    mask_png.data[p] = hdr.clipped.data[p];
  }
  result.clipped_fraction = static_cast<double>(flagged) / std::max<size_t>(1, hdr.clipped.pixels());

  if (o.out.has_parent_path()) EnsureOutputDir(o.out.parent_path());
  result.exr = o.out;
  result.mask = Beside(o.out, "_clipped.png");
  result.preview = Beside(o.out, "_preview.png");
  result.report = Beside(o.out, "_linearize.json");
  Report(progress, (steps - 0.2) / steps, "writing");
  WriteExr(result.exr, hdr.radiance, o.pixel_type);
  WriteLdr(result.mask, mask_png);
  WritePreviewPng(result.preview, hdr.radiance);
  if (!hdr.response[0].empty()) {
    result.response_png = Beside(o.out, "_response.png");
    WriteLdr(result.response_png, ResponsePlot(hdr.response));
    std::ostringstream csv;
    csv << "code,r,g,b\n";
    for (size_t z = 0; z < hdr.response[0].size(); ++z)
      csv << z << ',' << hdr.response[0][z] << ',' << hdr.response[1][z] << ',' << hdr.response[2][z] << '\n';
    WriteTextAtomically(Beside(o.out, "_response.csv"), csv.str());
  }
  report["kind"] = result.kind;
  report["width"] = result.width;
  report["height"] = result.height;
  report["clipped_fraction"] = result.clipped_fraction;
  report["mask"] = result.mask.filename().string();
  report["mask_codes"] = {{"saturated", 255}, {"underexposed", 128}, {"outside_frame", 64}};
  WriteJsonFile(result.report, report);
  Report(progress, 1.0, "done");
  return result;
}

}  // namespace shadowsg
