// The bad-input matrix (issue #10, part 1): every file the tool reads, broken
// in the ways files from cameras, photogrammetry programs and 3D packages
// break, fed to the real `shadowsg` binary. Each case must end with a non-zero
// exit status (no signal, no sanitizer report, no hang) and exactly one line
// on stderr that names the file, and must leave the output folder as it was:
// the good file already there byte-identical, nothing half-written beside it.
//
// The good inputs are made once (a tiny synthetic scene by `shadowsg synth`,
// a lighting file, capture artifacts, photos, a COLMAP model); each case copies
// the ones its command needs into its own folder and breaks one of them.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "calib/colmap_model.h"
#include "calib/conventions.h"
#include "calib/image.h"
#include "cli_harness.h"
#include "stages/io/image_io.h"

namespace shadowsg {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::json;
using testing::CliRun;
using testing::ReadWholeFile;
using testing::RunCli;

void WriteText(const fs::path& p, const std::string& text) {
  fs::create_directories(p.parent_path());
  std::ofstream(p, std::ios::binary) << text;
}

const char* kLighting =
    R"({"format": "sg-lighting/1", "up": [0, 0, 1],
        "lobes": [{"axis": [0.4, 0.2, 0.9], "sharpness": 200, "amplitude": [30, 30, 25]},
                  {"axis": [0, 0, 1], "sharpness": 2, "amplitude": [0.2, 0.3, 0.5]}]})";

const char* kCube =
    "v -1 -1 -1\nv 1 -1 -1\nv 1 1 -1\nv -1 1 -1\nv -1 -1 1\nv 1 -1 1\nv 1 1 1\nv -1 1 1\n"
    "f 1 4 3\nf 1 3 2\nf 5 6 7\nf 5 7 8\nf 1 2 6\nf 1 6 5\nf 2 3 7\nf 2 7 6\nf 3 4 8\nf 3 8 7\nf 4 1 5\nf 4 5 8\n";

const char* kPly =
    "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n"
    "element face 4\nproperty list uchar int vertex_indices\nend_header\n"
    "0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";

Json CameraJson(int w, int h) {
  return Json{{"proj_type", "perspective"}, {"width", w}, {"height", h}, {"fx", 30.0}, {"fy", 30.0},
              {"cx", (w - 1) / 2.0}, {"cy", (h - 1) / 2.0}, {"k1", 0.0}, {"k2", 0.0}, {"p1", 0.0},
              {"p2", 0.0}, {"k3", 0.0}, {"c2w", Json::array({{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}})},
              {"rms_px", 0.2}, {"views_used", Json::array()}, {"views_rejected", Json::array()}};
}

// Where the good inputs live (made once per test binary).
class GoodInputs {
 public:
  static const GoodInputs& Get() {
    static GoodInputs g;
    return g;
  }
  fs::path root;
  std::string error;  // set when the good inputs could not be made
  ~GoodInputs() {
    std::error_code ec;
    fs::remove_all(root, ec);
  }

 private:
  GoodInputs() {
    root = fs::temp_directory_path() / ("shadowsg_bad_input_" + std::to_string(getpid()));
    fs::remove_all(root);
    fs::create_directories(root);
    // The scene, by the real binary.
    WriteText(root / "spec.json", testing::kTinySceneSpec);
    const CliRun r = RunCli({"synth", (root / "spec.json").string(), "--out", (root / "scene").string(), "--quiet",
                             "--threads", "2"},
                            root, 120);
    if (!r.exited || r.code != 0) error = "synth failed: " + r.Describe();
    WriteText(root / "lighting.json", kLighting);
    WriteText(root / "cube.obj", kCube);
    WriteText(root / "tet.ply", kPly);
    // Capture artifacts for register: the registered frame, a camera 1 unit
    // above the plane looking down, the cube 0.3 in front of it.
    WriteText(root / "camera.json", CameraJson(16, 12).dump(1));
    const Json c2w = Json::array({{1, 0, 0, 0}, {0, -1, 0, 0}, {0, 0, -1, 1}, {0, 0, 0, 1}});
    WriteText(root / "plane.json",
              Json{{"plane", {{"xyz", {0, 0, 0}}, {"normal", {0, 0, 1}}, {"scale", {2, 2, 1}}}},
                   {"hero", {{"image", "photo.jpg"}, {"c2w", c2w}}},
                   {"scale_source", "none"},
                   {"registered_images", 3},
                   {"plane_inliers", 100}}
                  .dump(1));
    WriteText(root / "pose.json",
              Json{{"o2c", Json::array({{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0.8}, {0, 0, 0, 1}})},
                   {"rms_px", 0.3},
                   {"method", "pnp"}}
                  .dump(1));
    // Photos: an 8-bit PNG with a dark square, its linear EXR twin.
    Image photo(16, 12, 3);
    for (int y = 0; y < 12; ++y)
      for (int x = 0; x < 16; ++x)
        for (int c = 0; c < 3; ++c) photo.at(x, y, c) = (x > 5 && x < 10 && y > 3 && y < 8) ? 0.2f : 0.7f + 0.01f * x;
    WriteLdr(root / "photo.png", photo);
    WriteLdr(root / "photo.jpg", photo);
    WriteExr(root / "photo.exr", photo);
    // A COLMAP model: two cameras looking at a few points, binary and text.
    ColmapModel model;
    ColmapCamera cam;
    cam.id = 1;
    cam.model = "PINHOLE";
    cam.width = 16;
    cam.height = 12;
    cam.params = {30, 30, 8, 6};
    model.cameras[1] = cam;
    for (int i = 1; i <= 2; ++i) {
      ColmapImage im;
      im.id = i;
      im.camera_id = 1;
      im.name = i == 1 ? "photo.jpg" : "other.jpg";
      im.pose.tvec = Eigen::Vector3d(0.1 * i, 0, 2);
      im.points2D = {Eigen::Vector2d(3, 4), Eigen::Vector2d(5, 6)};
      im.point3D_ids = {1, kColmapInvalidPoint3D};
      model.images[i] = im;
    }
    for (int i = 1; i <= 4; ++i) {
      ColmapPoint3D p;
      p.id = i;
      p.xyz = Eigen::Vector3d(0.1 * i, -0.1 * i, 0);
      p.track = {{1, 0}, {2, 0}};
      model.points.push_back(p);
    }
    WriteColmapModel(root / "colmap_bin", model, ColmapFormat::kBinary);
    WriteColmapModel(root / "colmap_txt", model, ColmapFormat::kText);
  }
};

