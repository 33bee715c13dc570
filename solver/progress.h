// How long computations report progress without knowing about terminals:
// the caller passes a callback (the CLI draws a bar; tests pass nothing).
#pragma once

#include <functional>
#include <string>

namespace shadowsg {

// fraction in [0, 1]; status is a short line such as "loss 1.2e-3, 12 lobes".
// The callback may throw (e.g. Interrupted) to stop the computation.
using ProgressFn = std::function<void(double fraction, const std::string& status)>;

inline void Report(const ProgressFn& fn, double fraction, const std::string& status = "") {
  if (fn) fn(fraction, status);
}

}  // namespace shadowsg
