#include "calib/apriltag_detect.h"

#include <apriltag/apriltag.h>
#include <apriltag/common/zarray.h>
#include <apriltag/tag16h5.h>
#include <apriltag/tag25h9.h>
#include <apriltag/tag36h10.h>
#include <apriltag/tag36h11.h>
#include <apriltag/tagCircle21h7.h>
#include <apriltag/tagCircle49h12.h>
#include <apriltag/tagCustom48h12.h>
#include <apriltag/tagStandard41h12.h>
#include <apriltag/tagStandard52h13.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <opencv2/core.hpp>

#include "calib/conventions.h"
#include "calib/error.h"
#include "calib/internal/opencv_bridge.h"

namespace shadowsg {
namespace {

struct Family {
  const char* name;
  apriltag_family_t* (*create)();
  void (*destroy)(apriltag_family_t*);
};

const Family kFamilies[] = {
    {"tag36h11", tag36h11_create, tag36h11_destroy},
    {"tag36h10", tag36h10_create, tag36h10_destroy},
    {"tag25h9", tag25h9_create, tag25h9_destroy},
    {"tag16h5", tag16h5_create, tag16h5_destroy},
    {"tagCircle21h7", tagCircle21h7_create, tagCircle21h7_destroy},
    {"tagCircle49h12", tagCircle49h12_create, tagCircle49h12_destroy},
    {"tagStandard41h12", tagStandard41h12_create, tagStandard41h12_destroy},
    {"tagStandard52h13", tagStandard52h13_create, tagStandard52h13_destroy},
    {"tagCustom48h12", tagCustom48h12_create, tagCustom48h12_destroy},
};

// Owns a family for the scope of a call.
class FamilyHandle {
 public:
  explicit FamilyHandle(const std::string& name) {
    for (const auto& f : kFamilies)
      if (name == f.name) {
        family_ = &f;
        tf_ = f.create();
        return;
      }
    std::string known;
    for (const auto& f : kFamilies) known += (known.empty() ? "" : ", ") + std::string(f.name);
    throw InputError("--tag-family", "unknown AprilTag family \"" + name + "\" (known: " + known + ")");
  }
  ~FamilyHandle() {
    if (tf_) family_->destroy(tf_);
  }
  FamilyHandle(const FamilyHandle&) = delete;
  FamilyHandle& operator=(const FamilyHandle&) = delete;
  apriltag_family_t* get() const { return tf_; }

 private:
  const Family* family_ = nullptr;
  apriltag_family_t* tf_ = nullptr;
};

// Bits the detector corrects: libapriltag's default for the families (2).
constexpr int kCorrectedBits = 2;

}  // namespace

bool TagDetectorOptions::IsValid(std::string* why) const {
  if (decimate < 0 || (decimate > 0 && decimate < 1)) {
    *why = "decimation must be 0 (automatic) or at least 1";
    return false;
  }
  if (blur_sigma < 0) {
    *why = "the blur sigma must not be negative";
    return false;
  }
  if (max_hamming < 0 || max_hamming > kCorrectedBits) {
    *why = "max_hamming must be between 0 and 2";
    return false;
  }
  if (threads < 1) {
    *why = "threads must be positive";
    return false;
  }
  return true;
}

std::vector<std::string> TagFamilies() {
  std::vector<std::string> names;
  for (const auto& f : kFamilies) names.push_back(f.name);
  return names;
}

std::vector<TagDetection> DetectTags(const Image& image, const TagDetectorOptions& o) {
  std::string why;
  if (!o.IsValid(&why)) throw InputError("tag detector", why);
  FamilyHandle family(o.family);
  std::unique_ptr<apriltag_detector_t, void (*)(apriltag_detector_t*)> td(apriltag_detector_create(),
                                                                          apriltag_detector_destroy);
  apriltag_detector_add_family_bits(td.get(), family.get(), kCorrectedBits);
  const int side = std::max(image.width, image.height);
  td->quad_decimate = static_cast<float>(
      o.decimate > 0 ? o.decimate : std::max(1.0, std::floor(static_cast<double>(side) / kAutoDecimateSide)));
  td->quad_sigma = static_cast<float>(o.blur_sigma);
  td->decode_sharpening = o.sharpening;
  td->refine_edges = true;
  td->nthreads = o.threads;

  cv::Mat gray = internal::ToGray8(image);
  image_u8_t im{gray.cols, gray.rows, static_cast<int32_t>(gray.step[0]), gray.data};
  zarray_t* found = apriltag_detector_detect(td.get(), &im);
  std::vector<TagDetection> out;
  for (int i = 0; i < zarray_size(found); ++i) {
    apriltag_detection_t* det = nullptr;
    zarray_get(found, i, &det);
    if (det->hamming > o.max_hamming || det->decision_margin < o.min_margin) continue;
    TagDetection t;
    t.id = det->id;
    t.hamming = det->hamming;
    t.decision_margin = det->decision_margin;
    for (int k = 0; k < 4; ++k) t.corners[k] = AprilTagToOpenCvPixel({det->p[k][0], det->p[k][1]});
    t.centre = AprilTagToOpenCvPixel({det->c[0], det->c[1]});
    out.push_back(t);
  }
  apriltag_detections_destroy(found);
  std::sort(out.begin(), out.end(), [](const TagDetection& a, const TagDetection& b) {
    return a.id != b.id ? a.id < b.id : a.decision_margin > b.decision_margin;
  });
  return out;
}

int TagFamilySize(const std::string& name) {
  FamilyHandle family(name);
  return static_cast<int>(family.get()->ncodes);
}

TagPattern MakeTagPattern(const std::string& name, int id) {
  FamilyHandle family(name);
  apriltag_family_t* tf = family.get();
  if (id < 0 || id >= static_cast<int>(tf->ncodes))
    throw InputError("tag id",
                     std::to_string(id) + " is not in " + name + " (ids 0.." + std::to_string(tf->ncodes - 1) + ")");
  // The layout of libapriltag's apriltag_to_image (which cannot be used
  // directly: its image type's destructor is not exported): a one-cell white
  // ring around the black border square (inside it for reversed-border
  // families), the data bits at (bit_x, bit_y) from the border square's corner,
  // everything else black.
  const int total = tf->total_width, wab = tf->width_at_border;
  TagPattern p;
  p.total_width = total;
  p.border_width = wab;
  p.cells.assign(static_cast<size_t>(total) * total, 0);
  const auto set = [&](uint32_t x, uint32_t y) {
    if (x < static_cast<uint32_t>(total) && y < static_cast<uint32_t>(total)) p.cells[size_t(y) * total + x] = 1;
  };
  const int white_width = wab + (tf->reversed_border ? 0 : 2);
  const int white_start = (total - white_width) / 2;
  for (int i = 0; i < white_width; ++i) {
    set(white_start + i, white_start);
    set(white_start + i, white_start + white_width - 1);
    set(white_start, white_start + i);
    set(white_start + white_width - 1, white_start + i);
  }
  // bit_x/bit_y are unsigned and wrap for bits outside the border square;
  // adding the offset in unsigned arithmetic wraps them back.
  const uint32_t border_start = static_cast<uint32_t>((total - wab) / 2);
  for (uint32_t i = 0; i < tf->nbits; ++i)
    if (tf->codes[id] & (uint64_t{1} << (tf->nbits - i - 1)))
      set(tf->bit_x[i] + border_start, tf->bit_y[i] + border_start);
  return p;
}

}  // namespace shadowsg
