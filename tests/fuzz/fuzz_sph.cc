// Sphere trees (.sph text).
#include <sstream>

#include "fuzz_util.h"
#include "stages/io/sph_io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace shadowsg;
  std::istringstream in(fuzz::AsString(data, size));
  return fuzz::Expect([&] { ReadSph(in, "fuzz.sph"); });
}
