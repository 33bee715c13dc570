// `shadowsg intrinsics`: camera intrinsics from a folder of checkerboard
// photos. Writes camera.json (scene-format.md, Stage artifacts) and a coverage
// picture (every view's detected corners over the frame).
#pragma once

#include <filesystem>
#include <string>

#include "calib/checkerboard.h"
#include "stages/stage_context.h"

namespace shadowsg {

struct IntrinsicsStageOptions {
  std::filesystem::path images;  // folder of .jpg/.jpeg/.png/.exr photos
  std::filesystem::path out = "camera.json";
  std::filesystem::path coverage;  // empty: <out stem>_coverage.png beside out
  CornerDetector detector = CornerDetector::kSectorBased;
  IntrinsicsOptions calibration;  // board size, square, model flags, outlier rule

  // Message naming the bad option, or empty.
  std::string Validate() const;
};

struct IntrinsicsStageResult {
  IntrinsicsResult calibration;  // views in file-name order, including those not used
  std::filesystem::path camera_json, coverage_png;
};

IntrinsicsStageResult RunIntrinsicsStage(const IntrinsicsStageOptions& options, const StageContext& ctx);

// Image files a capture folder holds, sorted by name (.jpg .jpeg .png .exr).
std::vector<std::filesystem::path> ListImages(const std::filesystem::path& dir);

}  // namespace shadowsg
