// `shadowsg bench SCENE_DIR... --out DIR [--methods ...] [--stability] [--quick]`
// (stages/bench/bench_stage.h; README.md "Benchmark (bench)").
#include <cstdio>

#include "calib/error.h"
#include "pipeline/cli_common.h"
#include "pipeline/commands.h"
#include "pipeline/sample_data.h"
#include "stages/bench/bench_stage.h"

namespace shadowsg {

void RegisterBenchCommand(CLI::App& app) {
  struct Options {
    CommonOptions common;
    std::vector<std::string> scenes;
    std::string out_dir;
    BenchOptions bench;
    bool no_charts = false;
  };
  auto opt = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand(
      "bench", "Run every lighting method over scenes: tables, charts (gnuplot) and an HTML report");
  cmd->add_option("SCENE_DIR", opt->scenes, "Registered scene folders (none with --quick: the bundled sample)");
  cmd->add_option("--out", opt->out_dir, "Bench folder (results.md, results.csv, charts/, index.html, runs/)")
      ->required();
  cmd->add_option("--methods", opt->bench.methods,
                  "METHOD or METHOD:SETTING, comma-separated (default sg,sg-paper,ss03,ss03+,sh21); settings: "
                  "sg:fast|balanced|best|N lobes, sg-paper:STEPS, ss03|ss03+|sh21:ROWS")
      ->delimiter(',');
  cmd->add_flag("--stability", opt->bench.stability,
                "Also perturb the inputs (noise, clipping, pose, plane normal, albedo, texture, sphere tree, seeds), "
                "re-solve and score on the clean scene");
  cmd->add_flag("--quick", opt->bench.quick,
                "Small grid (and the sample scene at 160x120 when no SCENE_DIR is given): about a minute on 2 cores");
  cmd->add_flag("--full", opt->bench.full, "Also run sg-paper at the published 20000 steps (slow)");
  cmd->add_flag("--force", opt->bench.force, "Re-run runs whose metrics.json already exists (default: reuse)");
  cmd->add_flag("--no-charts", opt->no_charts, "Skip the charts (no gnuplot needed)");
  cmd->add_flag("--check-html", opt->bench.check_html,
                "Load index.html in headless Chromium and check that every image loads");
  cmd->add_option("--stability-methods", opt->bench.stability_methods,
                  "Settings re-solved under the perturbations (default: sg balanced (quick: fast), sg-paper 1000, "
                  "baselines 16 rows)")
      ->delimiter(',');
  cmd->add_option("--seeds", opt->bench.seeds, "Stability: re-solves of the clean scene with seeds 1..N")
      ->capture_default_str();
  cmd->add_option("--fail-below", opt->bench.fail_below,
                  "Stability: a run fails below this PSNR (dB), or with ss03 below both SS03's clean result and its "
                  "own clean result - 3 dB")
      ->capture_default_str();
  AddCommonOptions(cmd, &opt->common);
  cmd->callback([opt] {
    const StageContext ctx = MakeContext(opt->common);
    BenchOptions b = opt->bench;
    for (const std::string& s : opt->scenes) b.scene_dirs.emplace_back(s);
    b.out_dir = opt->out_dir;
    b.charts = !opt->no_charts;
    if (b.quick && b.scene_dirs.empty()) b.sample_spec = FindSampleSpec();
    const BenchSummary s = RunBench(b, ctx);
    std::printf("shadowsg bench: %d runs (%d reused) in %.0f s on %d threads; open %s/index.html (tables: "
                "results.md, results.csv)\n",
                s.runs, s.reused, s.seconds, ctx.threads, opt->out_dir.c_str());
  });
}

}  // namespace shadowsg
