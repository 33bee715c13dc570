// `shadowsg run CAPTURE_DIR`: a capture folder end to end. Reads
// capture.json (stages/io/capture_manifest_io.h) and chains the stages
//   intrinsics -> linearize -> plane (COLMAP) -> pose -> register -> solve -> composite
// into OUT (default CAPTURE_DIR/shadowsg): camera.json, linear.exr, plane.json,
// pose.json, scene/, solve/, composite/, and run_summary.json listing every
// artifact.
//
// Resuming. After a stage finishes, OUT/stamps/STAGE.json records its
// settings (the parts of capture.json that configure it, the input files, the
// seed where results depend on it) and its outputs. A later run skips the
// stage when the stamp's settings equal the current ones, every output
// exists, no input is newer than the oldest output, no stage it reads from
// was redone in this run, and it is not forced (`--force STAGE` or `all`).
// The stamp is removed before a stage runs, so one that fails or is
// interrupted is redone next time.
#pragma once

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "stages/io/json_util.h"
#include "stages/stage_context.h"

namespace shadowsg {

// The stages in the order they run.
inline const std::vector<std::string>& RunStageNames() {
  static const std::vector<std::string> names = {"intrinsics", "linearize", "plane",    "pose",
                                                 "register",   "solve",     "composite"};
  return names;
}

struct RunCaptureOptions {
  std::filesystem::path capture;  // the capture folder (or its capture.json)
  std::filesystem::path out;      // empty: CAPTURE_DIR/shadowsg
  std::vector<std::string> force;  // stage names to redo, or "all"

  // Message naming the bad option, or empty.
  std::string Validate() const;
};

struct RunStageReport {
  std::string name;
  std::string status;  // "ran", "skipped" (up to date), "given" (capture.json names the file), "off"
  std::string reason;  // why it ran, or why it did not
  double seconds = 0.0;
  std::vector<std::pair<std::string, std::filesystem::path>> artifacts;  // what, where
};

struct RunCaptureResult {
  std::vector<RunStageReport> stages;  // RunStageNames() order
  std::filesystem::path out_dir, summary_json;
  double seconds = 0.0;

  const RunStageReport& Stage(const std::string& name) const;
};

RunCaptureResult RunCapture(const RunCaptureOptions& options, const StageContext& ctx);

// The summary table (stage, status, seconds, artifacts) printed at the end.
std::string FormatRunSummary(const RunCaptureResult& result);

// ---- Resuming (exposed for tests) -------------------------------------------
struct StageRecord {
  Json settings;                              // what configures the stage (compared as a whole)
  std::vector<std::filesystem::path> inputs;  // files read (a missing one makes the stage stale)
  std::vector<std::filesystem::path> outputs;  // files written (all must exist)
};

// Why the stage must run given its stamp file, or "" when it is up to date.
// (Forcing and upstream reruns are RunCapture's.)
std::string StaleReason(const StageRecord& record, const std::filesystem::path& stamp);
void WriteStamp(const StageRecord& record, const std::filesystem::path& stamp, double seconds);

}  // namespace shadowsg
