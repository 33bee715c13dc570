// What `shadowsg bench` measured, shared by its parts: the method grid
// (runner.h), the perturbed re-solves (perturbations.h), and the tables,
// charts and page written from them (tables.h, charts.h, html.h).
// Paths in records are relative to the bench folder (DIR), so the tables and
// index.html can link them and the folder can be moved as a whole.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "stages/io/json_util.h"
#include "stages/solve_stage.h"

namespace shadowsg {

// One point of the method grid: a method and one of its settings.
struct BenchSetting {
  std::string method;   // sg | sg-paper | ss03 | ss03+ | sh21 (solve's --method)
  std::string setting;  // "fast", "lobes4", "1000", "h16": the part after the method in Name()
  std::string label;    // for tables: "fast", "4 lobes", "1000 steps", "16 rows"
  // Chart series: settings of one series are joined by a line ("sg budget",
  // "sg lobes", and the method name for the others).
  std::string series;
  SolveOptions solve;

  // "<method>-<setting>": the run folder's name and the CSV's run key.
  std::string Name() const { return method + "-" + setting; }
};

struct BenchScene {
  std::string name;                 // the folder's name; unique within a bench
  std::filesystem::path dir;        // as given (absolute when synthesised)
  bool has_env_gt = false;
  bool has_virtual_objects = false;  // image_virtual_objs.exr
  int plane_pixels = 0;
};

// One solve of one scene with one setting.
struct BenchRun {
  const BenchScene* scene = nullptr;
  BenchSetting setting;
  std::filesystem::path run_dir;  // relative to DIR: runs/<scene>/<setting name>
  Json metrics;                   // metrics.json; null when the run failed
  std::string error;              // one line when the run failed
  bool reused = false;            // metrics.json came from an earlier invocation

  bool ok() const { return error.empty() && metrics.is_object(); }
  // A number of metrics.json, or nullopt when absent or null.
  std::optional<double> Number(const std::string& key) const;
};

// An input perturbation of the stability study (perturbations.h).
struct Perturbation {
  std::string family;  // noise, clip, rotation, translation, normal, albedo, texture, spheretree, seed
  double size = 0;     // in `unit`; seed: the seed
  std::string unit;    // "%", "deg", "" (texture, spheretree, seed)
  std::string name;    // folder name: "noise-2", "rotation-3", "albedo-+10", "seed-4"
  std::string label;   // for tables: "noise 2 %", "caster rotation 3 deg"
  // Only the image changes: geometry, albedo and sphere tree are the clean
  // scene's (noise, clipping, texture, seeds).
  bool image_only = false;
  // Changes the input of every method; false for the sphere tree, which
  // only the SG methods use (the baselines ray-cast the mesh).
  bool affects_baselines = true;
};

// A re-solve under a perturbation, scored on the clean scene.
struct StabilityRun {
  const BenchScene* scene = nullptr;
  BenchSetting setting;
  Perturbation perturbation;
  std::filesystem::path run_dir;  // relative to DIR: the solve on the perturbed scene
  Json metrics;                   // scored against the UNPERTURBED scene (eval, or the solve for seeds)
  std::string error;
  bool reused = false;
  double clean_psnr = 0;  // the same setting on the clean scene

  bool ok() const { return error.empty() && metrics.is_object() && metrics.value("psnr", Json()).is_number(); }
  double Psnr() const { return metrics["psnr"].get<double>(); }
};

struct BenchReport {
  std::vector<BenchScene> scenes;
  std::vector<BenchRun> runs;
  int threads = 1;
  bool quick = false;
  std::string load_before, load_after;  // /proc/loadavg at the start and the end
  double seconds = 0;                    // wall time of the whole bench

  // --stability
  bool stability = false;
  std::vector<BenchSetting> stability_settings;
  std::vector<Perturbation> perturbations;
  std::vector<StabilityRun> stability_runs;
  std::string fail_rule;  // "ss03" or a number in dB, as given
  // Per scene (same order as scenes): the PSNR under which a run counts as failed.
  std::vector<std::optional<double>> fail_threshold;

  const BenchRun* FindRun(const BenchScene& scene, const std::string& setting_name) const;
};

}  // namespace shadowsg