// ---- How each case breaks its file --------------------------------------------

using Mutation = std::function<void(const fs::path& file)>;

Mutation Write(const std::string& text) {
  return [text](const fs::path& f) { WriteText(f, text); };
}
Mutation Empty() { return Write(""); }
Mutation Truncate(double fraction) {
  return [fraction](const fs::path& f) {
    const std::string s = ReadWholeFile(f);
    WriteText(f, s.substr(0, static_cast<size_t>(s.size() * fraction)));
  };
}
Mutation Garbage(size_t n) {
  return [n](const fs::path& f) {
    std::string s(n, '\0');
    uint32_t x = 12345;
    for (char& c : s) c = static_cast<char>((x = x * 1664525u + 1013904223u) >> 24);
    WriteText(f, s);
  };
}
// Edits a JSON file; the string "INF" in the result becomes the literal 1e999
// (which JSON parsers read as infinity) and "NAN" becomes NaN.
Mutation EditJson(std::function<void(Json&)> edit) {
  return [edit](const fs::path& f) {
    Json j = Json::parse(ReadWholeFile(f));
    edit(j);
    std::string s = j.dump(1);
    for (const auto& [from, to] : {std::pair<std::string, std::string>{"\"INF\"", "1e999"}, {"\"NAN\"", "NaN"}})
      for (size_t p; (p = s.find(from)) != std::string::npos;) s.replace(p, from.size(), to);
    WriteText(f, s);
  };
}
// Overwrites the value of EXR header attribute `name` (box2i: four int32).
Mutation PatchExrBox(const std::string& name, int xmin, int ymin, int xmax, int ymax) {
  return [=](const fs::path& f) {
    std::string s = ReadWholeFile(f);
    const std::string key = name + std::string("\0box2i\0", 7);
    const size_t p = s.find(key);
    if (p == std::string::npos) return;
    const int v[4] = {xmin, ymin, xmax, ymax};
    std::memcpy(&s[p + key.size() + 4], v, sizeof(v));
    WriteText(f, s);
  };
}
Mutation WriteImage(int w, int h, float value, bool exr) {
  return [=](const fs::path& f) {
    Image img(w, h, 3, value);
    exr ? WriteExr(f, img) : WriteLdr(f, img);
  };
}
// A scene image the size of the good one, every pixel `value`.
Mutation ConstantSceneImage(float value) {
  return [value](const fs::path& f) {
    Image img = ReadExr(f);
    std::fill(img.data.begin(), img.data.end(), value);
    WriteExr(f, img);
  };
}
Mutation NanPixel() {
  return [](const fs::path& f) {
    Image img = ReadExr(f);
    img.data[img.data.size() / 2] = std::nanf("");
    WriteExr(f, img);
  };
}
// Overwrites bytes of a binary file at `offset` (from the end when negative).
Mutation PatchBytes(long offset, const std::string& bytes) {
  return [=](const fs::path& f) {
    std::string s = ReadWholeFile(f);
    const size_t at = offset >= 0 ? static_cast<size_t>(offset) : s.size() + offset;
    s.replace(at, bytes.size(), bytes);
    WriteText(f, s);
  };
}
std::string U64(uint64_t v) { return std::string(reinterpret_cast<const char*>(&v), 8); }
std::string I32(int32_t v) { return std::string(reinterpret_cast<const char*>(&v), 4); }
std::string F64(double v) { return std::string(reinterpret_cast<const char*>(&v), 8); }

// ---- The commands ----------------------------------------------------------------
// {D}: the case's folder (copies of the good inputs); the output goes to {D}/out.

struct Command {
  std::vector<std::string> inputs;  // good inputs to copy into {D}
  std::vector<std::string> args;
  std::string sentinel;  // the good output file already in {D}/out
};

const std::vector<std::string> kQuiet = {"--quiet", "--threads", "1"};

