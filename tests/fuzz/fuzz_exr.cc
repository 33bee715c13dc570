// EXR images through ReadExr (OpenEXR behind our checks) and the env-map reader.
#include "fuzz_util.h"
#include "stages/io/image_io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace shadowsg;
  const auto path = fuzz::WriteScratch("fuzz.exr", data, size);
  return fuzz::Expect([&] { ReadEnvMapExr(path); });
}
