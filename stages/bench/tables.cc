#include "stages/bench/tables.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>
#include <sstream>

#include "calib/error.h"
#include "stages/io/atomic_file.h"

namespace shadowsg {
namespace fs = std::filesystem;

const char* const kContractMetricKeys[13] = {
    "psnr",      "ssim",     "rel_rmse",      "env_angular_error_deg", "irradiance_rel_rmse",
    "insert_psnr", "insert_ssim", "n_lobes",   "n_params",              "solve_seconds",
    "total_seconds", "threads", "plane_pixels"};

namespace {

// The paper's Table 1 order: baselines first, then the SG methods.
int MethodRank(const std::string& m) {
  static const char* kOrder[] = {"ss03", "ss03+", "sh21", "sg-paper", "sg"};
  for (int i = 0; i < 5; ++i)
    if (m == kOrder[i]) return i;
  return 5;
}

std::string CsvField(const std::string& s) {
  if (s.find_first_of(",\"\n\r") == std::string::npos) return s;
  std::string q = "\"";
  for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + "\"";
}

std::string CsvValue(const Json& v) {
  if (v.is_null()) return "";
  if (v.is_string()) return v.get<std::string>();
  if (v.is_boolean()) return v.get<bool>() ? "true" : "false";
  if (v.is_number_integer() || v.is_number_unsigned()) return v.dump();
  if (v.is_number_float()) {
    char buf[40];
    std::snprintf(buf, sizeof buf, "%.9g", v.get<double>());
    return buf;
  }
  return v.dump();  // arrays (and anything else) as JSON text
}

// metrics.json flattened one level: {"report": {"a": 1}} -> "report.a".
std::map<std::string, Json> Flatten(const Json& m) {
  std::map<std::string, Json> out;
  if (!m.is_object()) return out;
  for (auto it = m.begin(); it != m.end(); ++it) {
    if (it->is_object()) {
      for (auto jt = it->begin(); jt != it->end(); ++jt) out[it.key() + "." + jt.key()] = *jt;
    } else {
      out[it.key()] = *it;
    }
  }
  return out;
}

void WriteCsvRow(std::ostream& out, const std::vector<std::string>& cells) {
  for (size_t i = 0; i < cells.size(); ++i) out << (i ? "," : "") << CsvField(cells[i]);
  out << "\n";
}

void WriteFile(const fs::path& path, const std::function<void(std::ostream&)>& write) {
  std::ostringstream text;
  write(text);
  WriteTextAtomically(path, text.str());
}

// The setting that stands for a method in the overview and the stability
// table: sg balanced, the longest sg-paper run, the baselines at 16 rows;
// else the method's first setting in the grid.
std::vector<BenchSetting> ReferenceSettings(const BenchReport& r) {
  std::vector<BenchSetting> grid;  // distinct settings in run order
  for (const BenchRun& run : r.runs)
    if (std::none_of(grid.begin(), grid.end(), [&](const BenchSetting& s) { return s.Name() == run.setting.Name(); }))
      grid.push_back(run.setting);
  std::vector<BenchSetting> out;
  std::set<std::string> methods_done;
  for (const BenchSetting& s : grid) {
    if (methods_done.count(s.method)) continue;
    methods_done.insert(s.method);
    const BenchSetting* pick = &s;
    for (const BenchSetting& t : grid) {
      if (t.method != s.method) continue;
      if (t.method == "sg" && t.setting == "balanced") pick = &t;
      if (t.method == "sg-paper" && t.solve.steps > pick->solve.steps) pick = &t;
      if ((t.method == "ss03" || t.method == "ss03+" || t.method == "sh21") && t.solve.map_height == 16) pick = &t;
    }
    out.push_back(*pick);
  }
  std::stable_sort(out.begin(), out.end(),
                   [](const BenchSetting& a, const BenchSetting& b) { return MethodRank(a.method) < MethodRank(b.method); });
  return out;
}

std::string Bold(const std::string& s, bool b) { return b ? "**" + s + "**" : s; }

}  // namespace

std::string MethodDisplayName(const std::string& m) {
  if (m == "ss03") return "SS03";
  if (m == "ss03+") return "SS03+";
  if (m == "sh21") return "SH21";
  return m;
}

std::string FormatNumber(std::optional<double> v, int decimals) {
  if (!v || !std::isfinite(*v)) return "-";
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.*f", decimals, *v);
  return buf;
}

std::vector<const BenchRun*> RunsInTableOrder(const BenchReport& report, const BenchScene& scene) {
  std::vector<const BenchRun*> out;
  for (const BenchRun& r : report.runs)
    if (r.scene == &scene) out.push_back(&r);
  std::stable_sort(out.begin(), out.end(), [](const BenchRun* a, const BenchRun* b) {
    return MethodRank(a->setting.method) < MethodRank(b->setting.method);
  });
  return out;
}

void WriteResultsCsv(std::ostream& out, const BenchReport& report) {
  std::vector<std::string> columns = {"scene", "method", "setting", "run"};
  const std::set<std::string> leading(columns.begin(), columns.end());
  std::set<std::string> contract(std::begin(kContractMetricKeys), std::end(kContractMetricKeys));
  for (const char* k : kContractMetricKeys) columns.push_back(k);
  std::set<std::string> others;
  std::vector<std::map<std::string, Json>> flat;
  for (const BenchRun& r : report.runs) {
    flat.push_back(Flatten(r.metrics));
    for (const auto& [k, v] : flat.back())
      if (!leading.count(k) && !contract.count(k)) others.insert(k);
  }
  columns.insert(columns.end(), others.begin(), others.end());
  for (const char* k : {"run_dir", "reused", "error"}) columns.push_back(k);
  WriteCsvRow(out, columns);
  for (size_t i = 0; i < report.runs.size(); ++i) {
    const BenchRun& r = report.runs[i];
    std::vector<std::string> cells = {r.scene->name, r.setting.method, r.setting.setting, r.setting.Name()};
    for (size_t c = 4; c < columns.size() - 3; ++c) {
      const auto it = flat[i].find(columns[c]);
      cells.push_back(it == flat[i].end() ? "" : CsvValue(it->second));
    }
    cells.push_back(r.run_dir.generic_string());
    cells.push_back(r.reused ? "true" : "false");
    cells.push_back(r.error);
    WriteCsvRow(out, cells);
  }
}

void WriteResultsCsv(const fs::path& path, const BenchReport& report) {
  WriteFile(path, [&](std::ostream& out) { WriteResultsCsv(out, report); });
}

std::optional<double> FailThreshold(const BenchReport& report, const StabilityRun& run) {
  std::optional<double> scene_threshold;
  for (size_t i = 0; i < report.scenes.size(); ++i)
    if (&report.scenes[i] == run.scene && i < report.fail_threshold.size()) scene_threshold = report.fail_threshold[i];
  if (!scene_threshold) return std::nullopt;
  if (report.fail_rule != "ss03") return scene_threshold;
  return std::min(*scene_threshold, run.clean_psnr - kFailMarginDb);
}

bool StabilityRunFailed(const BenchReport& report, const StabilityRun& run) {
  if (!run.ok()) return true;
  const std::optional<double> threshold = FailThreshold(report, run);
  return threshold && run.Psnr() < *threshold;
}

void WriteStabilityCsv(std::ostream& out, const BenchReport& report) {
  static const char* kEvalKeys[] = {"ssim", "rel_rmse", "env_angular_error_deg", "irradiance_rel_rmse"};
  std::vector<std::string> columns = {"scene",      "method", "setting", "run",       "perturbation", "family",
                                      "size",       "unit",   "clean_psnr", "psnr",   "psnr_drop",   "failed",
                                      "fail_threshold"};
  for (const char* k : kEvalKeys) columns.push_back(k);
  columns.push_back("run_dir");
  columns.push_back("error");
  WriteCsvRow(out, columns);
  for (const StabilityRun& r : report.stability_runs) {
    const std::optional<double> threshold = FailThreshold(report, r);
    char size[32];
    std::snprintf(size, sizeof size, "%g", r.perturbation.size);
    std::vector<std::string> cells = {r.scene->name,
                                      r.setting.method,
                                      r.setting.setting,
                                      r.setting.Name(),
                                      r.perturbation.name,
                                      r.perturbation.family,
                                      size,
                                      r.perturbation.unit,
                                      CsvValue(Json(r.clean_psnr)),
                                      r.ok() ? CsvValue(Json(r.Psnr())) : "",
                                      r.ok() ? CsvValue(Json(r.clean_psnr - r.Psnr())) : "",
                                      StabilityRunFailed(report, r) ? "true" : "false",
                                      threshold ? CsvValue(Json(*threshold)) : ""};
    for (const char* k : kEvalKeys) cells.push_back(r.metrics.is_object() ? CsvValue(r.metrics.value(k, Json())) : "");
    cells.push_back(r.run_dir.generic_string());
    cells.push_back(r.error);
    WriteCsvRow(out, cells);
  }
}

void WriteStabilityCsv(const fs::path& path, const BenchReport& report) {
  WriteFile(path, [&](std::ostream& out) { WriteStabilityCsv(out, report); });
}

StabilityCell SummariseStability(const BenchReport& report, const BenchSetting& setting, const std::string& name) {
  StabilityCell c;
  double sum = 0;
  int scored = 0;
  for (const StabilityRun& r : report.stability_runs) {
    if (r.setting.Name() != setting.Name()) continue;
    if (name == "seed" ? r.perturbation.family != "seed" : r.perturbation.name != name) continue;
    ++c.runs;
    c.failed += StabilityRunFailed(report, r);
    if (!r.ok()) {
      ++c.errors;
      continue;
    }
    const double drop = r.clean_psnr - r.Psnr();
    c.min_drop = scored ? std::min(c.min_drop, drop) : drop;
    c.max_drop = scored ? std::max(c.max_drop, drop) : drop;
    sum += drop;
    ++scored;
  }
  if (scored) c.mean_drop = sum / scored;
  return c;
}

std::string MarkdownTable(const TextTable& t) {
  std::ostringstream md;
  md << "|";
  for (const std::string& h : t.header) md << " " << h << " |";
  md << "\n|";
  for (size_t c = 0; c < t.header.size(); ++c) md << (c < t.numeric.size() && t.numeric[c] ? "---:|" : "---|");
  md << "\n";
  for (size_t i = 0; i < t.rows.size(); ++i) {
    md << "|";
    for (size_t c = 0; c < t.rows[i].size(); ++c) {
      const bool b = i < t.bold.size() && c < t.bold[i].size() && t.bold[i][c];
      md << " " << Bold(t.rows[i][c], b && !t.rows[i][c].empty() && t.rows[i][c] != "-") << " |";
    }
    md << "\n";
  }
  if (!t.notes.empty()) md << "\n";
  for (const std::string& n : t.notes) md << n << "\n";
  return md.str();
}

std::vector<std::string> ReportNotes(const BenchReport& r) {
  std::vector<std::string> notes;
  char buf[512];
  std::set<std::string> settings;
  int reused = 0, failed = 0;
  for (const BenchRun& run : r.runs) {
    settings.insert(run.setting.Name());
    reused += run.reused;
    failed += !run.ok();
  }
  std::string scenes;
  for (size_t i = 0; i < r.scenes.size(); ++i) scenes += (i ? ", `" : "`") + r.scenes[i].name + "`";
  double run_seconds = 0;
  for (const BenchRun& run : r.runs) run_seconds += run.Number("total_seconds").value_or(0);
  std::snprintf(buf, sizeof buf,
                "Scenes: %s. %zu settings, %zu runs%s, all on %d threads; the runs took %.0f s (sum of their "
                "`total_seconds`), this bench invocation %.0f s.",
                scenes.c_str(), settings.size(), r.runs.size(), r.quick ? " (the `--quick` grid)" : "", r.threads,
                run_seconds, r.seconds);
  notes.push_back(buf);
  notes.push_back("Machine load (1/5/15-minute averages, /proc/loadavg): " + r.load_before + " at the start, " +
                  r.load_after + " at the end. Times are wall-clock seconds of the solve alone (`solve_seconds`) "
                  "on a machine that may be shared: compare methods by their ratio within one bench run "
                  "(metrics.md), never across runs.");
  bool paper_full = false, paper_any = false;
  for (const BenchRun& run : r.runs)
    if (run.setting.method == "sg-paper") {
      paper_any = true;
      paper_full |= run.setting.solve.steps >= 20000;
    }
  if (paper_any && !paper_full)
    notes.push_back("sg-paper (the paper's Adam optimiser) ran at the step counts listed, not at the published "
                    "20000 steps: those take minutes to tens of minutes per scene on two cores and run only with "
                    "`--full`.");
  if (reused)
    notes.push_back(std::to_string(reused) + " of " + std::to_string(r.runs.size()) +
                    " runs were reused from an earlier bench in this folder (their metrics.json existed; `--force` "
                    "re-runs them): their times were measured then.");
  if (failed) notes.push_back("**" + std::to_string(failed) + " runs failed**; the errors are listed under the scene tables.");
  notes.push_back("PSNR and SSIM: the re-rendered shadow plane against `image.exr` (metrics.md). Ang. err.: the "
                  "estimated environment map against `env_gt.exr` (upper hemisphere, solid-angle weighted; "
                  "degrees). Irr. err.: relative RMS error of the irradiance on 64 plane orientations. Insert: "
                  "virtual-object insertion against `image_virtual_objs.exr`, shown when a run reports it. LPIPS "
                  "(in the paper's Table 1) is not computed. Bold: the best of the scene. Time x: solve time "
                  "over that of SS03 (16x64) on the same scene.");
  return notes;
}

std::optional<TextTable> OverviewTable(const BenchReport& r) {
  const std::vector<BenchSetting> refs = ReferenceSettings(r);
  if (r.scenes.size() < 2 || refs.empty()) return std::nullopt;
  TextTable t;
  t.header = {"Scene"};
  t.numeric = {false};
  for (const BenchSetting& s : refs) {
    t.header.push_back(MethodDisplayName(s.method) + " " + s.label);
    t.numeric.push_back(true);
  }
  for (const BenchScene& scene : r.scenes) {
    std::vector<std::optional<double>> v;
    std::optional<double> best;
    for (const BenchSetting& s : refs) {
      const BenchRun* run = r.FindRun(scene, s.Name());
      v.push_back(run ? run->Number("psnr") : std::nullopt);
      if (v.back() && (!best || *v.back() > *best)) best = v.back();
    }
    std::vector<std::string> row = {scene.name};
    std::vector<bool> bold = {false};
    for (const auto& x : v) {
      row.push_back(FormatNumber(x, 2));
      bold.push_back(x && best && *x == *best);
    }
    t.rows.push_back(row);
    t.bold.push_back(bold);
  }
  return t;
}

std::string SceneLine(const BenchScene& scene) {
  return "`" + scene.dir.string() + "`: " + std::to_string(scene.plane_pixels) + " plane pixels" +
         (scene.has_env_gt ? ", env_gt.exr" : ", no env_gt.exr (no env-map scores)") +
         (scene.has_virtual_objects ? ", image_virtual_objs.exr" : "") + ".";
}

TextTable SceneTable(const BenchReport& r, const BenchScene& scene) {
  const std::vector<const BenchRun*> runs = RunsInTableOrder(r, scene);
  bool insert = false;
  for (const BenchRun* run : runs) insert |= run->Number("insert_psnr").has_value();
  const BenchRun* ss03 = r.FindRun(scene, "ss03-h16");
  const double ss03_time = ss03 ? ss03->Number("solve_seconds").value_or(0) : 0;  // 0: no SS03 run

  struct Column {
    std::string title, key;
    int decimals;
    int better;  // +1 higher is better, -1 lower, 0 no best
  };
  std::vector<Column> cols = {{"PSNR ↑", "psnr", 2, 1},
                              {"SSIM ↑", "ssim", 4, 1},
                              {"Ang. err. ↓", "env_angular_error_deg", 2, -1},
                              {"Irr. err. ↓", "irradiance_rel_rmse", 3, -1}};
  if (insert) {
    cols.push_back({"Insert PSNR ↑", "insert_psnr", 2, 1});
    cols.push_back({"Insert SSIM ↑", "insert_ssim", 4, 1});
  }
  cols.push_back({"Lobes", "n_lobes", 0, 0});
  cols.push_back({"Params", "n_params", 0, 0});
  cols.push_back({"Solve (s)", "solve_seconds", 2, 0});

  TextTable t;
  t.header = {"Method", "Setting"};
  t.numeric = {false, false};
  for (const Column& c : cols) {
    t.header.push_back(c.title);
    t.numeric.push_back(true);
  }
  t.header.push_back("Time x");
  t.numeric.push_back(true);

  std::vector<std::optional<double>> best(cols.size());
  for (size_t c = 0; c < cols.size(); ++c)
    for (const BenchRun* run : runs)
      if (const auto v = run->Number(cols[c].key); cols[c].better && v && std::isfinite(*v) &&
                                                   (!best[c] || (cols[c].better > 0 ? *v > *best[c] : *v < *best[c])))
        best[c] = v;
  char buf[64];
  for (const BenchRun* run : runs) {
    std::vector<std::string> row = {MethodDisplayName(run->setting.method), run->setting.label};
    std::vector<bool> bold(2, false);
    if (!run->ok()) {
      row.push_back("failed");
      row.resize(t.header.size());
      bold.resize(t.header.size(), false);
      t.notes.push_back("- " + run->setting.Name() + " failed: " + run->error);
    } else {
      for (size_t c = 0; c < cols.size(); ++c) {
        const auto v = run->Number(cols[c].key);
        int decimals = cols[c].decimals;
        if (cols[c].key == "solve_seconds" && v && *v >= 10) decimals = 1;
        // Maps have no lobes: "-" rather than metrics.json's 0.
        const bool map = run->setting.method != "sg" && run->setting.method != "sg-paper";
        row.push_back(cols[c].key == "n_lobes" && map ? "-" : FormatNumber(v, decimals));
        bold.push_back(v && best[c] && FormatNumber(v, decimals) == FormatNumber(best[c], decimals));
      }
      const auto time = run->Number("solve_seconds");
      std::string ratio = "-";
      if (time && ss03_time > 0) {
        std::snprintf(buf, sizeof buf, "%.2g", *time / ss03_time);
        ratio = buf;
      }
      row.push_back(ratio);
      bold.push_back(false);
    }
    t.rows.push_back(row);
    t.bold.push_back(bold);
  }
  return t;
}

std::vector<std::string> StabilityNotes(const BenchReport& r) {
  std::vector<std::string> notes;
  notes.push_back(
      "Each perturbation writes a perturbed copy of the scene (`perturbed/`), each method re-solves it "
      "(`stability/`), and the estimated lighting is scored by `eval` on the UNPERTURBED scene: true geometry, "
      "true image. Seeds re-solve the clean scene with `--seed` 1, 2, ... Cells: the PSNR drop, i.e. the PSNR of the "
      "same setting on the clean scene minus the PSNR under the perturbation (dB; positive = worse), mean over "
      "scenes; seeds: mean [min, max].");
  std::string rule = "Failure: a run fails when it errors or its PSNR falls below ";
  if (r.fail_rule == "ss03") {
    rule += "both the SS03 result (unconstrained least squares, 16x64 map) on the clean scene (";
    for (size_t i = 0; i < r.scenes.size(); ++i)
      rule += std::string(i ? ", " : "") + r.scenes[i].name + " " +
              FormatNumber(i < r.fail_threshold.size() ? r.fail_threshold[i] : std::nullopt, 2) + " dB";
    rule += ") and its own clean result minus 3 dB: it lost more than 3 dB and ended below the plainest baseline "
            "with clean inputs. (SS03 alone would count every run of a method whose clean result is already below "
            "SS03's as failed, which measures the scene, not the stability.)";
  } else {
    rule += r.fail_rule + " dB.";
  }
  notes.push_back(rule);
  return notes;
}

TextTable StabilityTable(const BenchReport& r) {
  TextTable t;
  t.header = {"Perturbation"};
  t.numeric = {false};
  for (const BenchSetting& s : r.stability_settings) {
    t.header.push_back(MethodDisplayName(s.method) + " " + s.label);
    t.numeric.push_back(true);
  }
  auto failed_note = [](const StabilityCell& c) {
    return c.failed ? " (" + std::to_string(c.failed) + " failed)" : std::string();
  };
  int seeds = 0;
  for (const Perturbation& p : r.perturbations) {
    if (p.family == "seed") {
      ++seeds;
      continue;
    }
    std::vector<std::string> row = {p.label};
    for (const BenchSetting& s : r.stability_settings) {
      const StabilityCell c = SummariseStability(r, s, p.name);
      if (c.empty()) row.push_back("n/a");
      else if (c.errors == c.runs) row.push_back("error");
      else row.push_back(FormatNumber(c.mean_drop, 2) + failed_note(c));
    }
    t.rows.push_back(row);
  }
  if (seeds) {
    std::vector<std::string> row = {std::to_string(seeds) + " seeds"};
    for (const BenchSetting& s : r.stability_settings) {
      const StabilityCell c = SummariseStability(r, s, "seed");
      if (c.empty()) row.push_back("n/a");
      else
        row.push_back(FormatNumber(c.mean_drop, 2) + " [" + FormatNumber(c.min_drop, 2) + ", " +
                      FormatNumber(c.max_drop, 2) + "]" + failed_note(c));
    }
    t.rows.push_back(row);
  }
  std::vector<std::string> row = {"failure rate"};
  char buf[64];
  for (const BenchSetting& s : r.stability_settings) {
    int runs = 0, fails = 0;
    for (const StabilityRun& run : r.stability_runs)
      if (run.setting.Name() == s.Name()) {
        ++runs;
        fails += StabilityRunFailed(r, run);
      }
    std::snprintf(buf, sizeof buf, "%d/%d (%.0f %%)", fails, runs, runs ? 100.0 * fails / runs : 0.0);
    row.push_back(buf);
  }
  t.rows.push_back(row);
  t.bold.assign(t.rows.size(), std::vector<bool>(t.header.size(), false));
  t.bold.back().assign(t.header.size(), true);
  t.notes.push_back("n/a: the perturbation does not reach the method (the baselines ray-cast the mesh and use no "
                    "sphere tree). Per-run numbers: `stability.csv`.");
  for (const StabilityRun& run : r.stability_runs)
    if (!run.error.empty())
      t.notes.push_back("- " + run.scene->name + " " + run.perturbation.name + " " + run.setting.Name() +
                        " failed: " + run.error);
  return t;
}

std::string ResultsMarkdown(const BenchReport& r) {
  std::ostringstream md;
  md << "# shadowsg bench results\n\n";
  for (const std::string& n : ReportNotes(r)) md << n << "\n\n";
  if (const auto overview = OverviewTable(r)) md << "## Overview: PSNR (dB) per scene\n\n" << MarkdownTable(*overview) << "\n";
  for (const BenchScene& scene : r.scenes)
    md << "## " << scene.name << "\n\n" << SceneLine(scene) << "\n\n" << MarkdownTable(SceneTable(r, scene)) << "\n";
  if (r.stability) {
    md << "## Stability (`--stability`)\n\n";
    for (const std::string& n : StabilityNotes(r)) md << n << "\n\n";
    md << MarkdownTable(StabilityTable(r)) << "\n";
  }
  return md.str();
}

}  // namespace shadowsg
