#include "calib/raw_decode.h"

#include <libraw/libraw.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <opencv2/imgproc.hpp>

#include "calib/error.h"

namespace shadowsg {

bool RawDecodeOptions::IsValid(std::string* why) const {
  if (white_balance == WhiteBalanceMode::kUser && !(user_wb.minCoeff() > 0 && user_wb.allFinite())) {
    *why = "white-balance multipliers must be positive";
    return false;
  }
  static const int kModes[] = {0, 1, 2, 3, 11, 12};
  if (std::find(std::begin(kModes), std::end(kModes), demosaic) == std::end(kModes)) {
    *why = "demosaic must be 0 (linear), 1 (VNG), 2 (PPG), 3 (AHD), 11 (DHT) or 12 (AAHD)";
    return false;
  }
  return true;
}

std::string RawLibraryVersion() { return LibRaw::version(); }

namespace {

struct MemImageDeleter {
  void operator()(libraw_processed_image_t* p) const { LibRaw::dcraw_clear_mem(p); }
};

bool Positive3(const float* m) { return m[0] > 0 && m[1] > 0 && m[2] > 0; }

}  // namespace

RawImage DecodeRaw(const std::filesystem::path& path, const RawDecodeOptions& o) {
  std::string why;
  if (!o.IsValid(&why)) throw InputError(path.string(), why);
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) throw InputError(path.string(), "file not found");
  const auto fail = [&](const char* step, int code) {
    return InputError(path.string(), std::string(step) + ": " + libraw_strerror(code));
  };
  // LibRaw holds large tables: keep it off the stack.
  auto raw = std::make_unique<LibRaw>();
  int rc = raw->open_file(path.c_str());
  if (rc != LIBRAW_SUCCESS) throw fail("not a camera raw file LibRaw can read", rc);
  rc = raw->unpack();
  if (rc != LIBRAW_SUCCESS) throw fail("cannot unpack the raw data", rc);

  libraw_data_t& d = raw->imgdata;
  RawImage out;
  out.make = d.idata.make;
  out.model = d.idata.model;
  out.raw_width = d.sizes.raw_width;
  out.raw_height = d.sizes.raw_height;
  out.exposure_time_s = d.other.shutter > 0 ? d.other.shutter : 0.0;
  out.iso = d.other.iso_speed;
  out.f_number = d.other.aperture;
  out.black_level =
      d.color.black + (d.color.cblack[0] + d.color.cblack[1] + d.color.cblack[2] + d.color.cblack[3]) / 4.0;
  out.white_level = d.color.maximum;
  if (d.idata.colors != 1 && d.idata.colors != 3)
    throw InputError(path.string(), std::to_string(d.idata.colors) + "-colour sensor (" + d.idata.cdesc +
                                        ") is not supported: only RGB and monochrome sensors are");

  // White balance multipliers (R, G, B).
  Eigen::Vector3d mul = Eigen::Vector3d::Ones();
  switch (o.white_balance) {
    case WhiteBalanceMode::kAsShot:
      if (Positive3(d.color.cam_mul)) {
        mul = {d.color.cam_mul[0], d.color.cam_mul[1], d.color.cam_mul[2]};
        break;
      }
      out.warning = "the file has no as-shot white balance; daylight multipliers used";
      [[fallthrough]];
    case WhiteBalanceMode::kDaylight:
      if (Positive3(d.color.pre_mul))
        mul = {d.color.pre_mul[0], d.color.pre_mul[1], d.color.pre_mul[2]};
      else
        out.warning = "the file has no daylight white balance; multipliers 1, 1, 1 used";
      break;
    case WhiteBalanceMode::kNone:
      break;
    case WhiteBalanceMode::kUser:
      mul = o.user_wb;
      break;
  }
  if (d.idata.colors == 1) mul = Eigen::Vector3d::Ones();
  mul /= mul.minCoeff();
  out.wb_multipliers = mul;

  libraw_output_params_t& p = d.params;
  p.gamm[0] = p.gamm[1] = 1.0;  // linear output curve
  p.no_auto_bright = 1;
  p.bright = 1.0f;
  p.output_bps = 16;
  // "Unclip": LibRaw scales by the largest multiplier, so no channel is pushed
  // past 16 bits (mode 0 would clip the red and blue highlights one stop early).
  p.highlight = 1;
  p.use_camera_wb = 0;
  p.use_auto_wb = 0;
  p.user_mul[0] = static_cast<float>(mul[0]);
  p.user_mul[1] = static_cast<float>(mul[1]);
  p.user_mul[2] = static_cast<float>(mul[2]);
  p.user_mul[3] = static_cast<float>(mul[1]);
  p.output_color = 0;  // camera RGB; the matrix is applied below, after the clip test
  p.user_qual = o.demosaic;
  p.half_size = o.half_size ? 1 : 0;
  p.adjust_maximum_thr = 0.0f;  // the file's white level, not the brightest pixel
  rc = raw->dcraw_process();
  if (rc != LIBRAW_SUCCESS) throw fail("cannot process the raw data", rc);
  int err = 0;
  std::unique_ptr<libraw_processed_image_t, MemImageDeleter> mem(raw->dcraw_make_mem_image(&err));
  if (!mem) throw fail("cannot build the output image", err);
  if (mem->type != LIBRAW_IMAGE_BITMAP || mem->bits != 16 || (mem->colors != 3 && mem->colors != 1))
    throw InputError(path.string(), "LibRaw produced an unexpected image layout");

  // LibRaw maps raw white of channel c to 65535 * mul_c / max(mul); we want
  // the least-amplified channel's white at 1.
  const double to_unit = mul.maxCoeff() / 65535.0;
  const int w = mem->width, h = mem->height, nc = mem->colors;
  const auto* px = reinterpret_cast<const uint16_t*>(mem->data);
  Eigen::Matrix3d rgb_cam;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) rgb_cam(i, j) = d.color.rgb_cam[i][j];
  out.has_colour_matrix = nc == 3 && !rgb_cam.isIdentity(1e-6);
  const bool to_srgb = o.colour == RawColourSpace::kSrgb && out.has_colour_matrix;
  if (o.colour == RawColourSpace::kSrgb && !out.has_colour_matrix && nc == 3 && out.warning.empty())
    out.warning = "LibRaw knows no colour matrix for this camera; the output is camera RGB";

  out.rgb = Image(w, h, 3);
  cv::Mat clip(h, w, CV_8UC1, cv::Scalar(0));
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const uint16_t* s = px + (static_cast<size_t>(y) * w + x) * nc;
      Eigen::Vector3d cam;
      for (int c = 0; c < 3; ++c) cam[c] = s[nc == 3 ? c : 0] * to_unit;
      bool clipped = false;
      for (int c = 0; c < 3; ++c) clipped |= cam[c] >= kRawClipFraction * mul[c];
      clip.at<unsigned char>(y, x) = clipped ? 1 : 0;
      const Eigen::Vector3d v = to_srgb ? Eigen::Vector3d(rgb_cam * cam) : cam;
      out.rgb.set_rgb(out.rgb.index(x, y), v.cast<float>());
    }
  const int r = o.half_size ? 1 : kRawClipDilatePx;
  cv::dilate(clip, clip, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * r + 1, 2 * r + 1)));
  out.clipped = Image(w, h, 1);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) out.clipped.at(x, y, 0) = clip.at<unsigned char>(y, x);
  return out;
}

}  // namespace shadowsg
