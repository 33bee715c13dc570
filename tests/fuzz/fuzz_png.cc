// PNG/JPEG images through ReadLdr (OpenCV's decoders behind our checks).
#include "fuzz_util.h"
#include "stages/io/image_io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace shadowsg;
  const auto path = fuzz::WriteScratch("fuzz.png", data, size);
  return fuzz::Expect([&] { ReadLdr(path); });
}
