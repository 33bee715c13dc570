// A grid search for the lobe that casts the strongest shadow. Levenberg-
// Marquardt moves a sharp lobe only as far as its shadow's edge still
// overlaps the observed one: a sun whose shadow (or the hole in it) lands a
// few degrees off stays there. On pub_torus_sunrise (sun 4-8 degrees above
// the horizon, shadow longer than the view) the size path left the sun 3
// degrees low and split over three blurred lobes on some pixel draws (37.4
// dB) and reached 39.6 dB on others. Here the lobe is tried at every point
// of a grid of elevations, azimuths and sharpness values around it, every
// amplitude re-solved by non-negative least squares (linear for fixed axes),
// and moved to the grid point of lowest weighted fit error.
#pragma once

#include <vector>

#include "solver/sg.h"
#include "solver/shadow_plane.h"

namespace shadowsg {

struct LobeScanOptions {
  double min_sharpness = 30;  // broader lobes cast no shadow edge to place
  double elevation_range_deg = 10, elevation_step_deg = 1;
  double azimuth_range_deg = 3, azimuth_step_deg = 1;
  std::vector<double> sharpness_factors = {0.5, 1, 2};
  // A grid point must lower the fit error by this fraction to count as a move.
  double min_gain = 0.01;
};

struct LobeScanResult {
  int lobe = -1;              // the lobe scanned (index into the input), -1: none sharp enough
  bool moved = false;         // a grid point other than the lobe's own fits better by min_gain
  double elevation_shift_deg = 0, azimuth_shift_deg = 0, sharpness_factor = 1;
  double error_before = 0, error_after = 0;  // weighted sum of squares, amplitudes by NNLS
};

// Scans the lobe of *lighting with the most unoccluded light on the plane
// among those at least min_sharpness sharp. When a grid point beats the
// lobe's own place, *lighting gets that lobe there (last in the list) and
// every amplitude from the NNLS of that grid point. weight: per point of
// `model`, targets likewise.
LobeScanResult ScanBrightestSharpLobe(const ShadowPlaneModel& model, const std::vector<double>& weight,
                                      const std::vector<Eigen::Vector3f>& targets, SgLighting* lighting,
                                      const LobeScanOptions& options = {});

}  // namespace shadowsg