std::map<std::string, Command> Commands() {
  std::map<std::string, Command> c;
  c["solve"] = {{"scene"},
                {"solve", "{D}/scene", "--out", "{D}/out", "--method", "ss03", "--map-height", "4"},
                "metrics.json"};
  c["info"] = {{"scene"}, {"info", "{D}/scene"}, ""};
  c["eval"] = {{"scene", "lighting.json"},
               {"eval", "{D}/scene", "--lighting", "{D}/lighting.json", "--out", "{D}/out"},
               "metrics.json"};
  c["eval-exr"] = {{"scene"}, {"eval", "{D}/scene", "--lighting", "{D}/env.exr", "--out", "{D}/out"}, "metrics.json"};
  c["render"] = {{"scene", "lighting.json"},
                 {"render", "{D}/scene", "--lighting", "{D}/lighting.json", "--out", "{D}/out/render.exr", "--spp",
                  "1"},
                 "render.exr"};
  c["spheretree-obj"] = {{"cube.obj"}, {"spheretree", "{D}/cube.obj", "--out", "{D}/out/m.sph", "--no-fit"}, "m.sph"};
  c["spheretree-ply"] = {{"tet.ply"}, {"spheretree", "{D}/tet.ply", "--out", "{D}/out/m.sph", "--no-fit"}, "m.sph"};
  c["linearize-png"] = {{"photo.png"}, {"linearize", "{D}/photo.png", "--out", "{D}/out/photo.exr"}, "photo.exr"};
  c["linearize-jpg"] = {{"photo.jpg"}, {"linearize", "{D}/photo.jpg", "--out", "{D}/out/photo.exr"}, "photo.exr"};
  c["linearize-exr"] = {{"photo.exr"}, {"linearize", "{D}/photo.exr", "--out", "{D}/out/photo.exr"}, "photo.exr"};
  c["linearize-raw"] = {{}, {"linearize", "{D}/photo.dng", "--out", "{D}/out/photo.exr"}, "photo.exr"};
  c["undistort"] = {{"photo.exr", "camera.json"},
                    {"linearize", "{D}/photo.exr", "--undistort", "{D}/camera.json", "--out", "{D}/out/photo.exr"},
                    "photo.exr"};
  c["register"] = {{"camera.json", "photo.exr", "plane.json", "pose.json", "cube.obj"},
                   {"register", "--camera", "{D}/camera.json", "--image", "{D}/photo.exr", "--plane",
                    "{D}/plane.json", "--pose", "{D}/pose.json", "--mesh", "{D}/cube.obj", "--out", "{D}/out/scene",
                    "--no-tag-mask"},
                   "scene/scene.json"};
  c["run"] = {{}, {"run", "{D}/cap", "--out", "{D}/out"}, "scene/scene.json"};
  c["plane-bin"] = {{"colmap_bin"},
                    {"plane", "--colmap-model", "{D}/colmap_bin", "--hero", "photo.jpg", "--out", "{D}/out/plane.json"},
                    "plane.json"};
  c["plane-txt"] = {{"colmap_txt"},
                    {"plane", "--colmap-model", "{D}/colmap_txt", "--hero", "photo.jpg", "--out", "{D}/out/plane.json"},
                    "plane.json"};
  return c;
}

struct Case {
  std::string name;     // test name
  std::string command;  // key of Commands()
  std::string file;     // the broken file, relative to {D}
  Mutation mutate;      // empty: the file is removed
  std::string names;    // what the error line must contain (default: file's name)
  std::string problem;  // and this (optional)
};

Mutation Remove() { return nullptr; }

Json& Obj0(Json& j) { return j["objects"][0]; }

