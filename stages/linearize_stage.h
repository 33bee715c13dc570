// `shadowsg linearize`: photos to a linear HDR image. Camera raws go through
// LibRaw (black level, white level, white balance, no gamma); a single 8-bit
// JPEG/PNG through the inverse sRGB curve; an 8-bit exposure stack through a
// recovered response (Debevec or Robertson); several raws are merged as linear
// exposures. Optionally undistorted to the pinhole camera of a camera.json.
// Writes OUT.exr, OUT_clipped.png (non-zero: do not use the pixel),
// OUT_preview.png, OUT_linearize.json, and for undistorted output
// OUT_camera.json; for a recovered response, OUT_response.png and .csv.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "calib/hdr_merge.h"
#include "calib/raw_decode.h"
#include "stages/io/image_io.h"
#include "stages/stage_context.h"

namespace shadowsg {

struct LinearizeStageOptions {
  std::vector<std::filesystem::path> inputs;
  std::filesystem::path out;        // .exr
  RawDecodeOptions raw;             // colour space, white balance, demosaic, half size
  LdrStackOptions stack;            // response recovery for 8-bit stacks
  std::vector<double> times;        // exposure times (s); empty: from EXIF / raw metadata
  bool align = false;               // align the exposures of a stack (hand-held brackets)
  std::filesystem::path undistort;  // camera.json: resample to its camera without distortion
  ExrPixelType pixel_type = ExrPixelType::kFloat;

  // Message naming the bad option, or empty.
  std::string Validate() const;
};

struct LinearizeStageResult {
  std::string kind;  // "raw", "raw stack", "8-bit sRGB", "8-bit stack", "exr"
  int width = 0, height = 0;
  double clipped_fraction = 0.0;  // share of pixels flagged in the mask
  std::filesystem::path exr, mask, preview, report, camera_json, response_png;
};

LinearizeStageResult RunLinearizeStage(const LinearizeStageOptions& options, const StageContext& ctx);

}  // namespace shadowsg
