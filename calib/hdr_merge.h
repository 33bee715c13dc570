// Linear radiance from 8-bit photos and exposure stacks: the inverse sRGB
// curve for a single JPEG/PNG, response recovery and merging (OpenCV's Debevec
// or Robertson) for a bracketed 8-bit stack, and a noise-optimal merge of
// linear (raw) exposures. Every path also returns a mask of pixels whose
// value is unknown (clipped), which the solver must ignore.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "calib/image.h"

namespace shadowsg {

// Codes of the clip mask (1 channel; non-zero = do not use the pixel).
inline constexpr float kMaskSaturated = 1.0f;     // highlight clipped in every exposure
inline constexpr float kMaskUnderexposed = 0.5f;  // black in every exposure (8-bit inputs)
inline constexpr float kMaskOutside = 0.25f;      // outside the source frame after undistortion

// 8-bit codes at or above kLdrSaturatedCode count as saturated (JPEG ringing
// keeps clipped areas a few codes below 255); at or below kLdrBlackCode as
// black (relative quantisation error above 20 %).
inline constexpr int kLdrSaturatedCode = 250;
inline constexpr int kLdrBlackCode = 2;

enum class ResponseMethod {
  kDebevec,  // Debevec & Malik, SIGGRAPH 97 (cv::CalibrateDebevec / MergeDebevec)
  // Robertson, Borman & Stevenson, ICIP 99 (cv::CalibrateRobertson /
  // MergeRobertson). Needs dense brackets: on a synthetic stack 3 stops apart
  // OpenCV's iteration stays 20 % off where Debevec is within 2 %; 1 stop apart
  // both are within 1 %.
  kRobertson,
  kSrgb,  // no recovery: the inverse sRGB curve, exposures merged as linear data
};

struct LdrStackOptions {
  ResponseMethod method = ResponseMethod::kDebevec;
  bool align = false;             // median-threshold-bitmap alignment (cv::AlignMTB) of hand-held brackets
  int debevec_samples = 70;       // OpenCV's default
  float debevec_lambda = 10.0f;   // smoothness weight, OpenCV's default
  int robertson_iterations = 30;  // OpenCV's default

  bool IsValid(std::string* why) const;
};

struct HdrResult {
  // Linear RGB. Stacks: scaled to the first input's exposure; recovered
  // responses are fixed so that code 128 of that exposure reads 1.0.
  Image radiance;
  Image clipped;  // mask codes above
  // Recovered response per channel (R, G, B): response[c][z] is the relative
  // exposure that gives code z. Empty for the sRGB and linear paths.
  std::array<std::vector<double>, 3> response;
};

// A single display-referred 8-bit image through the inverse sRGB curve.
HdrResult LinearizeSrgb(const Image& ldr);

// An exposure stack of display-referred 8-bit images (values in [0, 1], k/255)
// with exposure times in seconds (any consistent unit). All images the same size.
HdrResult MergeLdrStack(const std::vector<Image>& images, const std::vector<double>& times,
                        const LdrStackOptions& options);

// Linear exposures (e.g. decoded raws) with their clip masks: per pixel the
// maximum-likelihood radiance under photon noise, sum(v_i) / sum(t_i / t_0)
// over the exposures where the pixel is not clipped.
HdrResult MergeLinearStack(const std::vector<Image>& images, const std::vector<Image>& clipped,
                           const std::vector<double>& times, bool align);

}  // namespace shadowsg
