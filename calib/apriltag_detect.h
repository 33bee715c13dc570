// AprilTag detection (libapriltag 3; it stays in apriltag_detect.cc) and the
// tags' bit patterns (for printing them and for rendering test images).
#pragma once

#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

#include "calib/image.h"

namespace shadowsg {

struct TagDetectorOptions {
  std::string family = "tag36h11";
  // Quad detection on an image decimated by this factor (corners are refined
  // at full resolution). 0: automatic, 1 up to kAutoDecimateSide pixels, then
  // proportionally more.
  double decimate = 0.0;
  double blur_sigma = 0.0;   // Gaussian blur before quad detection (noisy images: 0.8)
  double sharpening = 0.25;  // libapriltag's decode_sharpening default
  int max_hamming = 1;       // bit errors accepted (the family allows up to 2 corrected)
  double min_margin = 15.0;  // decision margin below which a detection is dropped
  int threads = 1;

  bool IsValid(std::string* why) const;
};

inline constexpr int kAutoDecimateSide = 1600;

struct TagDetection {
  int id = -1;
  int hamming = 0;
  double decision_margin = 0.0;
  // Corners in pixels (centres at integers), libapriltag's order: with the tag
  // upright, bottom-left, bottom-right, top-right, top-left. In the tag frame
  // (x right, y down, z into the tag) they sit at (-s/2, s/2), (s/2, s/2),
  // (s/2, -s/2), (-s/2, -s/2), s the edge length of the black border square.
  std::array<Eigen::Vector2d, 4> corners;
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
};

// `image` is display-referred in [0, 1]. Throws InputError for an unknown family.
std::vector<TagDetection> DetectTags(const Image& image, const TagDetectorOptions& options);

// Names accepted as TagDetectorOptions::family.
std::vector<std::string> TagFamilies();

struct TagPattern {
  // cells x cells, row-major from the top-left cell of the upright tag: 1 white, 0 black.
  std::vector<unsigned char> cells;
  int total_width = 0;  // cells per side of the whole pattern
  // The detection corners are the outer corners of this many central cells
  // (the black border square; the tag size to measure).
  int border_width = 0;
  bool at(int col, int row) const { return cells[static_cast<size_t>(row) * total_width + col] != 0; }
};

// The printable pattern of tag `id` of `family` (libapriltag's apriltag_to_image).
TagPattern MakeTagPattern(const std::string& family, int id);
int TagFamilySize(const std::string& family);

}  // namespace shadowsg
