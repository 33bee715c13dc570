// `--method sg-paper`: the published ShadowSG optimiser, reproduced as
// published (method-notes.md, "The paper's optimiser"; paper Sec. 3.3, 4):
// 256 lobes on a Fibonacci hemisphere, |a| and exp(-s) parametrisation, Adam
// at 1e-3 decayed by 0.9 every 5000 steps, 20000 steps of 1024 random plane
// pixels, pruning by amplitude and amplitude-gradient thresholds.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "solver/progress.h"
#include "solver/sg.h"
#include "solver/shadow_plane.h"

namespace shadowsg {

struct SgPaperOptions {
  int lobes = 256;
  int steps = 20000;
  int batch = 1024;
  double learning_rate = 1e-3;
  double lr_decay = 0.9;
  int lr_decay_every = 5000;
  int prune_every = 500;
  int prune_from = 500;
  int prune_until = 15000;
  double prune_amplitude = 0.005;       // max |a| below this (reference units) ...
  double prune_amplitude_grad = 0.001;  // ... and max |dL/da| below this: prune
  uint64_t seed = 0;

  bool IsValid(std::string* error) const;
};

struct SgSolveSummary {
  int iterations = 0;
  double final_loss = 0;
  int lobes_initial = 0;
  int lobes_kept = 0;
  int invalid_lobes_removed = 0;  // non-finite lobes dropped by the last guard
  double seconds = 0;
  std::vector<std::pair<int, double>> loss_history;  // (step, batch loss)
};

// Fits SG lighting to `targets` (observed radiance at model.points).
SgLighting SolveSgPaper(const ShadowPlaneModel& model, const std::vector<Eigen::Vector3f>& targets,
                        const SgPaperOptions& options, SgSolveSummary* summary, const ProgressFn& progress = {});

// Axes on a Fibonacci sphere, those below the plane mirrored above it (the
// reference code's initialisation).
std::vector<Eigen::Vector3d> FibonacciHemisphereAxes(int count, const Eigen::Vector3d& normal);

}  // namespace shadowsg
