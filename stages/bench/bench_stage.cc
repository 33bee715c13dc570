#include "stages/bench/bench_stage.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

#include "calib/error.h"
#include "solver/plane_pixels.h"
#include "stages/bench/charts.h"
#include "stages/bench/html.h"
#include "stages/bench/perturbations.h"
#include "stages/bench/runner.h"
#include "stages/bench/tables.h"
#include "stages/io/atomic_file.h"
#include "stages/io/image_io.h"
#include "stages/io/scene_io.h"
#include "stages/stage_util.h"
#include "stages/synth_stage.h"

namespace shadowsg {
namespace fs = std::filesystem;

namespace {

std::optional<double> ParseDb(const std::string& s) {
  double v = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || end != s.data() + s.size() || !std::isfinite(v)) return std::nullopt;
  return v;
}

std::string LoadAverage() {
  std::ifstream in("/proc/loadavg");
  std::string a, b, c;
  if (!(in >> a >> b >> c)) return "unknown";
  return a + " " + b + " " + c;
}

// The bundled sample at the --quick size, synthesised once into DIR/scenes/sample.
fs::path QuickSampleScene(const BenchOptions& o, const StageContext& ctx) {
  if (o.sample_spec.empty()) throw InputError("--quick", "no scene given and the bundled sample was not found");
  const fs::path dir = fs::absolute(o.out_dir / "scenes" / "sample");
  std::error_code ec;
  if (!o.force && fs::is_regular_file(dir / "scene.json", ec)) {
    ctx.Log("bench: reusing the sample scene " + dir.string());
    return dir;
  }
  SynthSpec spec = ReadSynthSpec(o.sample_spec);
  SynthOverrides over;
  over.resolution_scale = kQuickSampleScale;
  over.samples_per_pixel = std::min(spec.trace.samples_per_pixel, kQuickSampleSpp);
  ApplyOverrides(over, &spec);
  // Casters only: the insertion preview of the virtual object costs minutes
  // for a 256-lobe or env-map estimate, more than the whole quick budget.
  std::erase_if(spec.objects, [](const SynthObject& obj) { return !obj.is_train; });
  ctx.Log("bench: synthesising the sample (" + o.sample_spec.string() + ") at " + std::to_string(spec.camera.width) +
          "x" + std::to_string(spec.camera.height) + " into " + dir.string());
  RunSynthStage(spec, dir, InnerContext(ctx));
  return dir;
}

// Loads every scene once (errors before any run), names it, and writes the
// input and true env-map previews for index.html.
std::vector<BenchScene> PrepareScenes(const std::vector<fs::path>& dirs, const fs::path& out_dir,
                                      const StageContext& ctx) {
  std::vector<BenchScene> scenes;
  std::set<std::string> names;
  for (const fs::path& dir : dirs) {
    // A bench folder inside a scene folder would be copied into every perturbed copy of it.
    const fs::path scene_abs = fs::weakly_canonical(fs::absolute(dir));
    const fs::path out_abs = fs::weakly_canonical(fs::absolute(out_dir));
    if (std::mismatch(scene_abs.begin(), scene_abs.end(), out_abs.begin(), out_abs.end()).first == scene_abs.end())
      throw InputError(out_dir.string(), "the bench folder is inside the scene folder " + dir.string() +
                                             "; choose --out elsewhere");
    Scene scene = LoadScene(dir);
    if (!names.insert(scene.name).second)
      throw InputError(dir.string(), "two scenes are named '" + scene.name +
                                         "' (the folder name): runs/<scene>/ would collide; rename one folder");
    const RayCaster casters = BuildRayCaster(scene.Casters());
    const PlanePixels pixels = FindPlanePixels(scene, casters);
    if (pixels.size() == 0)
      throw InputError((dir / "scene.json").string(), "no shadow-plane pixels: the camera does not see the plane");
    BenchScene b;
    b.name = scene.name;
    b.dir = dir;
    b.has_env_gt = scene.env_gt.has_value();
    b.has_virtual_objects = scene.image_virtual_objs.has_value();
    b.plane_pixels = static_cast<int>(pixels.size());
    const fs::path previews = out_dir / "runs" / scene.name;
    EnsureOutputDir(previews);
    float white = 0;  // the exposure of the re-render previews (evaluation.cc)
    for (int p : pixels.pixel) white = std::max(white, scene.image.rgb(p).maxCoeff());
    WritePreviewPng(previews / "input.png", scene.image, white);
    if (scene.env_gt) WritePreviewPng(previews / "env_gt.png", *scene.env_gt);
    scenes.push_back(b);
  }
  return scenes;
}

std::string ChartsMarkdown(const std::vector<BenchChart>& charts) {
  if (charts.empty()) return "";
  std::ostringstream md;
  md << "## Charts\n\n";
  for (const BenchChart& c : charts)
    md << "### " << c.title << "\n\n![" << c.title << "](" << c.png.generic_string() << ")\n\n" << c.caption
       << " SVG: `" << c.svg.generic_string() << "`; script: `charts/" << c.name << ".gp`.\n\n";
  return md.str();
}

}  // namespace

