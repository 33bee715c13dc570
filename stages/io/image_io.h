// Image files: EXR (OpenEXR; half or float, Y/RGB/RGBA) and 8/16-bit PNG/JPEG
// (OpenCV). Library types stay in image_io.cc. Every writer is atomic.
#pragma once

#include <filesystem>

#include "calib/image.h"

namespace shadowsg {

enum class ExrPixelType { kHalf, kFloat };

// Reads R,G,B (and A when asked) or a single Y channel. Throws InputError
// naming the file on any problem.
Image ReadExr(const std::filesystem::path& path, bool keep_alpha = false);
void WriteExr(const std::filesystem::path& path, const Image& image,
              ExrPixelType type = ExrPixelType::kFloat);
// An equirectangular map (width 2 x height), float, tagged with OpenEXR's
// `envmap` attribute = LATLONG (ImfEnvmap.h); the caller lays it out in
// OpenEXR's convention first (EnvMapToLatLong, calib/conventions.h).
void WriteLatLongExr(const std::filesystem::path& path, const Image& image);
// An equirectangular environment map (scene-format.md): an EXR twice as wide
// as high with finite radiance, non-negative unless kSigned; InputError
// otherwise. kSigned is for estimates to be scored: SS03's least-squares maps
// hold negative texels by design (the published method), and eval must
// render them as they are.
enum class EnvMapSign { kNonNegative, kSigned };
Image ReadEnvMapExr(const std::filesystem::path& path, EnvMapSign sign = EnvMapSign::kNonNegative);
// True when the EXR's header says envmap = LATLONG.
bool ExrIsLatLong(const std::filesystem::path& path);

// 8- or 16-bit PNG/JPEG as values in [0, 1] (no linearisation), RGB order.
Image ReadLdr(const std::filesystem::path& path);
// Writes values in [0, 1] as 8-bit PNG/JPEG (clamped), RGB order.
void WriteLdr(const std::filesystem::path& path, const Image& image);
// 1-channel mask from a PNG: 1 where the pixel is non-zero.
Image ReadMask(const std::filesystem::path& path);

// Any supported image by extension: .exr read as linear, .png/.jpg as stored.
Image ReadImage(const std::filesystem::path& path);

// Tone-mapped preview of a linear image: scaled so that `white` maps to 1
// (white <= 0: the 99th percentile), then the sRGB curve.
Image ToneMap(const Image& linear, float white = 0.0f);
void WritePreviewPng(const std::filesystem::path& path, const Image& linear, float white = 0.0f);
// Writes `path` (.exr) and its preview beside it (same stem, .png).
void WriteExrWithPreview(const std::filesystem::path& path, const Image& linear, float white = 0.0f);

// sRGB transfer curve and its inverse (IEC 61966-2-1).
float SrgbEncode(float linear);
float SrgbDecode(float encoded);

}  // namespace shadowsg
