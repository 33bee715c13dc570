#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <sstream>

#include "calib/error.h"
#include "solver/primitives.h"
#include "stages/io/image_io.h"
#include "stages/io/lighting_io.h"
#include "stages/io/mesh_io.h"
#include "stages/io/scene_io.h"
#include "stages/io/sph_io.h"
#include "test_util.h"

namespace shadowsg {
namespace {

using shadowsg::testing::TempDir;

void WriteText(const std::filesystem::path& p, const std::string& s) { std::ofstream(p) << s; }

// Expects an InputError whose message names `file` and contains `problem`.
template <typename F>
void ExpectInputError(F&& f, const std::string& file, const std::string& problem) {
  try {
    f();
    FAIL() << "no error; expected one naming " << file;
  } catch (const InputError& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(file), std::string::npos) << msg;
    EXPECT_NE(msg.find(problem), std::string::npos) << msg;
    EXPECT_EQ(msg.find('\n'), std::string::npos) << "one line: " << msg;
  }
}

TEST(ImageIo, ExrFloatAndHalfRoundTrip) {
  TempDir tmp;
  Image img(7, 5, 3);
  for (size_t i = 0; i < img.data.size(); ++i) img.data[i] = 0.001f * i + 0.5f;
  WriteExr(tmp / "f.exr", img, ExrPixelType::kFloat);
  WriteExr(tmp / "h.exr", img, ExrPixelType::kHalf);
  const Image f = ReadExr(tmp / "f.exr");
  const Image h = ReadExr(tmp / "h.exr");
  ASSERT_EQ(f.width, 7);
  ASSERT_EQ(f.height, 5);
  for (size_t i = 0; i < img.data.size(); ++i) {
    EXPECT_EQ(f.data[i], img.data[i]);
    EXPECT_NEAR(h.data[i], img.data[i], 1e-3 * img.data[i]);
  }
  EXPECT_FALSE(std::filesystem::exists(tmp / "f.tmp" ));
}

TEST(ImageIo, BadExrIsOneClearError) {
  TempDir tmp;
  WriteText(tmp / "bad.exr", "this is not an exr");
  ExpectInputError([&] { ReadExr(tmp / "bad.exr"); }, "bad.exr", "unreadable EXR");
  ExpectInputError([&] { ReadExr(tmp / "missing.exr"); }, "missing.exr", "not found");
}

TEST(ImageIo, PngRoundTripAndPreview) {
  TempDir tmp;
  Image img(4, 3, 3);
  for (size_t i = 0; i < img.data.size(); ++i) img.data[i] = (i % 11) / 10.0f;
  WriteLdr(tmp / "a.png", img);
  const Image back = ReadLdr(tmp / "a.png");
  for (size_t i = 0; i < img.data.size(); ++i) EXPECT_NEAR(back.data[i], img.data[i], 0.6 / 255);
  WriteExrWithPreview(tmp / "b.exr", img);
  EXPECT_TRUE(std::filesystem::exists(tmp / "b.png"));
  EXPECT_NEAR(SrgbDecode(SrgbEncode(0.2f)), 0.2f, 1e-6);
}

TEST(MeshIo, ObjAndPlyAgree) {
  TempDir tmp;
  const TriangleMesh box = MakeBox(Eigen::Vector3d(1, 2, 3));
  WriteObj(tmp / "box.obj", box);
  std::ostringstream ply;
  ply << "ply\nformat ascii 1.0\nelement vertex " << box.vertices.size()
      << "\nproperty float x\nproperty float y\nproperty float z\nelement face " << box.faces.size()
      << "\nproperty list uchar int vertex_indices\nend_header\n";
  for (const auto& v : box.vertices) ply << v.x() << ' ' << v.y() << ' ' << v.z() << '\n';
  for (const auto& f : box.faces) ply << "3 " << f[0] << ' ' << f[1] << ' ' << f[2] << '\n';
  WriteText(tmp / "box.ply", ply.str());
  const TriangleMesh a = ReadMesh(tmp / "box.obj");
  const TriangleMesh b = ReadMesh(tmp / "box.ply");
  EXPECT_NEAR(MeshVolume(a), 48, 1e-6);
  EXPECT_NEAR(MeshVolume(b), 48, 1e-6);
  WriteText(tmp / "empty.obj", "# nothing\n");
  ExpectInputError([&] { ReadMesh(tmp / "empty.obj"); }, "empty.obj", "no vertices");
  WriteText(tmp / "nofaces.obj", "v 0 0 0\nv 1 0 0\n");
  ExpectInputError([&] { ReadMesh(tmp / "nofaces.obj"); }, "nofaces.obj", "no faces");
}

// Binary PLY in both byte orders and mixed value types, with a list the
// reader skips (texture coordinates): the same box as the OBJ.
TEST(MeshIo, BinaryPlyBothByteOrders) {
  TempDir tmp;
  const TriangleMesh box = MakeBox(Eigen::Vector3d(1, 2, 3));
  for (const bool big : {false, true}) {
    std::string body;
    auto put = [&](const void* v, size_t n) {
      std::string bytes(static_cast<const char*>(v), n);
      if (big) std::reverse(bytes.begin(), bytes.end());  // the test machine is little-endian
      body += bytes;
    };
    for (const auto& v : box.vertices) {
      const double x = v.x();
      const float y = static_cast<float>(v.y());
      const int16_t z = static_cast<int16_t>(v.z());
      put(&x, 8), put(&y, 4), put(&z, 2);
    }
    for (const auto& f : box.faces) {
      const uint8_t two = 2, three = 3;
      const float uv[2] = {0.25f, 0.5f};
      put(&two, 1), put(&uv[0], 4), put(&uv[1], 4);
      put(&three, 1);
      for (int k = 0; k < 3; ++k) {
        const uint32_t i = static_cast<uint32_t>(f[k]);
        put(&i, 4);
      }
    }
    const std::string file = std::string("box_") + (big ? "be" : "le") + ".ply";
    WriteText(tmp / file, std::string("ply\nformat ") + (big ? "binary_big_endian" : "binary_little_endian") +
                              " 1.0\nelement vertex " + std::to_string(box.vertices.size()) +
                              "\nproperty double x\nproperty float y\nproperty short z\nelement face " +
                              std::to_string(box.faces.size()) +
                              "\nproperty list uchar float texcoord\nproperty list uchar uint vertex_indices\n"
                              "end_header\n" +
                              body);
    const TriangleMesh m = ReadMesh(tmp / file);
    ASSERT_EQ(m.vertices.size(), box.vertices.size()) << file;
    ASSERT_EQ(m.faces.size(), box.faces.size()) << file;
    for (size_t i = 0; i < box.vertices.size(); ++i) EXPECT_EQ(m.vertices[i], box.vertices[i]) << file;
    for (size_t i = 0; i < box.faces.size(); ++i) EXPECT_EQ(m.faces[i], box.faces[i]) << file;
    // Cut short inside the last face: one clear error.
    WriteText(tmp / "short.ply", std::string("ply\nformat ") + (big ? "binary_big_endian" : "binary_little_endian") +
                                     " 1.0\nelement vertex 1\nproperty float x\nelement face 1\n"
                                     "property list uchar int vertex_indices\nend_header\n" +
                                     std::string(4, '\0') + std::string(1, '\3') + std::string(6, '\0'));
    ExpectInputError([&] { ReadMesh(tmp / "short.ply"); }, "short.ply", "truncated");
  }
}

// A vertex line tinyobjloader would read as zeros is an error naming its
// line; CRLF endings, indented lines and other records are left alone.
TEST(MeshIo, ObjVertexLinesAreChecked) {
  const std::string faces = "f 1 2 3\nf 1 3 4\nf 1 4 2\nf 2 4 3\n";
  auto read = [](const std::string& text) {
    std::istringstream in(text);
    return ReadObj(in, "m.obj");
  };
  EXPECT_EQ(read("v 0 0 0\r\nv 1 0 0\r\n  v 0 1 0\n\tv 0 0 1\nvn 0 0 1\n# v x\n" + faces).vertices.size(), 4u);
  EXPECT_EQ(read("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1 1\n" + faces).faces.size(), 4u);  // w is allowed
  ExpectInputError([&] { read("v 0 0 0\nv 1 0\n" + faces); }, "m.obj:2", "vertex needs x y z");
  ExpectInputError([&] { read("v 0 0 0\n\nv 1 abc 0\n" + faces); }, "m.obj:3", "'abc' is not a number");
  ExpectInputError([&] { read("v 1.#IND 0 0\n" + faces); }, "m.obj:1", "'1.#IND' is not a number");
  ExpectInputError([&] { read("v 0 0 0\nv 0 0 inf\n" + faces); }, "m.obj:2", "non-finite");
  ExpectInputError([&] { read("v 0 0 0\nv 0 0 1e999\n" + faces); }, "m.obj:2", "non-finite");
}

TEST(SphIo, RoundTripAndTruncation) {
  SphereTree t;
  t.levels = 2;
  t.branching = 2;
  t.nodes = {{{0, 0, 0}, 1}, {{-0.5, 0, 0}, 0.6}, {{0.5, 0, 0}, 0}};
  std::stringstream ss;
  WriteSph(ss, t);
  const SphereTree back = ReadSph(ss, "mem.sph");
  ASSERT_EQ(back.nodes.size(), 3u);
  EXPECT_TRUE(back.nodes[2].empty());
  EXPECT_DOUBLE_EQ(back.nodes[1].radius, 0.6);
  // Bit-exact: the cached file must give the solver the tree it built.
  SphereTree odd = t;
  odd.nodes[1] = {{1.0 / 3, -2.0 / 7, 1e-9 + 0.1}, std::sqrt(2.0) / 10};
  std::stringstream exact;
  WriteSph(exact, odd);
  const SphereTree odd_back = ReadSph(exact, "exact.sph");
  EXPECT_EQ(odd_back.nodes[1].centre, odd.nodes[1].centre);
  EXPECT_EQ(odd_back.nodes[1].radius, odd.nodes[1].radius);
  std::stringstream bad("3 8\n0 0 0 1\n");
  ExpectInputError([&] { ReadSph(bad, "cut.sph"); }, "cut.sph", "truncated");
}

class SceneIoTest : public ::testing::Test {
 protected:
  void WriteScene(const std::string& json) {
    std::filesystem::create_directories(tmp_.path() / "geometry");
    WriteObj(tmp_ / "geometry/mesh.obj", MakeBox(Eigen::Vector3d(0.1, 0.1, 0.1)));
    WriteExr(tmp_ / "image.exr", Image(8, 6, 3, 0.5f));
    WriteText(tmp_ / "scene.json", json);
  }
  std::string Json(const std::string& normal = "[0, 0, 1]", const std::string& c2w_row0 = "[1,0,0,0]") {
    return R"({"camera": {"proj_type": "perspective", "width": 8, "height": 6, "fx": 10, "fy": 10,
      "cx": 3.5, "cy": 2.5, "c2w": [)" + c2w_row0 + R"(,[0,-1,0,0],[0,0,-1,2],[0,0,0,1]]},
      "plane": {"xyz": [0,0,0], "normal": )" + normal + R"(, "scale": [1,1,1], "diffuse": [0.8,0.8,0.8]},
      "objects": [{"path_to_mesh": "geometry/mesh.obj", "path_to_sph": "geometry/mesh_sphere.sph",
                   "o2w": [[1,0,0,0],[0,1,0,0],[0,0,1,0],[0,0,0,1]], "diffuse": [0.7,0.7,0.7], "is_train": true}],
      "image": "image.exr"})";
  }
  TempDir tmp_;
};

