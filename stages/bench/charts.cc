#include "stages/bench/charts.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <numeric>
#include <sstream>

#include "calib/error.h"
#include "stages/bench/tables.h"
#include "stages/colmap_runner.h"
#include "stages/io/atomic_file.h"
#include "stages/stage_util.h"

namespace shadowsg {
namespace fs = std::filesystem;

namespace {

// noenhanced: scene names hold underscores, which enhanced text would set as
// subscripts.
constexpr const char* kPngTerminal = "pngcairo noenhanced size 960,640 font 'sans,11'";
constexpr const char* kSvgTerminal = "svg noenhanced size 960,640 font 'sans,11' background rgb 'white'";
constexpr const char* kStabilityPng = "pngcairo noenhanced size 1200,760 font 'sans,10'";
constexpr const char* kStabilitySvg = "svg noenhanced size 1200,760 font 'sans,10' background rgb 'white'";
constexpr double kSamePointDb = 0.01;    // points closer than this (and at the same x) share a label
constexpr double kPsnrAxisSpanDb = 25;   // the PSNR axis reaches at most this far below the best point

// Marker (gnuplot point type) and colour per chart series.
struct SeriesStyle {
  int point;
  const char* colour;
};
SeriesStyle StyleOf(const std::string& series) {
  static const std::map<std::string, SeriesStyle> kStyles = {
      {"sg budget", {7, "#1f77b4"}}, {"sg lobes", {5, "#17becf"}}, {"sg", {7, "#1f77b4"}},
      {"sg-paper", {9, "#ff7f0e"}},  {"ss03", {2, "#2ca02c"}},     {"ss03+", {1, "#d62728"}},
      {"sh21", {13, "#9467bd"}}};
  const auto it = kStyles.find(series);
  return it == kStyles.end() ? SeriesStyle{3, "#7f7f7f"} : it->second;
}

// A gnuplot single-quoted string ('' stands for ').
std::string Quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("''") : std::string(1, c);
  return q + "'";
}

std::string SafeStem(const std::string& s) {
  std::string out;
  for (char c : s) out += std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' ? c : '_';
  return out;
}

std::string Num(double v) {
  char buf[40];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}

struct Point {
  double x, y;
  std::string label;
};
struct Series {
  std::string name;
  std::vector<Point> points;
};

// Data blocks (gnuplot "index" k) separated by two blank lines; labels quoted.
std::string DataText(const std::vector<Series>& series, const std::vector<Point>& extra_block) {
  std::ostringstream d;
  d << "# x y label; one block per series";
  for (const Series& s : series) {
    d << "\n\n\n# " << s.name << "\n";
    for (const Point& p : s.points) d << Num(p.x) << " " << Num(p.y) << " \"" << p.label << "\"\n";
  }
  d << "\n\n\n# pareto front\n";
  for (const Point& p : extra_block) d << Num(p.x) << " " << Num(p.y) << " \"" << p.label << "\"\n";
  return d.str();
}

// The script: `body` drawn once to PNG and once to SVG. Output names get the
// variable `suffix` appended (the bench passes ".tmp" and renames the files
// when gnuplot succeeded, so a failed run leaves no half-written picture).
std::string Script(const std::string& stem, const std::string& body, const char* png, const char* svg) {
  std::ostringstream s;
  s << "# Written by shadowsg bench; re-run with: gnuplot " << stem << ".gp (in this folder)\n"
    << "if (!exists('suffix')) suffix = ''\n"
    << "set terminal " << png << "\nset output '" << stem << ".png'.suffix\n"
    << body << "unset output\n"
    << "set terminal " << svg << "\nset output '" << stem << ".svg'.suffix\n"
    << body << "unset output\n";
  return s.str();
}

void RunGnuplot(const fs::path& gnuplot, const fs::path& charts_dir, const std::string& stem) {
  std::string last;
  std::vector<std::string> argv = {gnuplot.string(), "-e", "cd " + Quote(charts_dir.string()) + "; suffix = '.tmp'",
                                   stem + ".gp"};
  const int status = RunProcess(argv, {}, [&](const std::string& line) {
    if (!line.empty()) last = line;
  });
  std::error_code ec;
  if (status != 0) {
    for (const char* ext : {".png.tmp", ".svg.tmp"}) fs::remove(charts_dir / (stem + ext), ec);
    throw InputError((charts_dir / (stem + ".gp")).string(),
                     "gnuplot failed (exit status " + std::to_string(status) + ")" + (last.empty() ? "" : ": " + last));
  }
  for (const char* ext : {".png", ".svg"}) {
    const fs::path tmp = charts_dir / (stem + ext + ".tmp"), out = charts_dir / (stem + ext);
    fs::rename(tmp, out, ec);
    if (ec) throw InputError(out.string(), "gnuplot wrote no picture (" + ec.message() + ")");
  }
}

// Settings, in run order, with one point per setting: (x, PSNR), x from `xkey`.
// `scene` null: means over the scenes where the setting has a score (only
// settings scored on every scene).
std::vector<Series> ScatterSeries(const BenchReport& r, const BenchScene* scene, const std::string& xkey) {
  std::vector<Series> out;
  std::vector<std::string> names;
  for (const BenchRun& run : r.runs)
    if (std::find(names.begin(), names.end(), run.setting.Name()) == names.end()) names.push_back(run.setting.Name());
  for (const std::string& name : names) {
    double sx = 0, sy = 0;
    int n = 0;
    const BenchSetting* setting = nullptr;
    for (const BenchRun& run : r.runs) {
      if (run.setting.Name() != name || (scene && run.scene != scene)) continue;
      setting = &run.setting;
      const auto x = run.Number(xkey), y = run.Number("psnr");
      if (!run.ok() || !x || !y || !(*x > 0) || !std::isfinite(*y)) continue;
      sx += *x;
      sy += *y;
      ++n;
    }
    if (!setting || n == 0 || (!scene && n != static_cast<int>(r.scenes.size()))) continue;
    auto it = std::find_if(out.begin(), out.end(), [&](const Series& s) { return s.name == setting->series; });
    if (it == out.end()) {
      out.push_back({setting->series, {}});
      it = out.end() - 1;
    }
    it->points.push_back({sx / n, sy / n, setting->label});
  }
  for (Series& s : out) {
    std::sort(s.points.begin(), s.points.end(), [](const Point& a, const Point& b) { return a.x < b.x; });
    // Settings that land on one point (e.g. two budgets choosing the same
    // model) share one label.
    std::vector<Point> merged;
    for (const Point& p : s.points)
      if (!merged.empty() && merged.back().x == p.x && std::abs(merged.back().y - p.y) < kSamePointDb)
        merged.back().label += ", " + p.label;
      else
        merged.push_back(p);
    s.points = merged;
  }
  return out;
}

// The PSNR axis: from a little below the worst point to above the best, but
// at most kPsnrAxisSpanDb below the best; points further down are drawn on
// the bottom edge with their value in the label (a diverged run must not
// flatten every other point into one line).
double ClampAxis(std::vector<Series>* series, std::vector<Point>* front) {
  double lo = INFINITY, hi = -INFINITY;
  for (const Series& s : *series)
    for (const Point& p : s.points) {
      lo = std::min(lo, p.y);
      hi = std::max(hi, p.y);
    }
  const double floor_db = std::floor(std::max(lo, hi - kPsnrAxisSpanDb)) - 1;
  char buf[64];
  auto clamp = [&](Point& p) {
    if (p.y >= floor_db) return;
    std::snprintf(buf, sizeof buf, " (%.1f dB, off scale)", p.y);
    p.label += buf;
    p.y = floor_db;
  };
  for (Series& s : *series)
    for (Point& p : s.points) clamp(p);
  for (Point& p : *front) clamp(p);
  return floor_db;
}

std::string ScatterBody(const std::vector<Series>& series, const std::string& data, const std::string& title,
                        const std::string& xlabel, bool pareto, double ymin) {
  std::ostringstream b;
  b << "set title " << Quote(title) << "\n"
    << "set yrange [" << Num(ymin) << ":*]\n"
    << "set logscale x\nset format x '%g'\n"
    << "set xlabel " << Quote(xlabel) << "\nset ylabel 'PSNR (dB), shadow plane'\n"
    << "set grid xtics ytics mxtics lc rgb '#dddddd'\nset key outside right top\n"
    << "set offsets graph 0.05, graph 0.05, graph 0.08, graph 0.05\n"
    << "plot ";
  for (size_t i = 0; i < series.size(); ++i) {
    const SeriesStyle st = StyleOf(series[i].name);
    b << (i ? ", \\\n     " : "") << Quote(data) << " index " << i << " using 1:2 with linespoints lw 1.5 pt "
      << st.point << " ps 1.4 lc rgb '" << st.colour << "' title " << Quote(MethodDisplayName(series[i].name));
    b << ", \\\n     " << Quote(data) << " index " << i << " using 1:2:3 with labels offset 0,0.9 font ',8' tc rgb '"
      << st.colour << "' notitle";
  }
  if (pareto)
    b << ", \\\n     " << Quote(data) << " index " << series.size()
      << " using 1:2 with lines dt 2 lw 2 lc rgb '#444444' title 'Pareto front', \\\n     " << Quote(data)
      << " index " << series.size() << " using 1:2 with points pt 6 ps 2.6 lw 1.5 lc rgb '#444444' notitle";
  b << "\nunset logscale x\nunset title\nset yrange [*:*]\n";
  return b.str();
}

void WriteOrThrow(const fs::path& path, const std::string& text) { WriteTextAtomically(path, text); }

BenchChart ScatterChart(const BenchReport& r, const BenchScene* scene, const std::string& kind,
                        const fs::path& bench_dir, const fs::path& gnuplot) {
  const bool time = kind == "time";
  const std::string xkey = time ? "solve_seconds" : "n_params";
  const std::string scene_name = scene ? scene->name : "mean over scenes";
  const std::string stem = (time ? "time_psnr_" : "params_psnr_") + (scene ? SafeStem(scene->name) : "mean");
  std::vector<Series> series = ScatterSeries(r, scene, xkey);
  if (series.empty()) return {};  // no successful run to draw
  std::vector<Point> front;
  if (time) {
    std::vector<double> xs, ys;
    std::vector<std::string> labels;
    for (const Series& s : series)
      for (const Point& p : s.points) {
        xs.push_back(p.x);
        ys.push_back(p.y);
        labels.push_back(p.label);
      }
    for (size_t i : ParetoFront(xs, ys)) front.push_back({xs[i], ys[i], labels[i]});
  }
  const double ymin = ClampAxis(&series, &front);
  const fs::path charts = bench_dir / "charts";
  WriteOrThrow(charts / (stem + ".dat"), DataText(series, front));
  const std::string title = (time ? "Solve time against accuracy: " : "Model size against accuracy: ") + scene_name;
  const std::string xlabel = time ? (scene ? "solve time (s, log scale)" : "mean solve time (s, log scale)")
                                  : "lighting parameters (log scale; SG: 6 per lobe, map: 3 per texel)";
  WriteOrThrow(charts / (stem + ".gp"),
               Script(stem, ScatterBody(series, stem + ".dat", title, xlabel, time, ymin), kPngTerminal, kSvgTerminal));
  RunGnuplot(gnuplot, charts, stem);
  BenchChart c;
  c.name = stem;
  c.title = title;
  c.caption = time ? "Each marker is one setting; lines join the settings of one method; the dashed line and "
                     "circles mark the Pareto front (no other setting is both faster and more accurate)."
                   : "Each marker is one setting; lines join the settings of one method.";
  c.png = fs::path("charts") / (stem + ".png");
  c.svg = fs::path("charts") / (stem + ".svg");
  return c;
}

BenchChart StabilityChart(const BenchReport& r, const fs::path& bench_dir, const fs::path& gnuplot) {
  struct Family {
    const char* family;
    const char* xlabel;
  };
  static const Family kFamilies[] = {{"noise", "image noise sigma (% of the plane maximum)"},
                                     {"clip", "clipped highlights (% of plane pixels)"},
                                     {"rotation", "caster rotation (deg)"},
                                     {"translation", "caster translation (% of its size)"},
                                     {"normal", "plane normal error (deg)"},
                                     {"albedo", "plane albedo error (%)"}};
  const fs::path charts = bench_dir / "charts";
  const std::string stem = "stability";
  std::ostringstream body;
  body << "set multiplot layout 2,3 title 'PSNR on the clean scene against perturbation size (mean over scenes)'\n"
       << "set grid lc rgb '#dddddd'\nset ylabel 'PSNR (dB)'\nset key bottom left font ',8'\n"
       << "set offsets graph 0.05, graph 0.05, graph 0.05, graph 0.05\n";
  for (const Family& f : kFamilies) {
    // Sizes of this family, with the clean scene as size 0.
    std::vector<double> sizes = {0};
    for (const Perturbation& p : r.perturbations)
      if (p.family == f.family) sizes.push_back(p.size);
    std::sort(sizes.begin(), sizes.end());
    std::vector<Series> series;  // only lines with points: gnuplot does not count empty data blocks
    std::vector<SeriesStyle> styles;
    for (const BenchSetting& s : r.stability_settings) {
      Series line{MethodDisplayName(s.method) + " " + s.label, {}};
      for (double size : sizes) {
        double sum = 0;
        int n = 0;
        if (size == 0) {
          for (const BenchRun& run : r.runs)
            if (run.setting.Name() == s.Name() && run.ok() && run.Number("psnr")) {
              sum += *run.Number("psnr");
              ++n;
            }
        } else {
          for (const StabilityRun& run : r.stability_runs)
            if (run.setting.Name() == s.Name() && run.perturbation.family == f.family &&
                run.perturbation.size == size && run.ok()) {
              sum += run.Psnr();
              ++n;
            }
        }
        if (n) line.points.push_back({size, sum / n, ""});
      }
      if (line.points.empty()) continue;
      series.push_back(line);
      styles.push_back(StyleOf(s.series));
    }
    const std::string data = std::string("stability_") + f.family + ".dat";
    WriteOrThrow(charts / data, DataText(series, {}));
    body << "set title " << Quote(f.family) << "\nset xlabel " << Quote(f.xlabel) << "\n";
    if (series.empty()) {
      body << "set label 1 'no runs' at graph 0.5, graph 0.5 center\nplot [0:1][0:1] NaN notitle\nunset label 1\n";
      continue;
    }
    body << "plot ";
    for (size_t i = 0; i < series.size(); ++i) {
      const SeriesStyle st = styles[i];
      body << (i ? ", \\\n     " : "") << Quote(data) << " index " << i << " using 1:2 with linespoints lw 1.5 pt "
           << st.point << " ps 1.2 lc rgb '" << st.colour << "' title " << Quote(series[i].name);
    }
    body << "\n";
  }
  body << "unset multiplot\n";
  WriteOrThrow(charts / (stem + ".gp"), Script(stem, body.str(), kStabilityPng, kStabilitySvg));
  RunGnuplot(gnuplot, charts, stem);
  BenchChart c;
  c.name = stem;
  c.title = "Stability";
  c.caption = "PSNR of each method's estimate, re-rendered on the clean scene, as the input is perturbed (size 0: "
              "the clean input); one line per method, mean over scenes.";
  c.png = fs::path("charts") / (stem + ".png");
  c.svg = fs::path("charts") / (stem + ".svg");
  return c;
}

}  // namespace