std::vector<Case> Cases() {
  const std::string S = "scene/scene.json";
  std::vector<Case> v = {
      // scene.json
      {"scene_json_missing", "solve", S, Remove(), "", "not found"},
      {"scene_json_empty", "solve", S, Empty(), "", "empty"},
      {"scene_json_truncated", "solve", S, Truncate(0.5), "", "invalid JSON"},
      {"scene_json_binary", "solve", S, Garbage(300), "", "invalid JSON"},
      {"scene_json_array", "solve", S, Write("[1, 2]"), "", "object"},
      {"scene_json_width_string", "solve", S, EditJson([](Json& j) { j["camera"]["width"] = "wide"; }), "", "width"},
      {"scene_json_width_zero", "solve", S, EditJson([](Json& j) { j["camera"]["width"] = 0; }), "", "width"},
      {"scene_json_height_negative", "solve", S, EditJson([](Json& j) { j["camera"]["height"] = -24; }), "", "size"},
      {"scene_json_width_huge", "solve", S, EditJson([](Json& j) { j["camera"]["width"] = 4000000000LL; }), "",
       "width"},
      {"scene_json_fx_inf", "solve", S, EditJson([](Json& j) { j["camera"]["fx"] = "INF"; }), "", "overflow"},
      {"scene_json_fx_nan", "solve", S, EditJson([](Json& j) { j["camera"]["fx"] = "NAN"; }), "", "JSON"},
      {"scene_json_fx_zero", "solve", S, EditJson([](Json& j) { j["camera"]["fx"] = 0; }), "", "fx"},
      {"scene_json_k1_inf", "solve", S, EditJson([](Json& j) { j["camera"]["k1"] = "INF"; }), "", "overflow"},
      {"scene_json_c2w_not_rotation", "solve", S, EditJson([](Json& j) { j["camera"]["c2w"][0][0] = 3; }), "",
       "c2w"},
      {"scene_json_c2w_3x3", "solve", S,
       EditJson([](Json& j) { j["camera"]["c2w"] = Json::array({{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}); }), "", "c2w"},
      {"scene_json_plane_normal_zero", "solve", S, EditJson([](Json& j) { j["plane"]["normal"] = {0, 0, 0}; }), "",
       "normal"},
      {"scene_json_plane_scale_negative", "solve", S,
       EditJson([](Json& j) { j["plane"]["scale"] = {-1, 1, 1}; }), "", "scale"},
      {"scene_json_plane_diffuse_nan", "solve", S,
       EditJson([](Json& j) { j["plane"]["diffuse"] = {"INF", 0.5, 0.5}; }), "", "overflow"},
      {"scene_json_no_objects", "solve", S, EditJson([](Json& j) { j["objects"] = Json::array(); }), "", "objects"},
      {"scene_json_objects_not_list", "solve", S, EditJson([](Json& j) { j["objects"] = 7; }), "", "objects"},
      {"scene_json_o2w_singular", "solve", S,
       EditJson([](Json& j) { Obj0(j)["o2w"] = Json::array({{0, 0, 0, 0}, {0, 0, 0, 0}, {0, 0, 0, 0}, {0, 0, 0, 1}}); }),
       "", "o2w"},
      {"scene_json_mesh_path_number", "solve", S, EditJson([](Json& j) { Obj0(j)["path_to_mesh"] = 3; }), "",
       "path_to_mesh"},
      {"scene_json_no_caster", "solve", S, EditJson([](Json& j) { Obj0(j)["is_train"] = false; }), "", "caster"},
      {"scene_json_missing_mesh", "solve", S, EditJson([](Json& j) { Obj0(j)["path_to_mesh"] = "nope.obj"; }),
       "nope.obj", "not found"},
      {"scene_json_orthographic_empty", "solve", S,
       EditJson([](Json& j) {
         j["camera"] = Json{{"proj_type", "orthographic"}, {"width", 32}, {"height", 24}, {"znear", 0},
                            {"zfar", 1},  {"min_x", 1},      {"max_x", 1}, {"min_y", 0},  {"max_y", 1},
                            {"c2w", j["camera"]["c2w"]}};
       }),
       "", "orthographic"},
      // The camera does not see the plane; the mask leaves no plane pixel.
      {"scene_camera_looks_at_sky", "solve", S,
       EditJson([](Json& j) { j["camera"]["c2w"] = Json::array({{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 1}, {0, 0, 0, 1}}); }),
       "", "no shadow-plane pixels"},
      {"scene_camera_below_plane", "solve", S,
       EditJson([](Json& j) { j["camera"]["c2w"] = Json::array({{1, 0, 0, 0}, {0, -1, 0, 0}, {0, 0, -1, -1}, {0, 0, 0, 1}}); }),
       "", "no shadow-plane pixels"},
      {"scene_mask_empty", "solve", "scene/mask.png", WriteImage(32, 24, 0.0f, false), "scene.json",
       "no shadow-plane pixels"},
      // image.exr
      {"image_missing", "solve", "scene/image.exr", Remove(), "", "not found"},
      {"image_empty", "solve", "scene/image.exr", Empty(), "", "empty"},
      {"image_truncated", "solve", "scene/image.exr", Truncate(0.6), "", "EXR"},
      {"image_header_only", "solve", "scene/image.exr", Truncate(0.05), "", "EXR"},
      {"image_garbage", "solve", "scene/image.exr", Garbage(4000), "", "EXR"},
      {"image_wrong_size", "solve", "scene/image.exr", WriteImage(16, 12, 0.5f, true), "", "camera"},
      {"image_huge_data_window", "solve", "scene/image.exr", PatchExrBox("dataWindow", 0, 0, 1000000, 1000000), "",
       "EXR"},
      {"image_negative_data_window", "solve", "scene/image.exr", PatchExrBox("dataWindow", 10, 10, 0, 0), "", "EXR"},
      {"image_nan_pixel", "solve", "scene/image.exr", NanPixel(), "", "non-finite"},
      {"image_all_black", "solve", "scene/image.exr", ConstantSceneImage(0.0f), "", "black"},
      {"image_saturated", "solve", "scene/image.exr", ConstantSceneImage(1.0f), "", "saturated"},
      // mask.png, env_gt.exr, the sphere tree, the meshes of a scene
      {"mask_truncated", "solve", "scene/mask.png", [](const fs::path& f) {
         WriteLdr(f, Image(32, 24, 1, 1.0f));
         Truncate(0.5)(f);
       }, "", ""},
      {"mask_garbage", "solve", "scene/mask.png", Garbage(500), "", "unreadable"},
      {"mask_wrong_size", "solve", "scene/mask.png", WriteImage(8, 8, 1.0f, false), "", "camera"},
      {"env_gt_not_2to1", "solve", "scene/env_gt.exr", WriteImage(8, 8, 1.0f, true), "", "twice as wide"},
      {"env_gt_truncated", "solve", "scene/env_gt.exr", Truncate(0.5), "", "EXR"},
      {"env_gt_negative", "solve", "scene/env_gt.exr", WriteImage(16, 8, -1.0f, true), "", "negative"},
      {"sph_empty", "solve", "scene/geometry/mesh_sphere.sph", Empty(), "", "empty"},
      {"sph_bad_header", "solve", "scene/geometry/mesh_sphere.sph", Write("three two\n"), "", "levels"},
      {"sph_huge_shape", "solve", "scene/geometry/mesh_sphere.sph", Write("8 64\n0 0 0 1\n"), "", "sphere tree"},
      {"sph_truncated", "solve", "scene/geometry/mesh_sphere.sph", Write("3 8\n0 0 0 1\n0 0 0 0.5\n"), "",
       "truncated"},
      {"sph_nan", "solve", "scene/geometry/mesh_sphere.sph", Write("1 2\nnan 0 0 1\n"), "", ""},
      {"sph_inf", "solve", "scene/geometry/mesh_sphere.sph", Write("1 2\n0 0 0 inf\n"), "", ""},
      {"sph_garbage", "solve", "scene/geometry/mesh_sphere.sph", Garbage(200), "", ""},
      {"scene_mesh_empty", "solve", "scene/geometry/mesh.obj", Empty(), "", "no vertices"},
      {"scene_mesh_truncated", "solve", "scene/geometry/mesh.obj", Truncate(0.3), "", ""},
      {"scene_mesh_garbage", "solve", "scene/geometry/mesh.obj", Garbage(3000), "", ""},
      {"info_scene_json_truncated", "info", S, Truncate(0.7), "", "invalid JSON"},
      // OBJ (spheretree reads one mesh)
      {"obj_empty", "spheretree-obj", "cube.obj", Empty(), "", "no vertices"},
      {"obj_truncated", "spheretree-obj", "cube.obj", Truncate(0.45), "", ""},
      {"obj_garbage", "spheretree-obj", "cube.obj", Garbage(2000), "", ""},
      {"obj_index_out_of_range", "spheretree-obj", "cube.obj", Write("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n"), "",
       "vertex"},
      {"obj_index_zero", "spheretree-obj", "cube.obj", Write("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n"), "", ""},
      {"obj_nan_vertex", "spheretree-obj", "cube.obj",
       Write("v nan 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 3 4\nf 1 4 2\nf 2 4 3\n"), "", "non-finite"},
      {"obj_inf_vertex", "spheretree-obj", "cube.obj",
       Write("v 1e999 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\nf 1 3 4\nf 1 4 2\nf 2 4 3\n"), "", "non-finite"},
      {"obj_no_faces", "spheretree-obj", "cube.obj", Write("v 0 0 0\nv 1 0 0\nv 0 1 0\n"), "", "faces"},
      {"obj_degenerate_faces", "spheretree-obj", "cube.obj",
       Write("v 0 0 0\nv 0 0 0\nv 0 0 0\nv 1 1 1\nf 1 2 3\nf 1 2 3\n"), "", "degenerate"},
      {"obj_flat_open_sheet", "spheretree-obj", "cube.obj", Write("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"), "",
       "volume"},
      {"obj_huge_coordinates", "spheretree-obj", "cube.obj",
       Write("v -1e300 -1e300 -1e300\nv 1e300 -1e300 -1e300\nv 0 1e300 -1e300\nv 0 0 1e300\nf 1 3 2\nf 1 2 4\nf 2 3 "
             "4\nf 3 1 4\n"),
       "", ""},
      // PLY
      {"ply_empty", "spheretree-ply", "tet.ply", Empty(), "", ""},
      {"ply_no_magic", "spheretree-ply", "tet.ply", Write("plx\nend_header\n"), "", "PLY"},
      {"ply_no_end_header", "spheretree-ply", "tet.ply", Truncate(0.3), "", "end_header"},
      {"ply_truncated_body", "spheretree-ply", "tet.ply", Truncate(0.9), "", "truncated"},
      {"ply_binary_truncated", "spheretree-ply", "tet.ply",
       Write("ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty "
             "float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\x01\x02"),
       "", "truncated"},
      {"ply_huge_count", "spheretree-ply", "tet.ply",
       Write("ply\nformat binary_little_endian 1.0\nelement vertex 2000000000\nproperty double x\nend_header\n1234"),
       "", ""},
      {"ply_huge_list", "spheretree-ply", "tet.ply",
       Write("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float "
             "z\nelement face 1\nproperty list uint int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n4000000000 0 1 2\n"),
       "", "list"},
      {"ply_negative_count", "spheretree-ply", "tet.ply", Write("ply\nformat ascii 1.0\nelement vertex -3\nend_header\n"),
       "", "element"},
      {"ply_unknown_type", "spheretree-ply", "tet.ply",
       Write("ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty quad x\nend_header\nAAAAAAAA"), "",
       "type"},
      {"ply_unknown_format", "spheretree-ply", "tet.ply", Write("ply\nformat utf16 1.0\nend_header\n"), "", "format"},
      {"ply_index_out_of_range", "spheretree-ply", "tet.ply",
       Write("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float "
             "z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 -7\n"),
       "", "vertex"},
      {"ply_nan_vertex", "spheretree-ply", "tet.ply",
       Write("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float "
             "z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\nnan 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"),
       "", ""},
      {"ply_nan_list_count", "spheretree-ply", "tet.ply",
       // Binary: the count is a float NaN (0x7fc00000) after three zero vertices.
       Write("ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty "
             "float z\nelement face 1\nproperty list float int vertex_indices\nend_header\n" +
             std::string(36, '\0') + std::string("\0\0\xc0\x7f", 4)),
       "", "list length"},
      {"ply_propertyless_element", "spheretree-ply", "tet.ply",
       Write("ply\nformat binary_little_endian 1.0\nelement junk 1666666606\nend_header\n"), "", "no properties"},
      // lighting.json (eval reads it first; render too)
      {"lighting_missing", "eval", "lighting.json", Remove(), "", "not found"},
      {"lighting_empty", "eval", "lighting.json", Empty(), "", "empty"},
      {"lighting_truncated", "eval", "lighting.json", Truncate(0.5), "", "invalid JSON"},
      {"lighting_wrong_format", "eval", "lighting.json", EditJson([](Json& j) { j["format"] = "sg/9"; }), "",
       "format"},
      {"lighting_lobes_not_list", "eval", "lighting.json", EditJson([](Json& j) { j["lobes"] = "many"; }), "",
       "lobes"},
      {"lighting_no_lobes", "eval", "lighting.json", EditJson([](Json& j) { j["lobes"] = Json::array(); }), "",
       "no light"},
      {"lighting_axis_zero", "eval", "lighting.json", EditJson([](Json& j) { j["lobes"][0]["axis"] = {0, 0, 0}; }),
       "", "axis"},
      {"lighting_axis_short", "eval", "lighting.json", EditJson([](Json& j) { j["lobes"][0]["axis"] = {0, 1}; }), "",
       "axis"},
      {"lighting_sharpness_negative", "eval", "lighting.json",
       EditJson([](Json& j) { j["lobes"][0]["sharpness"] = -3; }), "", "sharpness"},
      {"lighting_sharpness_inf", "eval", "lighting.json",
       EditJson([](Json& j) { j["lobes"][0]["sharpness"] = "INF"; }), "", "overflow"},
      {"lighting_sharpness_huge", "eval", "lighting.json",
       EditJson([](Json& j) { j["lobes"][0]["sharpness"] = 1e300; }), "", "sharpness"},
      {"lighting_amplitude_negative", "eval", "lighting.json",
       EditJson([](Json& j) { j["lobes"][0]["amplitude"] = {-1, 1, 1}; }), "", "amplitude"},
      {"lighting_amplitude_huge", "eval", "lighting.json",
       EditJson([](Json& j) { j["lobes"][0]["amplitude"] = {1e300, 1, 1}; }), "", "amplitude"},
      {"lighting_up_zero", "eval", "lighting.json", EditJson([](Json& j) { j["up"] = {0, 0, 0}; }), "", "up"},
      {"lighting_env_missing", "eval", "lighting.json",
       EditJson([](Json& j) { j = Json{{"format", "lights/1"}, {"env", "nope.exr"}}; }), "nope.exr", "not found"},
      {"lighting_sun_zero", "eval", "lighting.json",
       EditJson([](Json& j) {
         j = Json{{"format", "lights/1"}, {"suns", {{{"direction", {0, 0, 0}}, {"irradiance", {1, 1, 1}}}}}};
       }),
       "", "direction"},
      {"lighting_sun_negative", "render", "lighting.json",
       EditJson([](Json& j) {
         j = Json{{"format", "lights/1"}, {"suns", {{{"direction", {0, 0, 1}}, {"irradiance", {-1, 1, 1}}}}}};
       }),
       "", "irradiance"},
      {"render_lighting_truncated", "render", "lighting.json", Truncate(0.4), "", "invalid JSON"},
      {"envmap_not_2to1", "eval-exr", "env.exr", WriteImage(8, 8, 1.0f, true), "", "twice as wide"},
      // Negative texels are allowed here: SS03's estimates hold them and eval scores them.
      {"envmap_nan", "eval-exr", "env.exr", WriteImage(16, 8, std::nanf(""), true), "", "non-finite"},
      {"envmap_truncated", "eval-exr", "env.exr", [](const fs::path& f) {
         WriteImage(16, 8, 1.0f, true)(f);
         Truncate(0.5)(f);
       }, "", "EXR"},
      // PNG / JPEG / EXR photos (linearize)
      {"png_empty", "linearize-png", "photo.png", Empty(), "", "empty"},
      {"png_truncated", "linearize-png", "photo.png", Truncate(0.5), "", ""},
      {"png_garbage", "linearize-png", "photo.png", Garbage(1000), "", "unreadable"},
      // A DICOM preamble: OpenCV's content sniffing would hand it to GDCM, which aborts.
      {"png_is_dicom", "linearize-png", "photo.png", Write(std::string(128, ',') + "DICMv"), "", "not a PNG or JPEG"},
      {"png_all_black", "linearize-png", "photo.png", WriteImage(16, 12, 0.0f, false), "", "black"},
      {"png_saturated", "linearize-png", "photo.png", WriteImage(16, 12, 1.0f, false), "", "saturated"},
      {"png_is_a_folder", "linearize-png", "photo.png", [](const fs::path& f) {
         fs::remove(f);
         fs::create_directories(f);
       }, "", ""},
      {"jpg_truncated", "linearize-jpg", "photo.jpg", Truncate(0.3), "", ""},
      {"jpg_garbage", "linearize-jpg", "photo.jpg", Garbage(1000), "", "unreadable"},
      {"exr_truncated", "linearize-exr", "photo.exr", Truncate(0.5), "", "EXR"},
      {"exr_garbage", "linearize-exr", "photo.exr", Garbage(1000), "", "EXR"},
      {"exr_huge_data_window", "linearize-exr", "photo.exr", PatchExrBox("dataWindow", -5, -5, 2000000000, 7), "",
       "EXR"},
      {"exr_nan", "linearize-exr", "photo.exr", NanPixel(), "", "non-finite"},
      // camera raw
      {"raw_empty", "linearize-raw", "photo.dng", Empty(), "", ""},
      {"raw_garbage", "linearize-raw", "photo.dng", Garbage(5000), "", ""},
      {"raw_tiff_header_only", "linearize-raw", "photo.dng", Write(std::string("II*\0\x08\0\0\0\x01\0", 10)), "",
       ""},
      // camera.json (linearize --undistort; register)
      {"camera_json_empty", "undistort", "camera.json", Empty(), "", "empty"},
      {"camera_json_truncated", "undistort", "camera.json", Truncate(0.5), "", "invalid JSON"},
      {"camera_json_not_object", "undistort", "camera.json", Write("\"camera\""), "", "object"},
      {"camera_json_fx_string", "undistort", "camera.json", EditJson([](Json& j) { j["fx"] = "600"; }), "", "fx"},
      {"camera_json_fx_negative", "undistort", "camera.json", EditJson([](Json& j) { j["fx"] = -30; }), "", "fx"},
      {"camera_json_width_zero", "undistort", "camera.json", EditJson([](Json& j) { j["width"] = 0; }), "", "width"},
      {"camera_json_height_huge", "undistort", "camera.json", EditJson([](Json& j) { j["height"] = 1e9; }), "",
       "size"},
      {"camera_json_k1_inf", "undistort", "camera.json", EditJson([](Json& j) { j["k1"] = "INF"; }), "", "overflow"},
      {"camera_json_cx_nan", "undistort", "camera.json", EditJson([](Json& j) { j["cx"] = "NAN"; }), "", "JSON"},
      {"camera_json_wrong_size", "undistort", "camera.json", EditJson([](Json& j) { j["width"] = 17; }), "", "camera"},
      {"register_camera_truncated", "register", "camera.json", Truncate(0.4), "", "invalid JSON"},
      // pose.json and plane.json (register)
      {"pose_json_empty", "register", "pose.json", Empty(), "", "empty"},
      {"pose_json_truncated", "register", "pose.json", Truncate(0.5), "", "invalid JSON"},
      {"pose_json_o2c_nan", "register", "pose.json", EditJson([](Json& j) { j["o2c"][0][3] = "INF"; }), "", "overflow"},
      {"pose_json_o2c_shear", "register", "pose.json", EditJson([](Json& j) { j["o2c"][0][1] = 0.5; }), "", "o2c"},
      {"pose_json_method", "register", "pose.json", EditJson([](Json& j) { j["method"] = 3; }), "", "method"},
      {"pose_json_no_rms", "register", "pose.json", EditJson([](Json& j) { j.erase("rms_px"); }), "", "rms_px"},
      {"pose_json_plane_normal_zero", "register", "pose.json",
       EditJson([](Json& j) { j["plane_c"] = {{"xyz", {0, 0, 1}}, {"normal", {0, 0, 0}}}; }), "", "normal"},
      {"pose_json_behind_camera", "register", "pose.json", EditJson([](Json& j) { j["o2c"][2][3] = -0.8; }), "", ""},
      {"plane_json_empty", "register", "plane.json", Empty(), "", "empty"},
      {"plane_json_truncated", "register", "plane.json", Truncate(0.5), "", "invalid JSON"},
      {"plane_json_normal_zero", "register", "plane.json",
       EditJson([](Json& j) { j["plane"]["normal"] = {0, 0, 0}; }), "", "normal"},
      {"plane_json_hero_c2w_bad", "register", "plane.json", EditJson([](Json& j) { j["hero"]["c2w"][3][3] = 0; }),
       "", "c2w"},
      {"plane_json_scale_source", "register", "plane.json", EditJson([](Json& j) { j["scale_source"] = "guess"; }),
       "", "scale_source"},
      {"plane_json_scale_zero", "register", "plane.json",
       EditJson([](Json& j) { j["plane"]["scale"] = {0, 0, 1}; }), "", "scale"},
      {"plane_json_camera_under_plane", "register", "plane.json",
       EditJson([](Json& j) { j["hero"]["c2w"][2][3] = -1; }), "", "above the plane"},
      {"register_mesh_garbage", "register", "cube.obj", Garbage(500), "", ""},
      {"register_image_black", "register", "photo.exr", WriteImage(16, 12, 0.0f, true), "", ""},
      // capture.json (`shadowsg run`; the reader: stages/io/capture_manifest_io)
      {"capture_json_missing", "run", "cap/capture.json", Remove(), "cap", ""},
      {"capture_json_empty", "run", "cap/capture.json", Empty(), "", "empty"},
      {"capture_json_truncated", "run", "cap/capture.json", Write("{\"format\": \"capture/1\", \"hero\": {"), "",
       "invalid JSON"},
      {"capture_json_not_object", "run", "cap/capture.json", Write("[]"), "", "object"},
      {"capture_json_wrong_format", "run", "cap/capture.json", Write("{\"format\": \"capture/9\"}"), "", "format"},
      {"capture_json_unknown_key", "run", "cap/capture.json", Write("{\"format\": \"capture/1\", \"heroes\": 1}"), "",
       "unknown key"},
      {"capture_json_inf", "run", "cap/capture.json", Write("{\"format\": \"capture/1\", \"solve\": {\"lobes\": 1e999}}"),
       "", "overflow"},
      {"capture_json_missing_folder", "run", "cap/capture.json",
       Write("{\"format\": \"capture/1\", \"walkaround\": {\"images\": \"nope\"}}"), "", ""},
      // COLMAP models (plane --colmap-model)
      {"colmap_cameras_bin_empty", "plane-bin", "colmap_bin/cameras.bin", Empty(), "", "truncated"},
      {"colmap_cameras_bin_truncated", "plane-bin", "colmap_bin/cameras.bin", Truncate(0.5), "", "truncated"},
      {"colmap_cameras_bin_huge_count", "plane-bin", "colmap_bin/cameras.bin", PatchBytes(0, U64(1ull << 40)), "",
       "implausible"},
      {"colmap_cameras_bin_model_id", "plane-bin", "colmap_bin/cameras.bin", PatchBytes(12, I32(99)), "", "model"},
      {"colmap_cameras_bin_width_zero", "plane-bin", "colmap_bin/cameras.bin", PatchBytes(16, U64(0)), "", "size"},
      {"colmap_cameras_bin_focal_nan", "plane-bin", "colmap_bin/cameras.bin", PatchBytes(32, F64(std::nan(""))), "",
       "non-finite"},
      {"colmap_images_bin_truncated", "plane-bin", "colmap_bin/images.bin", Truncate(0.5), "", "truncated"},
      {"colmap_images_bin_huge_points", "plane-bin", "colmap_bin/images.bin",
       PatchBytes(8 + 4 + 56 + 4 + 10, U64(1ull << 30)), "", "truncated"},
      {"colmap_images_bin_zero_quaternion", "plane-bin", "colmap_bin/images.bin",
       PatchBytes(12, U64(0) + U64(0) + U64(0) + U64(0)), "", "quaternion"},
      {"colmap_images_bin_unknown_camera", "plane-bin", "colmap_bin/images.bin", PatchBytes(8 + 4 + 56, I32(7)),
       "colmap_bin", "camera 7"},
      {"colmap_points_bin_huge_count", "plane-bin", "colmap_bin/points3D.bin", PatchBytes(0, U64(1ull << 31)), "",
       ""},
      {"colmap_points_bin_huge_track", "plane-bin", "colmap_bin/points3D.bin", PatchBytes(8 + 8 + 24 + 3 + 8,
       U64(1ull << 31)), "", "truncated"},
      {"colmap_points_bin_garbage", "plane-bin", "colmap_bin/points3D.bin", Garbage(333), "", ""},
      {"colmap_rig_model", "plane-bin", "colmap_bin/rigs.bin", Write("x"), "colmap_bin", "rig"},
      {"colmap_missing_images", "plane-bin", "colmap_bin/images.bin", Remove(), "colmap_bin", "no COLMAP model"},
      {"colmap_cameras_txt_garbage", "plane-txt", "colmap_txt/cameras.txt", Write("1 PINHOLE sixteen 12 30 30 8 6\n"),
       "", "CAMERA_ID"},
      {"colmap_cameras_txt_params", "plane-txt", "colmap_txt/cameras.txt", Write("1 PINHOLE 16 12 30 30 8\n"), "",
       "parameters"},
      {"colmap_cameras_txt_nan", "plane-txt", "colmap_txt/cameras.txt", Write("1 PINHOLE 16 12 nan 30 8 6\n"), "",
       ""},
      {"colmap_cameras_txt_negative_size", "plane-txt", "colmap_txt/cameras.txt",
       Write("1 PINHOLE -16 12 30 30 8 6\n"), "", "size"},
      {"colmap_cameras_txt_unknown_model", "plane-txt", "colmap_txt/cameras.txt", Write("1 WARP 16 12 30\n"), "",
       "model"},
      {"colmap_images_txt_short", "plane-txt", "colmap_txt/images.txt", Write("1 1 0 0 0 0 0\n"), "", "IMAGE_ID"},
      {"colmap_images_txt_bad_point", "plane-txt", "colmap_txt/images.txt",
       Write("1 1 0 0 0 0 0 2 1 photo.jpg\n3 4 x\n"), "", "POINT3D_ID"},
      {"colmap_images_txt_inf_pose", "plane-txt", "colmap_txt/images.txt",
       Write("1 1 0 0 0 inf 0 2 1 photo.jpg\n\n"), "", ""},
      {"colmap_points_txt_colour", "plane-txt", "colmap_txt/points3D.txt", Write("1 0 0 0 300 0 0 0.5\n"), "",
       "colour"},
      {"colmap_points_txt_truncated", "plane-txt", "colmap_txt/points3D.txt", Write("1 0 0\n"), "", "POINT3D_ID"},
      {"colmap_points_txt_odd_track", "plane-txt", "colmap_txt/points3D.txt", Write("1 0 0 0 1 2 3 0.5 1\n"), "",
       "pairs"},
  };
  return v;
}

// Everything under `dir` with its content.
std::map<std::string, std::string> Snapshot(const fs::path& dir) {
  std::map<std::string, std::string> m;
  std::error_code ec;
  if (!fs::exists(dir, ec)) return m;
  for (const auto& e : fs::recursive_directory_iterator(dir, ec))
    m[fs::relative(e.path(), dir).string()] = e.is_regular_file() ? ReadWholeFile(e.path()) : "<dir>";
  return m;
}

void PrintTo(const Case& c, std::ostream* os) { *os << c.name; }

class BadInput : public ::testing::TestWithParam<Case> {};

TEST_P(BadInput, FailsCleanlyWithOneLineNamingTheFile) {
  const GoodInputs& good = GoodInputs::Get();
  ASSERT_TRUE(good.error.empty()) << good.error;
  const Case& c = GetParam();
  const Command cmd = Commands().at(c.command);
  const fs::path dir = good.root / "cases" / c.name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  for (const auto& in : cmd.inputs) fs::copy(good.root / in, dir / in, fs::copy_options::recursive);
  const fs::path file = dir / c.file;
  if (c.mutate) {
    fs::create_directories(file.parent_path());
    c.mutate(file);
  } else {
    fs::remove_all(file);
  }
  // A good output from an earlier run, which must survive.
  const fs::path out = dir / "out";
  fs::create_directories(out);
  if (!cmd.sentinel.empty()) WriteText(out / cmd.sentinel, "good output of an earlier run\n");
  const auto before = Snapshot(out);

  std::vector<std::string> args;
  for (std::string a : cmd.args) {
    for (size_t p; (p = a.find("{D}")) != std::string::npos;) a.replace(p, 3, dir.string());
    args.push_back(a);
  }
  args.insert(args.end(), kQuiet.begin(), kQuiet.end());
  const CliRun r = RunCli(args, good.root, 30);

  ASSERT_FALSE(r.timed_out) << r.Describe();
  ASSERT_TRUE(r.exited) << "killed by a signal: " << r.Describe();
  EXPECT_NE(r.code, 0) << r.Describe();
  EXPECT_LT(r.code, 128) << r.Describe();
  const auto lines = r.ErrLines();
  ASSERT_EQ(lines.size(), 1u) << r.Describe();
  const std::string& line = lines[0];
  EXPECT_EQ(line.rfind("error: ", 0), 0u) << line;
  const std::string names = c.names.empty() ? fs::path(c.file).filename().string() : c.names;
  EXPECT_NE(line.find(names), std::string::npos) << "the line does not name " << names << ": " << line;
  if (!c.problem.empty()) {
    EXPECT_NE(line.find(c.problem), std::string::npos) << "expected \"" << c.problem << "\": " << line;
  }
  EXPECT_EQ(r.err.find("Sanitizer"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("runtime error"), std::string::npos) << r.err;
  // The output folder is as it was: no partial or temporary file, the good one intact.
  EXPECT_EQ(Snapshot(out), before);
  // And the inputs' folder holds no temporaries either.
  for (const auto& e : fs::recursive_directory_iterator(dir))
    EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos) << e.path();
  // The matrix's line for the README: case -> message.
  std::printf("[matrix] %-36s -> exit %d: %s\n", c.name.c_str(), r.code, line.c_str());
  fs::remove_all(dir);
}

INSTANTIATE_TEST_SUITE_P(Matrix, BadInput, ::testing::ValuesIn(Cases()),
                         [](const ::testing::TestParamInfo<Case>& i) { return i.param.name; });

// The good inputs are good: each command succeeds on them (so every failure
// above is the broken file's doing). Only the cheap commands.
TEST(BadInputBaseline, GoodInputsPass) {
  const GoodInputs& good = GoodInputs::Get();
  ASSERT_TRUE(good.error.empty()) << good.error;
  for (const std::string name : {"info", "spheretree-obj", "spheretree-ply", "linearize-png", "linearize-exr",
                                 "undistort"}) {
    const Command cmd = Commands().at(name);
    const fs::path dir = good.root / "cases" / ("good_" + name);
    fs::remove_all(dir);
    fs::create_directories(dir / "out");
    for (const auto& in : cmd.inputs) fs::copy(good.root / in, dir / in, fs::copy_options::recursive);
    std::vector<std::string> args;
    for (std::string a : cmd.args) {
      for (size_t p; (p = a.find("{D}")) != std::string::npos;) a.replace(p, 3, dir.string());
      args.push_back(a);
    }
    args.insert(args.end(), kQuiet.begin(), kQuiet.end());
    const CliRun r = RunCli(args, good.root, 60);
    EXPECT_TRUE(r.exited && r.code == 0) << name << ": " << r.Describe();
    fs::remove_all(dir);
  }
}

}  // namespace
}  // namespace shadowsg
