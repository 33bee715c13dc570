// Sub-pixel AprilTag corners from the tag's edges in LINEAR intensity.
//
// libapriltag places its quad edges at the strongest gradient of the image it
// is given; on a display-referred (sRGB-encoded) photo that maximum sits on
// the dark side of a blurred edge, so the black square comes out small: on
// 320x240 renders of a 40 px tag the corners land ~0.3 px inside and the edge
// ~1.2 % short, which becomes a 1.2 % error of any metric scale taken from
// the tag. Here each edge is re-located where the linear intensity crosses
// half-way between the black border and the white frame (a symmetric blur
// keeps that crossing on the true edge), a line is fitted per edge, and the
// corners are the lines' intersections.
#pragma once

#include <Eigen/Core>
#include <array>
#include <optional>

#include "calib/apriltag_detect.h"
#include "calib/image.h"

namespace shadowsg {

// The homography mapping src[k] to dst[k] (4 points, no three collinear).
Eigen::Matrix3d HomographyFrom4(const std::array<Eigen::Vector2d, 4>& src, const std::array<Eigen::Vector2d, 4>& dst);

// The pattern-to-image homography of a detection: pattern coordinates in
// cells, x right and y down from the top-left corner of the upright pattern
// (TagPattern's layout), image coordinates in pixels (centres at integers).
Eigen::Matrix3d TagPatternToImage(const TagDetection& detection, const TagPattern& pattern);

// Bilinear sample of channel-averaged `image` at (u, v) (centres at
// integers); nullopt outside the frame.
std::optional<double> SampleGrey(const Image& image, double u, double v);

// Refined corners (TagDetection's order) from `linear`, a linear-intensity
// image of the photo (sRGB photos: SrgbDecode them first). nullopt when an
// edge is too short, too faint or too poorly fitted; then keep the detector's.
std::optional<std::array<Eigen::Vector2d, 4>> RefineTagCorners(const Image& linear, const TagDetection& detection,
                                                                const TagPattern& pattern);

}  // namespace shadowsg
