// `shadowsg bench SCENE_DIR... --out DIR`: every method over every scene
// (runner.h), optionally the stability study (perturbations.h), then
// results.csv, results.md (tables.h), charts (charts.h) and index.html
// (html.h) in DIR. Resumable: a run whose metrics.json exists is reused
// unless `force`.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "stages/bench/bench_report.h"
#include "stages/stage_context.h"

namespace shadowsg {

struct BenchOptions {
  std::vector<std::filesystem::path> scene_dirs;  // empty with `quick`: the bundled sample
  std::filesystem::path out_dir;
  // METHOD or METHOD:SETTING entries (runner.h MethodGrid); empty: DefaultBenchMethods().
  std::vector<std::string> methods;
  bool full = false;    // sg-paper also at the published 20000 steps
  bool quick = false;   // small grid; synthesises the sample when no scene is given
  bool force = false;   // re-run runs whose metrics.json exists
  bool charts = true;   // false: no gnuplot (tables and index.html only)
  bool check_html = false;  // load index.html in headless Chromium
  // --stability
  bool stability = false;
  // METHOD[:SETTING] re-solved under each perturbation; empty: one reference
  // setting per method of the grid (sg balanced (quick: fast), sg-paper 1000,
  // baselines 16 rows).
  std::vector<std::string> stability_methods;
  int seeds = 10;
  // "ss03": a stability run fails below min(SS03's clean PSNR on the scene,
  // its own clean PSNR - 3 dB) (tables.h FailThreshold); or a PSNR in dB.
  std::string fail_below = "ss03";
  // The synth spec of the bundled sample (--quick without scenes).
  std::filesystem::path sample_spec;

  // Message naming the bad option, or empty.
  std::string Validate() const;
};

// The scale and samples of the sample scene that --quick synthesises.
inline constexpr double kQuickSampleScale = 0.5;
inline constexpr int kQuickSampleSpp = 16;

struct BenchSummary {
  int runs = 0, failed = 0, reused = 0;
  int stability_runs = 0, stability_failed = 0;  // failed: errored (not below the threshold)
  double seconds = 0;
};

// Runs the bench; writes DIR/results.csv, results.md, charts/, index.html
// (and stability.csv). Throws InputError for bad scenes/options before any run,
// and at the end (outputs written) when runs failed.
BenchSummary RunBench(const BenchOptions& options, const StageContext& ctx);

}  // namespace shadowsg
