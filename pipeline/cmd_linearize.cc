// `shadowsg linearize INPUT... --out OUT.exr`.
#include <cstdio>
#include <sstream>

#include "calib/error.h"
#include "pipeline/cli_common.h"
#include "pipeline/commands.h"
#include "stages/linearize_stage.h"

namespace shadowsg {

namespace {

std::vector<std::string> SplitList(const std::string& text) {
  std::vector<std::string> out;
  std::string item;
  std::istringstream ss(text);
  while (std::getline(ss, item, ','))
    if (!item.empty()) out.push_back(item);
  return out;
}

// "0.5", "1/250" -> seconds.
double ParseTime(const std::string& s) {
  try {
    const size_t slash = s.find('/');
    size_t used = 0;
    if (slash == std::string::npos) {
      const double t = std::stod(s, &used);
      if (used == s.size() && t > 0) return t;
    } else {
      const double num = std::stod(s.substr(0, slash));
      const std::string den_text = s.substr(slash + 1);
      const double den = std::stod(den_text, &used);
      if (used == den_text.size() && num > 0 && den > 0) return num / den;
    }
  } catch (const std::exception&) {
  }
  throw InputError("--times", "expected positive times like 0.5 or 1/250, got \"" + s + "\"");
}

}  // namespace

void RegisterLinearizeCommand(CLI::App& app) {
  struct Options {
    CommonOptions common;
    LinearizeStageOptions stage;
    std::vector<std::string> inputs;
    std::string colour = "srgb", wb = "as-shot", response = "debevec", times, half = "float";
  };
  auto opt = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand(
      "linearize", "Camera raw, 8-bit photo or exposure stack to a linear HDR EXR with a clipped-pixel mask");
  cmd->add_option("INPUT", opt->inputs, "One raw (DNG CR2 NEF ARW ...), one JPEG/PNG, a stack of either, or one EXR")
      ->required();
  cmd->add_option("--out", opt->stage.out, "Output .exr (mask, preview and report are written beside it)")->required();
  cmd->add_option("--colour,--color", opt->colour, "Raw output space: srgb (linear sRGB) or camera (camera RGB)")
      ->capture_default_str();
  cmd->add_option("--wb", opt->wb, "Raw white balance: as-shot, daylight, none, or R,G,B multipliers")
      ->capture_default_str();
  cmd->add_option("--demosaic", opt->stage.raw.demosaic,
                  "LibRaw demosaic: 0 linear, 1 VNG, 2 PPG, 3 AHD, 11 DHT, 12 AAHD")
      ->capture_default_str();
  cmd->add_flag("--half-size", opt->stage.raw.half_size, "Raw: 2x2 binning instead of demosaicing (half size)");
  cmd->add_option("--response", opt->response, "8-bit stack: debevec, robertson, or srgb (assume the sRGB curve)")
      ->capture_default_str();
  cmd->add_option("--times", opt->times,
                  "Exposure times of the inputs in seconds, comma-separated (1/250 allowed); "
                  "default: from EXIF / raw metadata");
  cmd->add_flag("--align", opt->stage.align, "Align the exposures of a stack (median threshold bitmaps)");
  cmd->add_option("--undistort", opt->stage.undistort,
                  "camera.json: resample to its camera without distortion (writes <out>_camera.json)");
  cmd->add_option("--exr-type", opt->half, "EXR pixels: float or half")->capture_default_str();
  AddCommonOptions(cmd, &opt->common);
  cmd->callback([opt] {
    LinearizeStageOptions& s = opt->stage;
    for (const auto& in : opt->inputs) s.inputs.emplace_back(in);
    if (opt->colour == "srgb")
      s.raw.colour = RawColourSpace::kSrgb;
    else if (opt->colour == "camera")
      s.raw.colour = RawColourSpace::kCamera;
    else
      throw InputError("--colour", "expected srgb or camera, got \"" + opt->colour + "\"");
    if (opt->wb == "as-shot")
      s.raw.white_balance = WhiteBalanceMode::kAsShot;
    else if (opt->wb == "daylight")
      s.raw.white_balance = WhiteBalanceMode::kDaylight;
    else if (opt->wb == "none")
      s.raw.white_balance = WhiteBalanceMode::kNone;
    else {
      const auto parts = SplitList(opt->wb);
      if (parts.size() != 3)
        throw InputError("--wb", "expected as-shot, daylight, none or R,G,B, got \"" + opt->wb + "\"");
      s.raw.white_balance = WhiteBalanceMode::kUser;
      for (int c = 0; c < 3; ++c) {
        try {
          s.raw.user_wb[c] = std::stod(parts[c]);
        } catch (const std::exception&) {
          throw InputError("--wb", "\"" + parts[c] + "\" is not a number");
        }
      }
    }
    if (opt->response == "debevec")
      s.stack.method = ResponseMethod::kDebevec;
    else if (opt->response == "robertson")
      s.stack.method = ResponseMethod::kRobertson;
    else if (opt->response == "srgb")
      s.stack.method = ResponseMethod::kSrgb;
    else
      throw InputError("--response", "expected debevec, robertson or srgb, got \"" + opt->response + "\"");
    for (const auto& t : SplitList(opt->times)) s.times.push_back(ParseTime(t));
    if (opt->half == "half")
      s.pixel_type = ExrPixelType::kHalf;
    else if (opt->half != "float")
      throw InputError("--exr-type", "expected float or half");
    const LinearizeStageResult r = RunLinearizeStage(s, MakeContext(opt->common));
    std::printf("input        %s, %dx%d\n", r.kind.c_str(), r.width, r.height);
    std::printf("clipped      %.2f %% of pixels (%s)\n", 100.0 * r.clipped_fraction, r.mask.string().c_str());
    std::printf("wrote        %s, %s, %s\n", r.exr.string().c_str(), r.preview.string().c_str(),
                r.report.string().c_str());
    if (!r.camera_json.empty()) std::printf("camera       %s (undistorted)\n", r.camera_json.string().c_str());
    if (!r.response_png.empty()) std::printf("response     %s\n", r.response_png.string().c_str());
  });
}

}  // namespace shadowsg
