// Small helpers shared by the stages.
#pragma once

#include <chrono>
#include <filesystem>

namespace shadowsg {

// Wall-clock stopwatch in seconds.
class Stopwatch {
 public:
  Stopwatch() : start_(std::chrono::steady_clock::now()) {}
  double Seconds() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }

 private:
  std::chrono::steady_clock::time_point start_;
};

// Creates DIR (and parents); InputError naming it when that is impossible.
void EnsureOutputDir(const std::filesystem::path& dir);

}  // namespace shadowsg
