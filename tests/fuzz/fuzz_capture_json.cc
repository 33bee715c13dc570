// camera.json, pose.json, plane.json and the capture.json manifest of `run`
// (the first byte picks the parser; paths resolve against a folder that does
// not exist, so a well-formed manifest ends in a clean "not found").
#include "fuzz_util.h"
#include "stages/io/capture_io.h"
#include "stages/io/capture_manifest_io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace shadowsg;
  if (size < 1) return 0;
  const int which = data[0] % 4;
  const std::string text = fuzz::AsString(data + 1, size - 1);
  return fuzz::Expect([&] {
    const Json j = ParseJson(text, "fuzz.json");
    if (which == 0) ParseCameraFile(j, "camera.json");
    if (which == 1) ParsePoseFile(j, "pose.json");
    if (which == 2) ParsePlaneFile(j, "plane.json");
    if (which == 3) ParseCaptureManifest(j, "capture.json", "/nonexistent-capture");
  });
}
