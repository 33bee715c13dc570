#include "pipeline/cli_common.h"

#include <omp.h>
#include <unistd.h>

#include <cstdio>
#include <memory>

#include "pipeline/progress.h"
#include "solver/eigen_blocking.h"
#include "stages/io/atomic_file.h"

namespace shadowsg {

void AddCommonOptions(CLI::App* cmd, CommonOptions* o) {
  cmd->add_option("--threads", o->threads, "Worker threads (default: all cores)")->check(CLI::NonNegativeNumber);
  cmd->add_option("--seed", o->seed, "Random seed (same seed, same result)");
  cmd->add_flag("--quiet", o->quiet, "Only errors and warnings on stderr");
}

StageContext MakeContext(const CommonOptions& o) {
  StageContext ctx;
  ctx.threads = o.threads > 0 ? o.threads : omp_get_num_procs();
  omp_set_num_threads(ctx.threads);
  PinEigenBlocking();  // results independent of the caches the CPU reports
  ctx.seed = o.seed;
  ctx.quiet = o.quiet;
  const bool quiet = o.quiet;
  ctx.progress = [quiet](const std::string& label) -> ProgressFn {
    auto bar = std::make_shared<ProgressBar>(label, quiet);
    return [bar](double f, const std::string& s) {
      ThrowIfInterrupted();
      bar->Update(f, s);
      if (f >= 1.0) bar->Finish();
    };
  };
  // On a terminal, a log line first clears a progress bar drawn on its line.
  const bool tty = isatty(2) != 0;
  ctx.log = [tty](const std::string& line) { std::fprintf(stderr, "%s%s\n", tty ? "\r\033[K" : "", line.c_str()); };
  return ctx;
}

}  // namespace shadowsg
