// lighting.json: sg-lighting/1 and lights/1 through ReadLighting.
#include "fuzz_util.h"
#include "stages/io/lighting_io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace shadowsg;
  const auto path = fuzz::WriteScratch("lighting.json", data, size);
  return fuzz::Expect([&] { ReadLighting(path); });
}
