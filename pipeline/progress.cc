#include "pipeline/progress.h"

#include <unistd.h>

#include <algorithm>
#include <cstdio>

namespace shadowsg {

ProgressBar::ProgressBar(std::string label, bool quiet)
    : label_(std::move(label)), quiet_(quiet), tty_(isatty(2) != 0), start_(std::chrono::steady_clock::now()) {}

ProgressBar::~ProgressBar() { Finish(); }

void ProgressBar::Update(double fraction, const std::string& status) {
  if (quiet_) return;
  std::lock_guard<std::mutex> lock(mutex_);
  const auto now = std::chrono::steady_clock::now();
  fraction = std::clamp(fraction, 0.0, 1.0);
  const int percent = static_cast<int>(fraction * 100);
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  if (tty_) {
    if (now - last_draw_ < std::chrono::milliseconds(100) && fraction < 1.0) return;
    constexpr int kWidth = 30;
    const int filled = static_cast<int>(fraction * kWidth);
    std::string bar(filled, '#');
    bar += std::string(kWidth - filled, '.');
    std::fprintf(stderr, "\r%-12s [%s] %3d%% %6.1fs %s\033[K", label_.c_str(), bar.c_str(), percent, elapsed,
                 status.c_str());
  } else {
    // Logs get a line when the work starts, then every 10 %.
    if (last_percent_ >= 0 && percent / 10 == last_percent_ / 10 && fraction < 1.0) return;
    std::fprintf(stderr, "%s: %3d%% %.1fs %s\n", label_.c_str(), percent, elapsed, status.c_str());
  }
  std::fflush(stderr);
  last_percent_ = percent;
  last_draw_ = now;
}

void ProgressBar::Finish() {
  if (quiet_ || finished_) return;
  finished_ = true;
  if (tty_ && last_percent_ >= 0) std::fprintf(stderr, "\n");
}

}  // namespace shadowsg
