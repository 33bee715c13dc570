// The method grid of `shadowsg bench` and the runs over it: every setting
// is solved in-process by RunSolve (the same code and metrics as `shadowsg
// solve`) into DIR/runs/<scene>/<method>-<setting>/.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "stages/bench/bench_report.h"
#include "stages/stage_context.h"

namespace shadowsg {

// Paper optimiser step counts of the default grid; 20000 (the published
// count) is added by GridOptions::full because it takes minutes to tens of
// minutes per scene on two cores.
inline constexpr int kPaperStepsDefault[] = {1000, 5000};
inline constexpr int kPaperStepsFull = 20000;
// --quick: enough steps to show sg-paper's start on the chart, within the
// quick bench's two minutes (a step costs 0.05-0.2 s on two cores).
inline constexpr int kPaperStepsQuick = 100;
// Forced lobe counts of the sg model-size sweep.
inline constexpr int kSgLobeSweep[] = {1, 2, 4, 8, 16, 32, 64};
inline constexpr int kSgQuickLobes[] = {1, 4};  // --quick, at the fast budget
// Baseline map heights (rows over the hemisphere; the map is rows x 4 rows).
inline constexpr int kSh21Heights[] = {8, 16, 32};
inline constexpr int kBaselineHeight = 16;  // ss03, ss03+ and the paper's maps (16 x 64)

struct GridOptions {
  bool full = false;   // sg-paper also at 20000 steps
  bool quick = false;  // a small grid for CI and demos (README "Benchmark (bench)")
};

// The methods of the default grid, in table order.
std::vector<std::string> DefaultBenchMethods();

// Expands --methods entries, each METHOD or METHOD:SETTING, into settings:
//   sg           fast, balanced, best and the forced-lobe sweep (quick: fast, 1 and 4 lobes at the fast budget)
//   sg:B         budget B (fast | balanced | best);  sg:N  N lobes forced (balanced budget)
//   sg-paper     1000 and 5000 steps (full: and 20000; quick: 100);  sg-paper:N  N steps
//   ss03, ss03+  16 rows;  ss03:N  N rows
//   sh21         8, 16 and 32 rows (quick: 16);  sh21:N  N rows
// Duplicates are dropped, order kept. InputError("--methods", ...) on a bad entry.
std::vector<BenchSetting> MethodGrid(const std::vector<std::string>& entries, const GridOptions& options);

// One setting from "METHOD:SETTING" (METHOD alone: its reference setting,
// sg balanced, sg-paper 1000, baselines 16 rows).
BenchSetting ParseBenchSetting(const std::string& entry);

// Solves `scene` with `setting` into bench_dir/run_dir unless that folder
// already holds a metrics.json (and !force). A failed solve is recorded in
// BenchRun::error (one line) rather than thrown; Interrupted propagates.
// `tag` prefixes the progress line ("[3/17]").
BenchRun RunBenchSetting(const BenchScene& scene, const BenchSetting& setting, const std::filesystem::path& bench_dir,
                         const std::filesystem::path& run_dir, bool force, const std::string& tag,
                         const StageContext& ctx);

// The context the inner stages get: the bench's threads, seed and progress
// bars, without their log lines (the bench prints one line per run);
// warnings still show.
StageContext InnerContext(const StageContext& ctx);

// Reads a JSON file that an earlier run wrote, or nullopt when it is missing
// or unreadable (the run is then redone).
std::optional<Json> ReadPreviousJson(const std::filesystem::path& path);

}  // namespace shadowsg
