// COLMAP text models: cameras.txt, images.txt, points3D.txt (the first byte
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
      case 0: ReadColmapCamerasText(in, "cameras.txt", &model); break;
      case 1: ReadColmapImagesText(in, "images.txt", &model); break;
      default: ReadColmapPointsText(in, "points3D.txt", &model); break;
    }
  });
}
