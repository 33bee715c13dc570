// camera.json, pose.json and plane.json (the first byte picks the parser).
#include "fuzz_util.h"
#include "stages/io/capture_io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace shadowsg;
  if (size < 1) return 0;
  const int which = data[0] % 3;
  const std::string text = fuzz::AsString(data + 1, size - 1);
  return fuzz::Expect([&] {
    const Json j = ParseJson(text, "fuzz.json");
    if (which == 0) ParseCameraFile(j, "camera.json");
    if (which == 1) ParsePoseFile(j, "pose.json");
    if (which == 2) ParsePlaneFile(j, "plane.json");
  });
}
