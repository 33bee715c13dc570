// PLY meshes (our reader: ASCII and binary, both endiannesses).
#include <sstream>

#include "fuzz_util.h"
#include "stages/io/mesh_io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace shadowsg;
  std::istringstream in(fuzz::AsString(data, size));
  return fuzz::Expect([&] { ReadPly(in, "fuzz.ply"); });
}
