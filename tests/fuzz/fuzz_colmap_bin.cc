// COLMAP binary models: cameras.bin, images.bin, points3D.bin (the first byte
// picks the reader).
#include <sstream>

#include "calib/colmap_model.h"
#include "fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace shadowsg;
  if (size < 1) return 0;
  std::istringstream in(fuzz::AsString(data + 1, size - 1));
  ColmapModel model;
  return fuzz::Expect([&] {
    switch (data[0] % 3) {
      case 0: ReadColmapCamerasBinary(in, "cameras.bin", &model); break;
      case 1: ReadColmapImagesBinary(in, "images.bin", &model); break;
      default: ReadColmapPointsBinary(in, "points3D.bin", &model); break;
    }
  });
}
