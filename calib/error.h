// The project's one error channel for bad input: an exception that carries one
// line naming the file (or option) and the problem. The CLI prints it and exits
// non-zero. Programmer bugs use SHADOWSG_CHECK, which aborts.
#pragma once

#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <string>

namespace shadowsg {

class InputError : public std::runtime_error {
 public:
  InputError(const std::string& where, const std::string& problem)
      : std::runtime_error(where.empty() ? problem : where + ": " + problem) {}
};

// Thrown when the user interrupts (SIGINT/SIGTERM) a long computation.
class Interrupted : public std::runtime_error {
 public:
  Interrupted() : std::runtime_error("interrupted") {}
};

[[noreturn]] inline void CheckFailed(const char* cond, const char* file, int line) {
  std::fprintf(stderr, "internal error: %s:%d: check failed: %s\n", file, line, cond);
  std::abort();
}

}  // namespace shadowsg

#define SHADOWSG_CHECK(cond) \
  ((cond) ? (void)0 : ::shadowsg::CheckFailed(#cond, __FILE__, __LINE__))
