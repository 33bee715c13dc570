#include "stages/bench/runner.h"

#include <algorithm>
#include <charconv>
#include <cstdio>

#include "calib/error.h"

namespace shadowsg {
namespace fs = std::filesystem;

std::optional<double> BenchRun::Number(const std::string& key) const {
  if (!metrics.is_object()) return std::nullopt;
  const auto it = metrics.find(key);
  if (it == metrics.end() || !it->is_number()) return std::nullopt;
  return it->get<double>();
}

const BenchRun* BenchReport::FindRun(const BenchScene& scene, const std::string& setting_name) const {
  for (const BenchRun& r : runs)
    if (r.scene == &scene && r.setting.Name() == setting_name) return &r;
  return nullptr;
}

std::vector<std::string> DefaultBenchMethods() { return {"sg", "sg-paper", "ss03", "ss03+", "sh21"}; }

namespace {

std::optional<int> ParsePositive(const std::string& s) {
  int v = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || end != s.data() + s.size() || v <= 0) return std::nullopt;
  return v;
}

BenchSetting SgBudget(const std::string& budget) {
  BenchSetting s;
  s.method = "sg";
  s.setting = budget;
  s.label = budget;
  s.series = "sg budget";
  s.solve.method = "sg";
  s.solve.budget = budget;
  return s;
}

// Forced lobe counts at the balanced budget, or at `budget` (named in the
// setting, so that runs of another budget are never reused for it).
BenchSetting SgLobes(int lobes, const std::string& budget = "") {
  BenchSetting s;
  s.method = "sg";
  s.setting = "lobes" + std::to_string(lobes) + (budget.empty() ? "" : "-" + budget);
  s.label = std::to_string(lobes) + (lobes == 1 ? " lobe" : " lobes") + (budget.empty() ? "" : " (" + budget + ")");
  s.series = "sg lobes";
  s.solve.method = "sg";
  s.solve.lobes = lobes;
  if (!budget.empty()) s.solve.budget = budget;
  return s;
}

BenchSetting PaperSteps(int steps) {
  BenchSetting s;
  s.method = "sg-paper";
  s.setting = std::to_string(steps);
  s.label = std::to_string(steps) + " steps";
  s.series = "sg-paper";
  s.solve.method = "sg-paper";
  s.solve.steps = steps;
  return s;
}

BenchSetting Baseline(const std::string& method, int rows) {
  BenchSetting s;
  s.method = method;
  s.setting = std::string("h") + std::to_string(rows);
  s.label = std::to_string(rows) + "x" + std::to_string(4 * rows) + " map";
  s.series = method;
  s.solve.method = method;
  s.solve.map_height = rows;
  return s;
}

bool IsBaseline(const std::string& m) { return m == "ss03" || m == "ss03+" || m == "sh21"; }

[[noreturn]] void BadEntry(const std::string& entry, const std::string& why) {
  throw InputError("--methods", "'" + entry + "': " + why);
}

}  // namespace

BenchSetting ParseBenchSetting(const std::string& entry) {
  const size_t colon = entry.find(':');
  const std::string method = entry.substr(0, colon);
  const std::string arg = colon == std::string::npos ? "" : entry.substr(colon + 1);
  if (method == "sg") {
    if (arg.empty()) return SgBudget("balanced");
    if (arg == "fast" || arg == "balanced" || arg == "best") return SgBudget(arg);
    if (const auto n = ParsePositive(arg)) return SgLobes(*n);
    BadEntry(entry, "sg settings are fast, balanced, best or a lobe count");
  }
  if (method == "sg-paper") {
    if (arg.empty()) return PaperSteps(kPaperStepsDefault[0]);
    if (const auto n = ParsePositive(arg)) return PaperSteps(*n);
    BadEntry(entry, "the sg-paper setting is a step count");
  }
  if (IsBaseline(method)) {
    if (arg.empty()) return Baseline(method, kBaselineHeight);
    if (const auto n = ParsePositive(arg)) return Baseline(method, *n);
    BadEntry(entry, "the " + method + " setting is a map height (rows over the hemisphere)");
  }
  BadEntry(entry, "unknown method (expected sg, sg-paper, ss03, ss03+ or sh21, optionally with :SETTING)");
}

