// How long computations report progress without knowing about terminals:
// the caller passes a callback (the CLI draws a bar; tests pass nothing).
#pragma once

#include <algorithm>
#include <functional>
#include <mutex>
#include <string>
#include <vector>

namespace shadowsg {

// fraction in [0, 1]; status is a short line such as "loss 1.2e-3, 12 lobes".
// The callback may throw (e.g. Interrupted) to stop the computation.
using ProgressFn = std::function<void(double fraction, const std::string& status)>;

inline void Report(const ProgressFn& fn, double fraction, const std::string& status = "") {
  if (fn) fn(fraction, status);
}

// Progress of equal parts that may run side by side, each reporting its own
// fraction: the callback sees the parts' mean times `span` (what the parts
// are of the whole job), which never goes back, from one thread at a time.
class ProgressShares {
 public:
  ProgressShares(ProgressFn fn, size_t parts, double span = 1.0)
      : fn_(std::move(fn)), share_(parts, 0.0), span_(span) {}
  void Report(size_t part, double fraction, const std::string& status) {
    std::lock_guard<std::mutex> lock(mutex_);
    const double mean = Update(part, fraction);
    if (fn_) fn_(span_ * mean, status);
  }
  // A part finished without a last report.
  void Done(size_t part) {
    std::lock_guard<std::mutex> lock(mutex_);
    Update(part, 1.0);
  }

 private:
  double Update(size_t part, double fraction) {
    share_.at(part) = std::max(share_.at(part), std::clamp(fraction, 0.0, 1.0));
    double sum = 0;
    for (double s : share_) sum += s;
    return share_.empty() ? 1.0 : sum / static_cast<double>(share_.size());
  }

  ProgressFn fn_;
  std::vector<double> share_;
  double span_;
  std::mutex mutex_;
};

}  // namespace shadowsg