std::string BenchOptions::Validate() const {
  if (out_dir.empty()) return "--out: required";
  if (scene_dirs.empty() && !quick) return "give at least one SCENE_DIR (or --quick for the bundled sample)";
  if (seeds < 0 || seeds > 1000) return "--seeds: expected 0 to 1000";
  if (fail_below != "ss03" && !ParseDb(fail_below)) return "--fail-below: expected ss03 or a PSNR in dB";
  return "";
}

BenchSummary RunBench(const BenchOptions& o, const StageContext& ctx) {
  const Stopwatch clock;
  if (const std::string e = o.Validate(); !e.empty()) throw InputError("", e);
  GridOptions grid_options;
  grid_options.full = o.full;
  grid_options.quick = o.quick;
  const std::vector<std::string> methods = o.methods.empty() ? DefaultBenchMethods() : o.methods;
  std::vector<BenchSetting> grid = MethodGrid(methods, grid_options);
  if (o.charts) RequireGnuplot();  // before hours of runs, not after
  EnsureOutputDir(o.out_dir);

  BenchReport report;
  report.threads = ctx.threads;
  report.quick = o.quick;
  report.load_before = LoadAverage();
  report.stability = o.stability;
  report.fail_rule = o.fail_below;

  // Stability settings: given, or one reference setting per method of the grid.
  if (o.stability) {
    for (const std::string& e : o.stability_methods) {
      const BenchSetting s = ParseBenchSetting(e);
      if (const std::string err = s.solve.Validate(); !err.empty()) throw InputError("--stability-methods", err);
      report.stability_settings.push_back(s);
    }
    if (o.stability_methods.empty()) {
      // Per method of the grid: its reference setting (sg fast with --quick)
      // when the grid has it, else the method's first setting in the grid.
      std::set<std::string> seen;
      for (const BenchSetting& s : grid) {
        if (!seen.insert(s.method).second) continue;
        const std::string ref = ParseBenchSetting(s.method == "sg" && o.quick ? "sg:fast" : s.method).Name();
        const auto it = std::find_if(grid.begin(), grid.end(), [&](const BenchSetting& g) { return g.Name() == ref; });
        report.stability_settings.push_back(it != grid.end() ? *it : s);
      }
    }
    report.perturbations = StabilityPerturbations(o.quick, o.seeds);
  }
  // Every stability setting needs its clean run, and the ss03 rule SS03's.
  std::vector<BenchSetting> all = grid;
  auto ensure = [&](const BenchSetting& s) {
    if (std::none_of(all.begin(), all.end(), [&](const BenchSetting& g) { return g.Name() == s.Name(); }))
      all.push_back(s);
  };
  for (const BenchSetting& s : report.stability_settings) ensure(s);
  if (o.stability && o.fail_below == "ss03") ensure(ParseBenchSetting("ss03:16"));

  std::vector<fs::path> dirs = o.scene_dirs;
  if (dirs.empty()) dirs.push_back(QuickSampleScene(o, ctx));
  report.scenes = PrepareScenes(dirs, o.out_dir, ctx);

  const size_t n_runs = report.scenes.size() * all.size();
  ctx.Log("bench: " + std::to_string(report.scenes.size()) + " scenes x " + std::to_string(all.size()) +
          " settings = " + std::to_string(n_runs) + " runs on " + std::to_string(ctx.threads) + " threads into " +
          o.out_dir.string());
  size_t k = 0;
  for (const BenchScene& scene : report.scenes)
    for (const BenchSetting& s : all) {
      const std::string tag = std::string("[") + std::to_string(++k) + "/" + std::to_string(n_runs) + "]";
      report.runs.push_back(
          RunBenchSetting(scene, s, o.out_dir, fs::path("runs") / scene.name / s.Name(), o.force, tag, ctx));
      if (report.runs.back().reused && report.runs.back().Number("threads") &&
          *report.runs.back().Number("threads") != ctx.threads)
        ctx.Warn("bench: " + report.runs.back().run_dir.string() + " was run on " +
                 std::to_string(static_cast<int>(*report.runs.back().Number("threads"))) +
                 " threads, this bench uses " + std::to_string(ctx.threads) + " (--force re-runs it)");
    }

  if (o.stability) {
    for (const BenchScene& scene : report.scenes) {
      std::optional<double> threshold;
      if (o.fail_below == "ss03") {
        if (const BenchRun* ss03 = report.FindRun(scene, "ss03-h16")) threshold = ss03->Number("psnr");
      } else {
        threshold = ParseDb(o.fail_below);
      }
      report.fail_threshold.push_back(threshold);
    }
    size_t total = 0;
    for (const Perturbation& p : report.perturbations)
      for (const BenchSetting& s : report.stability_settings) total += p.affects_baselines || s.method == "sg" || s.method == "sg-paper";
    total *= report.scenes.size();
    size_t j = 0;
    for (const BenchScene& scene : report.scenes)
      for (const Perturbation& p : report.perturbations) {
        const fs::path pdir = o.out_dir / "perturbed" / scene.name / p.name;
        std::error_code ec;
        if (p.family != "seed" && (o.force || !fs::is_regular_file(pdir / "scene.json", ec))) {
          ctx.Log("stability: writing " + pdir.string());
          WritePerturbedScene(scene.dir, p, pdir, ctx.seed, InnerContext(ctx));
        }
        for (const BenchSetting& s : report.stability_settings) {
          if (!p.affects_baselines && s.method != "sg" && s.method != "sg-paper") continue;
          const BenchRun* clean = report.FindRun(scene, s.Name());
          const std::string tag = std::string("[") + std::to_string(++j) + "/" + std::to_string(total) + "]";
          if (!clean || !clean->ok()) {
            StabilityRun failed;
            failed.scene = &scene;
            failed.setting = s;
            failed.perturbation = p;
            failed.error = "no clean run to compare with";
            report.stability_runs.push_back(failed);
            continue;
          }
          report.stability_runs.push_back(
              RunPerturbedSetting(scene, s, p, *clean->Number("psnr"), o.out_dir, o.force, tag, ctx));
        }
      }
  }

  report.load_after = LoadAverage();
  report.seconds = clock.Seconds();
  WriteResultsCsv(o.out_dir / "results.csv", report);
  if (o.stability) WriteStabilityCsv(o.out_dir / "stability.csv", report);
  WriteTextAtomically(o.out_dir / "results.md", ResultsMarkdown(report));
  std::vector<BenchChart> charts;
  if (o.charts) {
    charts = WriteCharts(report, o.out_dir, ctx);
    WriteTextAtomically(o.out_dir / "results.md", ResultsMarkdown(report) + ChartsMarkdown(charts));
  }
  WriteIndexHtml(report, charts, o.out_dir);
  const std::vector<std::string> missing = MissingLinks(o.out_dir / "index.html");
  if (!missing.empty())
    throw InputError((o.out_dir / "index.html").string(),
                     std::to_string(missing.size()) + " links to missing files, e.g. " + missing.front());
  if (o.check_html) CheckHtmlInChromium(o.out_dir / "index.html", o.out_dir / "index_screenshot.png", ctx);

  BenchSummary summary;
  summary.runs = static_cast<int>(report.runs.size());
  for (const BenchRun& r : report.runs) {
    summary.failed += !r.ok();
    summary.reused += r.reused;
  }
  summary.stability_runs = static_cast<int>(report.stability_runs.size());
  for (const StabilityRun& r : report.stability_runs) summary.stability_failed += !r.error.empty();
  summary.seconds = clock.Seconds();
  ctx.Log("bench: wrote " + (o.out_dir / "results.md").string() + ", results.csv, " +
          (o.charts ? "charts/, " : "") + "index.html in " + std::to_string(static_cast<int>(summary.seconds)) + " s");
  if (summary.failed || summary.stability_failed)
    throw InputError("bench", std::to_string(summary.failed) + " of " + std::to_string(summary.runs) + " runs" +
                                  (o.stability ? " and " + std::to_string(summary.stability_failed) + " of " +
                                                     std::to_string(summary.stability_runs) + " stability runs"
                                               : "") +
                                  " failed; the tables, charts and index.html were written (errors in results.md)");
  return summary;
}

}  // namespace shadowsg