std::vector<BenchSetting> MethodGrid(const std::vector<std::string>& entries, const GridOptions& o) {
  std::vector<BenchSetting> grid;
  auto add = [&](const BenchSetting& s) {
    if (const std::string e = s.solve.Validate(); !e.empty()) throw InputError("--methods", s.Name() + ": " + e);
    const bool seen =
        std::any_of(grid.begin(), grid.end(), [&](const BenchSetting& g) { return g.Name() == s.Name(); });
    if (!seen) grid.push_back(s);
  };
  for (const std::string& entry : entries) {
    if (entry.find(':') != std::string::npos) {
      add(ParseBenchSetting(entry));
    } else if (entry == "sg") {
      if (o.quick) {
        add(SgBudget("fast"));
        for (int n : kSgQuickLobes) add(SgLobes(n, "fast"));
      } else {
        for (const char* b : {"fast", "balanced", "best"}) add(SgBudget(b));
        for (int n : kSgLobeSweep) add(SgLobes(n));
      }
    } else if (entry == "sg-paper") {
      if (o.quick) {
        add(PaperSteps(kPaperStepsQuick));
      } else {
        for (int n : kPaperStepsDefault) add(PaperSteps(n));
        if (o.full) add(PaperSteps(kPaperStepsFull));
      }
    } else if (entry == "sh21" && !o.quick) {
      for (int n : kSh21Heights) add(Baseline("sh21", n));
    } else {
      add(ParseBenchSetting(entry));
    }
  }
  if (grid.empty()) throw InputError("--methods", "no method given");
  return grid;
}

StageContext InnerContext(const StageContext& ctx) {
  StageContext inner = ctx;
  inner.quiet = true;  // Log() lines off; Warn() and the progress bars (made with the bench's --quiet) stay
  return inner;
}

std::optional<Json> ReadPreviousJson(const fs::path& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) return std::nullopt;
  try {
    Json j = ReadJsonFile(path);
    if (j.is_object()) return j;
  } catch (const InputError&) {
  }
  return std::nullopt;
}

BenchRun RunBenchSetting(const BenchScene& scene, const BenchSetting& setting, const fs::path& bench_dir,
                         const fs::path& run_dir, bool force, const std::string& tag, const StageContext& ctx) {
  BenchRun run;
  run.scene = &scene;
  run.setting = setting;
  run.run_dir = run_dir;
  const fs::path dir = bench_dir / run_dir;
  const std::string what = "bench " + tag + " " + scene.name + " " + setting.Name();
  if (!force) {
    if (auto previous = ReadPreviousJson(dir / "metrics.json")) {
      run.metrics = std::move(*previous);
      run.reused = true;
    }
  }
  if (!run.reused) {
    ctx.Log(what + ": solving");
    try {
      RunSolve(scene.dir, dir, setting.solve, InnerContext(ctx));
      run.metrics = ReadJsonFile(dir / "metrics.json");
    } catch (const Interrupted&) {
      throw;
    } catch (const std::exception& e) {
      run.error = e.what();
      ctx.Warn(what + ": failed: " + run.error);
      return run;
    }
  }
  char line[256];
  std::snprintf(line, sizeof line, ": %.2f dB, ssim %.4f, %d params, solve %.2f s%s",
                run.Number("psnr").value_or(0), run.Number("ssim").value_or(0),
                static_cast<int>(run.Number("n_params").value_or(0)), run.Number("solve_seconds").value_or(0),
                run.reused ? " (reused: metrics.json exists; --force re-runs)" : "");
  ctx.Log(what + line);
  return run;
}

}  // namespace shadowsg
