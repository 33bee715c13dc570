// Runs the real COLMAP program (Debian's `colmap` 3.8 CLI; there is no
// library to link) for a sparse reconstruction on the CPU: feature
// extraction, matching and mapping, streaming its output to the log, a full
// copy to WORKSPACE/colmap.log, and its progress to a progress bar.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "calib/camera.h"
#include "stages/stage_context.h"

namespace shadowsg {

struct ColmapRunOptions {
  std::string executable = "colmap";   // a name looked up on PATH, or a path
  std::filesystem::path images;        // COLMAP's --image_path
  std::vector<std::string> image_names;  // relative to `images`; empty: every image COLMAP finds there
  std::filesystem::path workspace;     // database.db, sparse/, image_list.txt, colmap.log
  // Known intrinsics (camera.json): an OPENCV camera (FULL_OPENCV when k3 != 0)
  // shared by all images and held fixed by the bundle adjustment.
  std::optional<Camera> camera;
  std::string camera_model = "SIMPLE_RADIAL";  // without known intrinsics (COLMAP's default)
  std::string matcher = "exhaustive";          // "exhaustive" or "sequential" (video-like order)
  int max_image_size = 3200;                   // SiftExtraction.max_image_size (COLMAP's default)
  // SiftExtraction.max_num_features (COLMAP's default). CPU matching is brute
  // force, so its time grows with the square of this.
  int max_features = 8192;
  int threads = 1;
  uint64_t seed = 0;                           // COLMAP's --random_seed

  // Message naming the bad option, or empty.
  std::string Validate() const;
};

// The exact command lines RunColmap executes, in order (argv[0] = executable).
std::vector<std::vector<std::string>> ColmapCommands(const ColmapRunOptions& options);

struct ColmapRunResult {
  std::filesystem::path sparse_dir;         // WORKSPACE/sparse, holding 0/, 1/, ... (one per model)
  std::filesystem::path log;                // WORKSPACE/colmap.log
  double seconds = 0;                       // wall time of the three programs
};

// An executable's full path: `name` itself when it contains a '/', else the
// first match on PATH; nullopt when there is none.
std::optional<std::filesystem::path> FindExecutable(const std::string& name);

// Throws InputError with one line when colmap is missing ("not found on
// PATH"), or a program fails (its exit status and last output line). Removes
// a database.db and sparse/ left in the workspace by an earlier run first.
ColmapRunResult RunColmap(const ColmapRunOptions& options, const StageContext& ctx);

// Runs argv (argv[0] looked up on PATH), calling on_line for every line of its
// merged stdout and stderr as it arrives; returns its exit status (128 + n
// when killed by signal n). `extra_env` entries ("NAME=value") are added to
// the environment. Stops the child and throws Interrupted on SIGINT/SIGTERM.
int RunProcess(const std::vector<std::string>& argv, const std::vector<std::string>& extra_env,
               const std::function<void(const std::string& line)>& on_line);

}  // namespace shadowsg
