// `shadowsg bench` on a tiny synthetic scene: the method grid, resumable runs,
// results.csv / results.md, the charts (when gnuplot is installed), index.html
// links, and the stability study's perturbed scenes.
#include "stages/bench/bench_stage.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <fstream>
#include <map>
#include <sstream>

#include "calib/error.h"
#include "stages/bench/charts.h"
#include "stages/bench/html.h"
#include "stages/bench/perturbations.h"
#include "stages/bench/runner.h"
#include "stages/colmap_runner.h"
#include "stages/io/image_io.h"
#include "stages/io/json_util.h"
#include "stages/io/scene_io.h"
#include "stages/synth_stage.h"
#include "quiet_context.h"
#include "test_util.h"

namespace shadowsg {
namespace {

namespace fs = std::filesystem;
using shadowsg::testing::TempDir;

// 48 x 36 pixels, a sphere on a plane under a sun and a sky lobe.
const char* kSpec = R"({
  "format": "synth/1",
  "camera": {"width": 48, "height": 36, "fov_deg": 50,
             "look_from": [0.6, -2.2, 1.5], "look_at": [0, 0, 0.15]},
  "plane": {"xyz": [0, 0, 0], "normal": [0, 0, 1], "scale": [4, 4, 1], "diffuse": [0.8, 0.8, 0.8]},
  "objects": [{"mesh": {"primitive": "icosphere", "radius": 0.3, "subdivisions": 2},
               "position": [0, 0, 0], "rest_on_plane": true, "diffuse": [0.7, 0.7, 0.7]}],
  "lights": {"suns": [{"direction": [0.5, 0.3, 0.8], "irradiance": [3, 3, 2.6], "angular_radius_deg": 1}],
             "lobes": [{"axis": [0, 0, 1], "sharpness": 2, "amplitude": [0.2, 0.3, 0.5]}]},
  "render": {"spp": 4, "bounces": 1, "seed": 1},
  "env_gt_height": 32
})";

using shadowsg::testing::QuietContext;

// One scene (with its sphere tree cached in the folder) for every test.
class BenchTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    root_ = new fs::path(fs::temp_directory_path() / ("shadowsg_bench_test_" + std::to_string(getpid())));
    fs::remove_all(*root_);
    fs::create_directories(*root_);
    std::ofstream(*root_ / "spec.json") << kSpec;
    RunSynthStage(ReadSynthSpec(*root_ / "spec.json"), SceneDir(), QuietContext(2));
  }
  static void TearDownTestSuite() {
    std::error_code ec;
    fs::remove_all(*root_, ec);
    delete root_;
  }
  static fs::path SceneDir() { return *root_ / "tiny"; }
  static bool HaveGnuplot() { return FindExecutable("gnuplot").has_value(); }

  static fs::path* root_;
};
fs::path* BenchTest::root_ = nullptr;

// RFC 4180 rows (quoted fields may hold commas and doubled quotes).
std::vector<std::vector<std::string>> ReadCsv(const fs::path& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  const std::string s = text.str();
  std::vector<std::vector<std::string>> rows(1);
  std::string cell;
  bool quoted = false;
  for (size_t i = 0; i < s.size(); ++i) {
    const char c = s[i];
    if (quoted) {
      if (c == '"' && i + 1 < s.size() && s[i + 1] == '"') cell += '"', ++i;
      else if (c == '"') quoted = false;
      else cell += c;
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      rows.back().push_back(cell);
      cell.clear();
    } else if (c == '\n') {
      rows.back().push_back(cell);
      cell.clear();
      rows.emplace_back();
    } else {
      cell += c;
    }
  }
  if (rows.back().empty()) rows.pop_back();
  return rows;
}

