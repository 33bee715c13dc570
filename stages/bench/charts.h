// The charts of `shadowsg bench`, drawn by gnuplot (run as a program): for
// each chart a data file and a script in DIR/charts/ (re-runnable by hand:
// `cd DIR/charts && gnuplot NAME.gp`), and NAME.png + NAME.svg.
//   time_psnr_<scene>    solve time (log) against PSNR, one marker per method,
//                        settings joined by lines, the Pareto front marked
//   params_psnr_<scene>  lighting parameters (log) against PSNR
//   *_mean               the same over all scenes (mean PSNR, mean time), when
//                        there are several scenes
//   stability            PSNR on the clean scene against perturbation size,
//                        one line per method, a panel per perturbation family
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "stages/bench/bench_report.h"
#include "stages/stage_context.h"

namespace shadowsg {

struct BenchChart {
  std::string name;     // file stem
  std::string title;
  std::string caption;  // one sentence for index.html
  std::filesystem::path png, svg;  // relative to DIR
};

// gnuplot's path; InputError naming gnuplot when it is not on PATH.
std::filesystem::path RequireGnuplot();

// The (time, PSNR) points not beaten by any other (faster or as fast AND at
// least as accurate, one of them strictly): indices into the input, sorted by
// time.
std::vector<size_t> ParetoFront(const std::vector<double>& seconds, const std::vector<double>& psnr);

// Writes data, scripts and pictures into bench_dir/charts/. InputError with
// one line when gnuplot is missing or fails.
std::vector<BenchChart> WriteCharts(const BenchReport& report, const std::filesystem::path& bench_dir,
                                    const StageContext& ctx);

}  // namespace shadowsg
