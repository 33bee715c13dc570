// scene.json, through LoadScene (camera, plane, objects; the meshes it names
// are not there, which is one more error path).
#include "fuzz_util.h"
#include "stages/io/scene_io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace shadowsg;
  const auto dir = fuzz::ScratchDir() / "scene";
  static const bool made = [&] {  // the mesh the seed names, so that objects parse too
    std::filesystem::create_directories(dir / "geometry");
    std::ofstream(dir / "geometry" / "mesh.obj")
        << "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";
    return true;
  }();
  (void)made;
  std::ofstream(dir / "scene.json", std::ios::binary).write(reinterpret_cast<const char*>(data), size);
  SceneLoadOptions o;
  o.require_image = false;
  o.load_extras = false;
  return fuzz::Expect([&] { LoadScene(dir, o); });
}