std::string ReadText(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST_F(BenchTest, GridExpandsMethodsAndSettings) {
  const auto names = [](const std::vector<BenchSetting>& grid) {
    std::vector<std::string> n;
    for (const auto& s : grid) n.push_back(s.Name());
    return n;
  };
  const std::vector<std::string> all = names(MethodGrid(DefaultBenchMethods(), {}));
  const std::vector<std::string> expected = {
      "sg-fast",    "sg-balanced", "sg-best",        "sg-lobes1",      "sg-lobes2", "sg-lobes4",
      "sg-lobes8",  "sg-lobes16",  "sg-lobes32",     "sg-lobes64",     "sg-paper-1000",
      "sg-paper-5000", "ss03-h16", "ss03+-h16",      "sh21-h8",        "sh21-h16",  "sh21-h32"};
  EXPECT_EQ(all, expected);
  GridOptions full;
  full.full = true;
  EXPECT_EQ(names(MethodGrid({"sg-paper"}, full)),
            (std::vector<std::string>{"sg-paper-1000", "sg-paper-5000", "sg-paper-20000"}));
  GridOptions quick;
  quick.quick = true;
  const std::vector<BenchSetting> quick_grid = MethodGrid(DefaultBenchMethods(), quick);
  EXPECT_EQ(names(quick_grid), (std::vector<std::string>{"sg-fast", "sg-lobes1-fast", "sg-lobes4-fast",
                                                         "sg-paper-100", "ss03-h16", "ss03+-h16", "sh21-h16"}));
  EXPECT_EQ(quick_grid[1].solve.budget, "fast");
  EXPECT_EQ(quick_grid[1].solve.lobes, 1);
  EXPECT_EQ(names(MethodGrid({"sg:3", "sg:fast", "ss03:8", "sg:fast"}, {})),
            (std::vector<std::string>{"sg-lobes3", "sg-fast", "ss03-h8"}));
  const BenchSetting paper = ParseBenchSetting("sg-paper:250");
  EXPECT_EQ(paper.solve.method, "sg-paper");
  EXPECT_EQ(paper.solve.steps, 250);
  EXPECT_EQ(ParseBenchSetting("sh21:8").solve.map_height, 8);
  EXPECT_EQ(ParseBenchSetting("sg:4").solve.lobes, 4);
  for (const char* bad : {"nope", "sg:medium", "sg-paper:0", "ss03:x", "sh21:-3"})
    EXPECT_THROW(MethodGrid({bad}, {}), InputError) << bad;
}

TEST_F(BenchTest, ParetoFrontKeepsTheUnbeatenPoints) {
  // (seconds, psnr): b is beaten by a (faster and better); d by c.
  const std::vector<double> t = {1, 2, 4, 8, 16};
  const std::vector<double> p = {20, 19, 25, 24, 30};
  EXPECT_EQ(ParetoFront(t, p), (std::vector<size_t>{0, 2, 4}));
}

TEST_F(BenchTest, WritesTablesChartsAndAPageThatLinksOnlyExistingFiles) {
  TempDir tmp;
  BenchOptions o;
  o.scene_dirs = {SceneDir()};
  o.out_dir = tmp / "bench";
  o.methods = {"sg:fast", "sg:2", "sg-paper:30", "ss03:4", "ss03+:4", "sh21:4"};
  o.charts = HaveGnuplot();
  const BenchSummary s = RunBench(o, QuietContext(2));
  EXPECT_EQ(s.runs, 6);
  EXPECT_EQ(s.failed, 0);
  EXPECT_EQ(s.reused, 0);

  // results.csv: one row per run, every metrics.json key with its value.
  const auto rows = ReadCsv(o.out_dir / "results.csv");
  ASSERT_EQ(rows.size(), 7u);
  const std::vector<std::string>& header = rows[0];
  std::map<std::string, size_t> col;
  for (size_t i = 0; i < header.size(); ++i) col[header[i]] = i;
  for (size_t r = 1; r < rows.size(); ++r) {
    ASSERT_EQ(rows[r].size(), header.size());
    const fs::path run_dir = o.out_dir / rows[r][col.at("run_dir")];
    const Json m = ReadJsonFile(run_dir / "metrics.json");
    EXPECT_EQ(rows[r][col.at("scene")], "tiny");
    EXPECT_EQ(rows[r][col.at("method")], m["method"].get<std::string>());
    for (auto it = m.begin(); it != m.end(); ++it) {
      if (it->is_object()) {
        for (auto jt = it->begin(); jt != it->end(); ++jt)
          EXPECT_TRUE(col.count(it.key() + "." + jt.key())) << it.key() + "." + jt.key();
        continue;
      }
      ASSERT_TRUE(col.count(it.key())) << it.key();
      const std::string& cell = rows[r][col.at(it.key())];
      if (it->is_null()) {
        EXPECT_EQ(cell, "") << it.key();
      } else if (it->is_number()) {
        EXPECT_NEAR(std::stod(cell), it->get<double>(), 1e-6 * (1 + std::abs(it->get<double>()))) << it.key();
      }
    }
  }

  // results.md: the Table 1 layout, a row per setting.
  const std::string md = ReadText(o.out_dir / "results.md");
  EXPECT_NE(md.find("## tiny"), std::string::npos);
  EXPECT_NE(md.find("| Method | Setting | PSNR ↑ | SSIM ↑ | Ang. err. ↓ | Irr. err. ↓ |"), std::string::npos);
  for (const char* row : {"| SS03 | 4x16 map |", "| SS03+ | 4x16 map |", "| SH21 | 4x16 map |",
                          "| sg-paper | 30 steps |", "| sg | fast |", "| sg | 2 lobes |"})
    EXPECT_NE(md.find(row), std::string::npos) << row;
  // Table 1 order: baselines first, then the SG methods.
  EXPECT_LT(md.find("| SS03 |"), md.find("| sg | fast |"));

  // index.html: tables, image strip, only links to files that exist.
  const std::string html = ReadText(o.out_dir / "index.html");
  EXPECT_NE(html.find("<table>"), std::string::npos);
  EXPECT_NE(html.find("runs/tiny/sg-fast/render.png"), std::string::npos);
  EXPECT_NE(html.find("runs/tiny/input.png"), std::string::npos);
  EXPECT_NE(html.find("runs/tiny/env_gt.png"), std::string::npos);
  EXPECT_NE(html.find("runs/tiny/ss03%2B-h4/error.png"), std::string::npos);
  EXPECT_TRUE(MissingLinks(o.out_dir / "index.html").empty());

  // A second bench reuses every run.
  const BenchSummary again = RunBench(o, QuietContext(2));
  EXPECT_EQ(again.reused, 6);

  // The page renders in headless Chromium with every image decoded; a
  // corrupt picture is reported (install-deps.sh installs chromium).
  if (FindExecutable("chromium")) {
    const fs::path shot = tmp / "shot.png";
    EXPECT_NO_THROW(CheckHtmlInChromium(o.out_dir / "index.html", shot, QuietContext(2)));
    EXPECT_GT(fs::file_size(shot), 1000u);
    std::ofstream(o.out_dir / "runs" / "tiny" / "input.png", std::ios::trunc) << "not a png";
    try {
      CheckHtmlInChromium(o.out_dir / "index.html", shot, QuietContext(2));
      ADD_FAILURE() << "a corrupt image passed the Chromium check";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("did not load"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find("input.png"), std::string::npos) << e.what();
    }
  }

  if (!HaveGnuplot()) GTEST_SKIP() << "gnuplot not installed: charts not checked";
  for (const char* chart : {"time_psnr_tiny", "params_psnr_tiny"})
    for (const char* ext : {".png", ".svg", ".gp", ".dat"}) {
      const fs::path f = o.out_dir / "charts" / (std::string(chart) + ext);
      EXPECT_TRUE(fs::is_regular_file(f)) << f;
      EXPECT_GT(fs::file_size(f), 100u) << f;
    }
  EXPECT_NE(html.find("charts/time_psnr_tiny.png"), std::string::npos);
  EXPECT_NE(ReadText(o.out_dir / "charts" / "time_psnr_tiny.svg").find("<svg"), std::string::npos);
  // Scene names are drawn as written: gnuplot's enhanced text would set the
  // underscore of "pub_torus_sunsky" as a subscript.
  EXPECT_NE(ReadText(o.out_dir / "charts" / "time_psnr_tiny.gp").find("noenhanced"), std::string::npos);
}

TEST_F(BenchTest, MissingLinksFindsBrokenRelativeLinks) {
  TempDir tmp;
  std::ofstream(tmp / "a b.png") << "x";
  std::ofstream(tmp / "page.html") << "<a href=\"https://example.org/x\">x</a><a href=\"#top\">t</a>"
                                      "<img src=\"a%20b.png\"><img src=\"gone.png\"><a href='x'>";
  EXPECT_EQ(MissingLinks(tmp / "page.html"), (std::vector<std::string>{"gone.png"}));
}

TEST_F(BenchTest, PerturbedScenesChangeWhatTheyShould) {
  TempDir tmp;
  const Scene clean = LoadScene(SceneDir());
  auto write = [&](const std::string& family, double size) {
    for (const Perturbation& p : StabilityPerturbations(false, 1))
      if (p.family == family && p.size == size) {
        WritePerturbedScene(SceneDir(), p, tmp / p.name, 7, QuietContext(2));
        return LoadScene(tmp / p.name);
      }
    ADD_FAILURE() << family << " " << size;
    return clean;
  };
  // Noise: zero-mean, sigma = 5 % of the plane maximum (here about the image maximum).
  const Scene noisy = write("noise", 5);
  double sum = 0, sum2 = 0, peak = 0;
  for (size_t i = 0; i < clean.image.data.size(); ++i) {
    const double d = noisy.image.data[i] - clean.image.data[i];
    sum += d;
    sum2 += d * d;
    peak = std::max(peak, static_cast<double>(clean.image.data[i]));
  }
  const double n = static_cast<double>(clean.image.data.size());
  EXPECT_NEAR(sum / n, 0, 0.01 * peak);
  EXPECT_GT(std::sqrt(sum2 / n), 0.02 * peak);
  EXPECT_LT(std::sqrt(sum2 / n), 0.06 * peak);
  // Clipping: no value above the level, some values at it.
  const Scene clipped = write("clip", 5);
  const float level = *std::max_element(clipped.image.data.begin(), clipped.image.data.end());
  EXPECT_LT(level, *std::max_element(clean.image.data.begin(), clean.image.data.end()));
  // Rotation: 3 degrees.
  const Scene rotated = write("rotation", 3);
  const Eigen::Matrix3d r = rotated.objects[0].o2w.block<3, 3>(0, 0) * clean.objects[0].o2w.block<3, 3>(0, 0).inverse();
  EXPECT_NEAR(Eigen::AngleAxisd(r).angle() * 180 / M_PI, 3, 1e-6);
  // Plane normal: 1 degree; albedo: +10 %.
  EXPECT_NEAR(std::acos(write("normal", 1).plane.normal.dot(clean.plane.normal)) * 180 / M_PI, 1, 1e-6);
  EXPECT_NEAR(write("albedo", 10).plane.diffuse.x(), 1.1 * clean.plane.diffuse.x(), 1e-9);
  // The coarser tree has two levels and is the scene's.
  const Scene coarse = write("spheretree", kCoarseTreeLevels);
  ASSERT_TRUE(coarse.objects[0].sphere_tree);
  EXPECT_EQ(coarse.objects[0].sphere_tree->levels, kCoarseTreeLevels);
  // The images of geometry perturbations are the clean one.
  EXPECT_EQ(rotated.image.data, clean.image.data);
}

TEST_F(BenchTest, StabilityScoresPerturbedSolvesOnTheCleanScene) {
  TempDir tmp;
  BenchOptions o;
  o.scene_dirs = {SceneDir()};
  o.out_dir = tmp / "bench";
  o.methods = {"ss03:4", "sg:1"};  // the cheapest of each kind; each stands for its method
  o.stability = true;
  o.quick = true;  // one size per family
  o.seeds = 1;
  o.charts = HaveGnuplot();
  const BenchSummary s = RunBench(o, QuietContext(2));
  EXPECT_EQ(s.failed, 0);
  // 8 perturbations + 1 seed, for two methods; the sphere tree does not reach ss03.
  EXPECT_EQ(s.stability_runs, 9 + 8);
  EXPECT_EQ(s.stability_failed, 0);
  const auto rows = ReadCsv(o.out_dir / "stability.csv");
  ASSERT_EQ(rows.size(), 18u);
  std::map<std::string, size_t> col;
  for (size_t i = 0; i < rows[0].size(); ++i) col[rows[0][i]] = i;
  for (size_t r = 1; r < rows.size(); ++r) {
    const double clean = std::stod(rows[r][col.at("clean_psnr")]);
    const double psnr = std::stod(rows[r][col.at("psnr")]);
    EXPECT_NEAR(std::stod(rows[r][col.at("psnr_drop")]), clean - psnr, 1e-6);
    EXPECT_TRUE(std::isfinite(psnr));
  }
  // The perturbed copies are complete scene folders; the scores are eval's on the clean scene.
  EXPECT_TRUE(fs::is_regular_file(o.out_dir / "perturbed" / "tiny" / "noise-5" / "scene.json"));
  const Json eval = ReadJsonFile(o.out_dir / "stability" / "tiny" / "noise-5" / "ss03-h4" / "clean_eval" / "metrics.json");
  EXPECT_EQ(eval["method"], "eval");
  const std::string md = ReadText(o.out_dir / "results.md");
  EXPECT_NE(md.find("## Stability"), std::string::npos);
  EXPECT_NE(md.find("failure rate"), std::string::npos);
  EXPECT_NE(md.find("SS03 result"), std::string::npos);
  EXPECT_TRUE(MissingLinks(o.out_dir / "index.html").empty());
  if (!HaveGnuplot()) GTEST_SKIP() << "gnuplot not installed: the stability chart not checked";
  EXPECT_TRUE(fs::is_regular_file(o.out_dir / "charts" / "stability.png"));
  EXPECT_TRUE(fs::is_regular_file(o.out_dir / "charts" / "stability.svg"));
}

}  // namespace
}  // namespace shadowsg
