#include "calib/hdr_merge.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <opencv2/photo.hpp>

#include "calib/error.h"
#include "calib/internal/opencv_bridge.h"

namespace shadowsg {

bool LdrStackOptions::IsValid(std::string* why) const {
  if (debevec_samples < 10) {
    *why = "Debevec needs at least 10 samples";
    return false;
  }
  if (!(debevec_lambda > 0)) {
    *why = "the Debevec smoothness weight must be positive";
    return false;
  }
  if (robertson_iterations < 1) {
    *why = "Robertson needs at least one iteration";
    return false;
  }
  return true;
}

namespace {

constexpr int kLdrLevels = 256;

float SrgbToLinear(float v) { return v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f); }

int Code(float v) { return static_cast<int>(std::lround(std::clamp(v, 0.0f, 1.0f) * 255.0f)); }

cv::Mat ToBgr8(const Image& img) {
  cv::Mat m(img.height, img.width, CV_8UC3);
  for (int y = 0; y < img.height; ++y) {
    auto* row = m.ptr<cv::Vec3b>(y);
    for (int x = 0; x < img.width; ++x) {
      const Eigen::Vector3f v = img.rgb(img.index(x, y));
      row[x] = cv::Vec3b(static_cast<unsigned char>(Code(v.z())), static_cast<unsigned char>(Code(v.y())),
                         static_cast<unsigned char>(Code(v.x())));
    }
  }
  return m;
}

void CheckStack(size_t n_images, size_t n_times, const std::vector<Image>& images) {
  if (n_images < 2) throw InputError("exposure stack", "needs at least 2 images");
  if (n_times != n_images)
    throw InputError("exposure stack",
                     std::to_string(n_images) + " images but " + std::to_string(n_times) + " exposure times");
  for (const auto& im : images)
    if (im.width != images[0].width || im.height != images[0].height)
      throw InputError("exposure stack", "images differ in size (" + std::to_string(im.width) + "x" +
                                             std::to_string(im.height) + " vs " + std::to_string(images[0].width) +
                                             "x" + std::to_string(images[0].height) + ")");
}

void CheckTimes(const std::vector<double>& times) {
  for (double t : times)
    if (!(t > 0) || !std::isfinite(t)) throw InputError("exposure stack", "exposure times must be positive");
}

// Saturated where the shortest exposure is; black where the longest is.
Image LdrClipMask(const std::vector<cv::Mat>& bgr, const std::vector<double>& times) {
  const size_t shortest = std::min_element(times.begin(), times.end()) - times.begin();
  const size_t longest = std::max_element(times.begin(), times.end()) - times.begin();
  Image mask(bgr[0].cols, bgr[0].rows, 1);
  for (int y = 0; y < mask.height; ++y)
    for (int x = 0; x < mask.width; ++x) {
      const cv::Vec3b s = bgr[shortest].at<cv::Vec3b>(y, x);
      const cv::Vec3b l = bgr[longest].at<cv::Vec3b>(y, x);
      if (std::max({s[0], s[1], s[2]}) >= kLdrSaturatedCode)
        mask.at(x, y, 0) = kMaskSaturated;
      else if (std::max({l[0], l[1], l[2]}) <= kLdrBlackCode)
        mask.at(x, y, 0) = kMaskUnderexposed;
    }
  return mask;
}

}  // namespace

HdrResult LinearizeSrgb(const Image& ldr) {
  HdrResult r;
  r.radiance = Image(ldr.width, ldr.height, 3);
  r.clipped = Image(ldr.width, ldr.height, 1);
  for (size_t p = 0; p < ldr.pixels(); ++p) {
    const Eigen::Vector3f v = ldr.rgb(p);
    r.radiance.set_rgb(p, Eigen::Vector3f(SrgbToLinear(v.x()), SrgbToLinear(v.y()), SrgbToLinear(v.z())));
    const int hi = std::max({Code(v.x()), Code(v.y()), Code(v.z())});
    if (hi >= kLdrSaturatedCode)
      r.clipped.data[p] = kMaskSaturated;
    else if (hi <= kLdrBlackCode)
      r.clipped.data[p] = kMaskUnderexposed;
  }
  return r;
}