fs::path RequireGnuplot() {
  const auto exe = FindExecutable("gnuplot");
  if (!exe)
    throw InputError("gnuplot", "not found on PATH: the bench draws its charts with it (Debian: apt-get install "
                                "gnuplot-nox), or pass --no-charts");
  return *exe;
}

std::vector<size_t> ParetoFront(const std::vector<double>& seconds, const std::vector<double>& psnr) {
  std::vector<size_t> order(seconds.size());
  std::iota(order.begin(), order.end(), 0);
  // Fastest first; at equal time the most accurate first.
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return seconds[a] != seconds[b] ? seconds[a] < seconds[b] : psnr[a] > psnr[b];
  });
  std::vector<size_t> front;
  double best = -INFINITY;
  for (size_t i : order)
    if (psnr[i] > best) {
      front.push_back(i);
      best = psnr[i];
    }
  return front;
}

std::vector<BenchChart> WriteCharts(const BenchReport& report, const fs::path& bench_dir, const StageContext& ctx) {
  const fs::path gnuplot = RequireGnuplot();
  EnsureOutputDir(bench_dir / "charts");
  std::vector<BenchChart> charts;
  for (const BenchScene& scene : report.scenes)
    for (const char* kind : {"time", "params"})
      if (BenchChart c = ScatterChart(report, &scene, kind, bench_dir, gnuplot); !c.name.empty()) charts.push_back(c);
      else ctx.Warn("bench: " + scene.name + ": no successful run to chart");
  if (report.scenes.size() > 1)
    for (const char* kind : {"time", "params"})
      if (BenchChart c = ScatterChart(report, nullptr, kind, bench_dir, gnuplot); !c.name.empty()) charts.push_back(c);
  if (report.stability && !report.stability_runs.empty()) charts.push_back(StabilityChart(report, bench_dir, gnuplot));
  ctx.Log("bench: " + std::to_string(charts.size()) + " charts (PNG + SVG, gnuplot scripts) in " +
          (bench_dir / "charts").string());
  return charts;
}

}  // namespace shadowsg
