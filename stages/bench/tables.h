// The tables of `shadowsg bench`: results.csv (one row per scene x method x
// setting, every metrics.json key), stability.csv, and results.md (a table per
// scene in the layout of the paper's Table 1, and the stability summary).
#pragma once

#include <filesystem>
#include <ostream>
#include <string>
#include <vector>

#include "stages/bench/bench_report.h"

namespace shadowsg {

// The metrics.json keys of cli.md, in the order the CSV puts them first.
extern const char* const kContractMetricKeys[13];

// Runs in table order: per scene, the paper's order of methods (ss03, ss03+,
// sh21, sg-paper, sg), settings in grid order.
std::vector<const BenchRun*> RunsInTableOrder(const BenchReport& report, const BenchScene& scene);

// CSV (RFC 4180 quoting). Leading columns scene, method, setting, run; then
// the contract keys; then every other key of any metrics.json (nested objects
// flattened as "report.key", arrays as JSON text); then run_dir, reused, error.
// A key a run lacks is an empty cell, as is JSON null.
void WriteResultsCsv(std::ostream& out, const BenchReport& report);
void WriteResultsCsv(const std::filesystem::path& path, const BenchReport& report);

// One row per stability run: scene, method, setting, perturbation, family,
// size, unit, clean_psnr, psnr, psnr_drop, failed, threshold, the eval's
// metrics, run_dir, error.
void WriteStabilityCsv(std::ostream& out, const BenchReport& report);
void WriteStabilityCsv(const std::filesystem::path& path, const BenchReport& report);

// A table as text, rendered to Markdown here and to HTML by html.h.
struct TextTable {
  std::vector<std::string> header;
  std::vector<bool> numeric;                 // right-aligned columns
  std::vector<std::vector<std::string>> rows;
  std::vector<std::vector<bool>> bold;       // per cell: the best of its column
  std::vector<std::string> notes;            // lines under the table (Markdown inline: `code`, **bold**)
};
std::string MarkdownTable(const TextTable& table);

// The paragraphs above the tables (Markdown inline): scenes, threads, machine
// load, what ran, reused and failed runs, what the columns mean.
std::vector<std::string> ReportNotes(const BenchReport& report);
// PSNR of the reference settings across scenes (only with several scenes).
std::optional<TextTable> OverviewTable(const BenchReport& report);
// The paper's Table 1 layout for one scene.
TextTable SceneTable(const BenchReport& report, const BenchScene& scene);
// The one-line description under a scene's heading.
std::string SceneLine(const BenchScene& scene);
// The stability study: its explanation, and PSNR drop per perturbation x method.
std::vector<std::string> StabilityNotes(const BenchReport& report);
TextTable StabilityTable(const BenchReport& report);

std::string ResultsMarkdown(const BenchReport& report);

// Stability summaries shared by results.md, the chart and index.html.
struct StabilityCell {
  int runs = 0, failed = 0, errors = 0;
  double mean_drop = 0, min_drop = 0, max_drop = 0;  // over scenes (and seeds)
  bool empty() const { return runs == 0; }
};
// All stability runs of `setting` under perturbations whose name matches
// `name` (or whose family is "seed" when name == "seed").
StabilityCell SummariseStability(const BenchReport& report, const BenchSetting& setting, const std::string& name);
// A stability run fails when it errors or scores below its threshold: with
// --fail-below ss03 (the default), the lower of SS03's clean PSNR on the scene
// and the run's own clean PSNR minus kFailMarginDb (it lost more than 3 dB AND
// ended below the plainest baseline with clean inputs); else the given dB.
inline constexpr double kFailMarginDb = 3;
std::optional<double> FailThreshold(const BenchReport& report, const StabilityRun& run);
bool StabilityRunFailed(const BenchReport& report, const StabilityRun& run);

// "ss03", "ss03+", "sh21" in upper case as in the paper; sg names unchanged.
std::string MethodDisplayName(const std::string& method);
// "12.34", "-" for nullopt.
std::string FormatNumber(std::optional<double> v, int decimals);

}  // namespace shadowsg
