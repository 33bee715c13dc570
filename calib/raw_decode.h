// Camera raw files (DNG, CR2, NEF, ARW, ... anything LibRaw reads) to linear
// RGB: black level subtracted, white level normalised, white balance applied,
// no gamma, no auto-brightness, no highlight recovery. LibRaw stays in
// raw_decode.cc.
#pragma once

#include <Eigen/Core>
#include <filesystem>
#include <string>

#include "calib/image.h"

namespace shadowsg {

enum class RawColourSpace {
  kCamera,  // the sensor's RGB, white-balanced (no colour matrix)
  kSrgb,    // linear sRGB / Rec. 709 primaries, D65 (LibRaw's camera matrix)
};

enum class WhiteBalanceMode {
  kAsShot,    // the camera's multipliers (cam_mul); daylight when the file has none
  kDaylight,  // LibRaw's daylight multipliers from the colour matrix (pre_mul)
  kNone,      // 1, 1, 1: the raw channel ratios
  kUser,      // RawDecodeOptions::user_wb
};

// Demosaicing (LibRaw user_qual): 0 linear, 1 VNG, 2 PPG, 3 AHD, 11 DHT, 12 AAHD.
inline constexpr int kDemosaicAhd = 3;

// A raw value counts as clipped at this fraction of its channel's white level
// (demosaicing spreads a saturated photosite slightly below the level).
inline constexpr double kRawClipFraction = 0.98;
// Pixels within this distance of a clipped one are flagged too: the
// demosaicing kernels (AHD: 5x5) mix a saturated photosite into them.
inline constexpr int kRawClipDilatePx = 2;

struct RawDecodeOptions {
  RawColourSpace colour = RawColourSpace::kSrgb;
  WhiteBalanceMode white_balance = WhiteBalanceMode::kAsShot;
  Eigen::Vector3d user_wb = Eigen::Vector3d::Ones();  // R, G, B multipliers for kUser
  bool half_size = false;                             // 2x2 binning instead of demosaicing (fast previews)
  int demosaic = kDemosaicAhd;

  bool IsValid(std::string* why) const;
};

struct RawImage {
  Image rgb;      // linear; the white level of the least-amplified channel is 1.0
  Image clipped;  // 1 channel: 1 where any channel reached its white level (dilated)
  std::string make, model;
  double black_level = 0;                                    // mean black level, raw units
  double white_level = 0;                                    // raw units
  Eigen::Vector3d wb_multipliers = Eigen::Vector3d::Ones();  // applied, normalised so that min = 1
  bool has_colour_matrix = false;                            // false: kSrgb output is camera RGB (no matrix known)
  double exposure_time_s = 0;                                // 0 when the file does not say
  double iso = 0;
  double f_number = 0;
  int raw_width = 0, raw_height = 0;
  std::string warning;  // empty, or one line worth telling the user
};

// Throws InputError naming `path` when LibRaw cannot open or decode it.
RawImage DecodeRaw(const std::filesystem::path& path, const RawDecodeOptions& options);

// LibRaw's version string, for reports.
std::string RawLibraryVersion();

}  // namespace shadowsg