HdrResult MergeLdrStack(const std::vector<Image>& images, const std::vector<double>& times, const LdrStackOptions& o) {
  std::string why;
  if (!o.IsValid(&why)) throw InputError("exposure stack", why);
  CheckStack(images.size(), times.size(), images);
  CheckTimes(times);
  std::vector<cv::Mat> bgr;
  for (const auto& im : images) bgr.push_back(ToBgr8(im));
  if (o.align) cv::createAlignMTB()->process(std::vector<cv::Mat>(bgr), bgr);

  HdrResult r;
  r.clipped = LdrClipMask(bgr, times);
  if (o.method == ResponseMethod::kSrgb) {
    std::vector<Image> linear, masks;
    for (const auto& m : bgr) {
      Image ldr(m.cols, m.rows, 3);
      for (int y = 0; y < m.rows; ++y)
        for (int x = 0; x < m.cols; ++x) {
          const cv::Vec3b v = m.at<cv::Vec3b>(y, x);
          ldr.set_rgb(ldr.index(x, y), Eigen::Vector3f(v[2], v[1], v[0]) / 255.0f);
        }
      HdrResult one = LinearizeSrgb(ldr);
      for (float& c : one.clipped.data) c = c == kMaskSaturated ? 1.0f : 0.0f;  // only highlights exclude
      linear.push_back(std::move(one.radiance));
      masks.push_back(std::move(one.clipped));
    }
    HdrResult merged = MergeLinearStack(linear, masks, times, false);
    merged.clipped = r.clipped;
    return merged;
  }

  std::vector<float> t32(times.begin(), times.end());
  cv::Mat response, hdr;
  try {
    if (o.method == ResponseMethod::kDebevec) {
      cv::createCalibrateDebevec(o.debevec_samples, o.debevec_lambda, false)->process(bgr, response, t32);
      cv::createMergeDebevec()->process(bgr, hdr, t32, response);
    } else {
      auto cal = cv::createCalibrateRobertson(o.robertson_iterations);
      cal->process(bgr, response, t32);
      cv::createMergeRobertson()->process(bgr, hdr, t32, response);
    }
  } catch (const cv::Exception& e) {
    throw InputError("exposure stack", "response recovery failed: " + e.err);
  }
  // OpenCV's radiance reads 1 for code 128 at exposure 1; scale to the first
  // input's exposure.
  const float scale = static_cast<float>(times[0]);
  r.radiance = Image(hdr.cols, hdr.rows, 3);
  for (int y = 0; y < hdr.rows; ++y)
    for (int x = 0; x < hdr.cols; ++x) {
      const cv::Vec3f v = hdr.at<cv::Vec3f>(y, x);
      r.radiance.set_rgb(r.radiance.index(x, y), Eigen::Vector3f(v[2], v[1], v[0]) * scale);
    }
  for (int c = 0; c < 3; ++c) {
    r.response[c].resize(kLdrLevels);
    for (int z = 0; z < kLdrLevels; ++z) r.response[c][z] = response.at<cv::Vec3f>(z)[2 - c];
  }
  return r;
}

HdrResult MergeLinearStack(const std::vector<Image>& images, const std::vector<Image>& clipped,
                           const std::vector<double>& times, bool align) {
  CheckStack(images.size(), times.size(), images);
  CheckTimes(times);
  SHADOWSG_CHECK(clipped.size() == images.size());
  std::vector<Image> imgs = images, masks = clipped;
  if (align) {
    // Shifts from the median-threshold bitmaps of display-encoded copies.
    auto mtb = cv::createAlignMTB();
    std::vector<cv::Mat> gray;
    for (const auto& im : images) {
      Image enc(im.width, im.height, 3);
      for (size_t p = 0; p < im.pixels(); ++p) {
        const Eigen::Vector3f v = im.rgb(p);
        for (int c = 0; c < 3; ++c) {
          const float x = std::clamp(v[c], 0.0f, 1.0f);
          enc.data[p * 3 + c] = x <= 0.0031308f ? 12.92f * x : 1.055f * std::pow(x, 1.0f / 2.4f) - 0.055f;
        }
      }
      gray.push_back(internal::ToGray8(enc));
    }
    for (size_t i = 1; i < imgs.size(); ++i) {
      const cv::Point shift = mtb->calculateShift(gray[0], gray[i]);
      cv::Mat a = internal::ToCvFloat(imgs[i]), b = internal::ToCvFloat(masks[i]), as, bs;
      mtb->shiftMat(a, as, shift);
      mtb->shiftMat(b, bs, shift);
      imgs[i] = internal::FromCvFloat(as);
      masks[i] = internal::FromCvFloat(bs);
    }
  }
  HdrResult r;
  const int w = images[0].width, h = images[0].height;
  r.radiance = Image(w, h, 3);
  r.clipped = Image(w, h, 1);
  const size_t shortest = std::min_element(times.begin(), times.end()) - times.begin();
  for (size_t p = 0; p < r.radiance.pixels(); ++p) {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    double tsum = 0;
    for (size_t i = 0; i < imgs.size(); ++i) {
      if (masks[i].data[p] > 0) continue;
      sum += imgs[i].rgb(p).cast<double>();
      tsum += times[i] / times[0];
    }
    if (tsum > 0) {
      r.radiance.set_rgb(p, (sum / tsum).cast<float>());
    } else {
      r.radiance.set_rgb(p, imgs[shortest].rgb(p) * static_cast<float>(times[0] / times[shortest]));
      r.clipped.data[p] = kMaskSaturated;
    }
  }
  return r;
}

}  // namespace shadowsg