TEST_F(SceneIoTest, LoadsValidScene) {
  WriteScene(Json());
  const Scene s = LoadScene(tmp_.path());
  EXPECT_EQ(s.camera.width, 8);
  EXPECT_EQ(s.objects.size(), 1u);
  EXPECT_FALSE(s.objects[0].sphere_tree);  // named but absent: built later
  EXPECT_EQ(s.image.channels, 3);
}

TEST_F(SceneIoTest, RejectsZeroNormal) {
  WriteScene(Json("[0, 0, 0]"));
  ExpectInputError([&] { LoadScene(tmp_.path()); }, "scene.json", "plane.normal: normal is zero");
}

TEST_F(SceneIoTest, RejectsNonUnitNormal) {
  WriteScene(Json("[0, 0, 2]"));
  ExpectInputError([&] { LoadScene(tmp_.path()); }, "scene.json", "not unit length");
}

TEST_F(SceneIoTest, RejectsWrongShape) {
  WriteScene(Json("[0, 1]"));
  ExpectInputError([&] { LoadScene(tmp_.path()); }, "scene.json", "plane.normal: expected an array of 3 numbers");
  WriteScene(Json("[0,0,1]", "[1,0,0]"));
  ExpectInputError([&] { LoadScene(tmp_.path()); }, "scene.json", "camera.c2w: expected a 4x4 array");
}

