// The StageContext most stage tests run with: no progress or log lines.
#pragma once

#include "stages/stage_context.h"

namespace shadowsg::testing {

inline StageContext QuietContext(int threads = 1) {
  StageContext ctx;
  ctx.quiet = true;
  ctx.threads = threads;
  return ctx;
}

}  // namespace shadowsg::testing
