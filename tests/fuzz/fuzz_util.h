// Shared by the libFuzzer targets (tests/fuzz/README in the top README):
// each target feeds its parser one input and treats InputError (bad input,
// reported to the user as one line) as the expected outcome; anything else
// (a crash, a sanitizer report, another exception escaping) is a finding.
#pragma once

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

#include "calib/error.h"

namespace shadowsg::fuzz {

inline std::string AsString(const uint8_t* data, size_t size) {
  return std::string(reinterpret_cast<const char*>(data), size);
}

// A per-process scratch folder for parsers that read files by path, removed
// when the process exits normally (libFuzzer's runs end in exit()); a crash
// leaves it beside its finding.
inline std::filesystem::path ScratchDir() {
  struct Scratch {
    std::filesystem::path path =
        std::filesystem::temp_directory_path() / ("shadowsg_fuzz_" + std::to_string(getpid()));
    Scratch() { std::filesystem::create_directories(path); }
    ~Scratch() {
      std::error_code ec;  // nothing to report to at exit
      std::filesystem::remove_all(path, ec);
    }
  };
  static const Scratch dir;
  return dir.path;
}

inline std::filesystem::path WriteScratch(const std::string& name, const uint8_t* data, size_t size) {
  const auto p = ScratchDir() / name;
  std::ofstream(p, std::ios::binary).write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  return p;
}

template <typename Fn>
int Expect(Fn fn) {
  try {
    fn();
  } catch (const InputError&) {
  }
  return 0;
}

}  // namespace shadowsg::fuzz