TEST_F(SceneIoTest, RejectsMissingKeyAndBadJson) {
  WriteScene(R"({"plane": {}})");
  ExpectInputError([&] { LoadScene(tmp_.path()); }, "scene.json", "camera: missing key");
  WriteScene("{ not json");
  ExpectInputError([&] { LoadScene(tmp_.path()); }, "scene.json", "invalid JSON");
}

TEST_F(SceneIoTest, RejectsImageSizeMismatch) {
  WriteScene(Json());
  WriteExr(tmp_ / "image.exr", Image(9, 6, 3, 0.5f));
  ExpectInputError([&] { LoadScene(tmp_.path()); }, "image.exr", "camera is 8x6");
}

TEST(LightingIo, SgRoundTrip) {
  TempDir tmp;
  SgLighting sg;
  sg.lobes.push_back({Eigen::Vector3d(0, 0.6, 0.8), 12.0, Eigen::Vector3d(1, 2, 3)});
  WriteSgLighting(tmp / "lighting.json", sg);
  const LightSet back = ReadLighting(tmp / "lighting.json");
  ASSERT_TRUE(back.sg);
  ASSERT_EQ(back.sg->lobes.size(), 1u);
  EXPECT_DOUBLE_EQ(back.sg->lobes[0].sharpness, 12.0);
  EXPECT_NEAR((back.sg->lobes[0].axis - Eigen::Vector3d(0, 0.6, 0.8)).norm(), 0, 1e-12);
  WriteText(tmp / "neg.json", R"({"format":"sg-lighting/1","lobes":[{"axis":[0,0,1],"sharpness":1,"amplitude":[-1,0,0]}]})");
  ExpectInputError([&] { ReadLighting(tmp / "neg.json"); }, "neg.json", "lobes[0].amplitude");
}

}  // namespace
}  // namespace shadowsg
