// `shadowsg run` (stages/run_stage.h): capture.json's errors name the file
// and the key; the resume rule (settings, inputs newer than outputs, missing
// outputs); and, with the real COLMAP program (CTest label "colmap", skipped
// without it), a synthetic capture folder end to end: the lighting solved on
// the registered scene re-renders the hero photo within 1 dB of the same
// solver on the true scene; a second run skips every stage; a touched input,
// --force and a changed setting redo exactly the stages they should.
// RunCaptureResume (fast, no COLMAP: capture.json names a camera.json and a
// sparse model made from the capture's true cameras) interrupts the real
// `shadowsg run` binary while solve runs and resumes it.
#include "stages/run_stage.h"

#include <gtest/gtest.h>

#include <signal.h>

#include <chrono>
#include <cstdio>
#include <functional>
#include <map>
#include <random>
#include <set>
#include <thread>

#include "calib/colmap_model.h"
#include "calib/error.h"
#include "solver/primitives.h"
#include "stages/colmap_runner.h"
#include "stages/io/atomic_file.h"
#include "stages/io/capture_io.h"
#include "stages/io/capture_manifest_io.h"
#include "stages/io/mesh_io.h"
#include "stages/io/scene_io.h"
#include "stages/solve_stage.h"
#include "stages/stage_util.h"
#include "cli_harness.h"
#include "multiview_capture.h"
#include "test_util.h"

namespace shadowsg {
namespace {

namespace fs = std::filesystem;
using testing::TempDir;

void Touch(const fs::path& p, const std::string& text = "x") { WriteTextAtomically(p, text); }

// The files a capture.json names, as empty stand-ins (the reader only checks
// that they exist), and the document.
Json MinimalCapture(const TempDir& tmp) {
  fs::create_directories(tmp / "boards");
  fs::create_directories(tmp / "images");
  Touch(tmp / "images" / "hero.png");
  Touch(tmp / "hero.exr");
  Touch(tmp / "box.obj");
  return Json{{"format", "capture/1"},
              {"intrinsics", {{"images", "boards"}, {"board", "8x5"}, {"square", 0.03}}},
              {"walkaround", {{"images", "images"}}},
              {"hero", {{"photo", "images/hero.png"}, {"linear", "hero.exr"}, {"times", {"1/4"}}}},
              {"object", {{"mesh", "box.obj"}}},
              {"tags", {{"size", 0.2}, {"offset", {0.1, 0.2, 0.15}}}},
              {"solve", {{"method", "sg"}, {"budget", "fast"}}}};
}

std::string ParseError(const TempDir& tmp, const Json& doc) {
  try {
    ParseCaptureManifest(doc, (tmp / "capture.json").string(), tmp.path());
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}

TEST(RunCaptureManifest, ReadsAValidCapture) {
  TempDir tmp;
  const CaptureManifest m = ParseCaptureManifest(MinimalCapture(tmp), "capture.json", tmp.path());
  EXPECT_EQ(m.intrinsics.cols, 8);
  EXPECT_EQ(m.intrinsics.rows, 5);
  EXPECT_EQ(m.intrinsics.images, tmp / "boards");
  EXPECT_EQ(m.hero.photo, tmp / "images" / "hero.png");
  ASSERT_EQ(m.hero.linear.size(), 1u);
  ASSERT_EQ(m.hero.times.size(), 1u);
  EXPECT_DOUBLE_EQ(m.hero.times[0], 0.25);
  EXPECT_DOUBLE_EQ(m.tags.size, 0.2);
  ASSERT_TRUE(m.tags.offset);
  EXPECT_DOUBLE_EQ(m.tags.offset->z(), 0.15);
  EXPECT_EQ(m.solve.budget, "fast");
  EXPECT_FALSE(m.solve.lobes);  // left to the stage's default
  EXPECT_TRUE(m.composite.objects.empty());
}

TEST(RunCaptureManifest, ErrorsNameTheFileAndTheKey) {
  TempDir tmp;
  const Json good = MinimalCapture(tmp);
  struct Case {
    std::function<void(Json&)> edit;
    std::string expected;  // after "<tmp>/capture.json: "
  };
  const std::vector<Case> cases = {
      {[](Json& j) { j["format"] = "capture/2"; }, "format: expected \"capture/1\""},
      {[](Json& j) { j.erase("intrinsics"); }, "intrinsics: missing key"},
      {[](Json& j) { j["hero"] = "hero.png"; }, "hero: expected an object"},
      {[](Json& j) { j["hero"]["linear"] = {{"a", 1}}; }, "hero.linear: expected a path or a list of paths"},
      {[](Json& j) { j["solve"]["budgte"] = "fast"; }, "solve.budgte: unknown key"},
      {[](Json& j) { j["solve"]["method"] = "magic"; }, "solve.method: expected one of sg, sg-paper"},
      {[](Json& j) { j["object"]["mesh"] = "bunny.obj"; }, "object.mesh: file not found"},
      {[](Json& j) { j["walkaround"]["images"] = "photos"; }, "walkaround.images: folder not found"},
      {[](Json& j) { j["hero"]["photo"] = "hero.exr"; }, "hero.photo: must be one of walkaround.images' photos"},
      {[](Json& j) { j["intrinsics"]["board"] = "8by5"; }, "intrinsics.board: expected inner corners"},
      {[](Json& j) { j["hero"]["times"] = {0.25, 1}; }, "hero.times: 2 times for 1 linear input(s)"},
      {[](Json& j) { j["hero"]["times"] = {"fast"}; }, "hero.times[0]: expected a positive time"},
      {[](Json& j) { j["tags"].erase("size"); }, "tags.size: missing key"},
      {[](Json& j) { j["plane"] = {{"albedo", 1.5}}; }, "plane.albedo: albedo must be in (0, 1]"},
      {[](Json& j) { j["intrinsics"]["camera"] = "camera.json"; }, "intrinsics.images: give either"},
  };
  for (const auto& c : cases) {
    Json doc = good;
    c.edit(doc);
    const std::string error = ParseError(tmp, doc);
    EXPECT_EQ(error.rfind((tmp / "capture.json").string() + ": " + c.expected, 0), 0u)
        << error;
  }
}

TEST(RunCaptureManifest, MissingCaptureJsonAndBadForce) {
  TempDir tmp;
  RunCaptureOptions o;
  o.capture = tmp.path();
  StageContext ctx;
  ctx.quiet = true;
  try {
    RunCapture(o, ctx);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), (tmp / "capture.json").string() + ": file not found");
  }
  o.force = {"solve", "colmap"};
  EXPECT_NE(o.Validate().find("--force: unknown stage \"colmap\""), std::string::npos) << o.Validate();
  o.force = {"plane", "all"};
  EXPECT_EQ(o.Validate(), "");
}

TEST(RunStaleness, SettingsInputsAndOutputs) {
  TempDir tmp;
  Touch(tmp / "in.txt");
  Touch(tmp / "out.txt");
  StageRecord r;
  r.settings = {{"solve", {{"budget", "fast"}}}, {"seed", "0"}};
  r.inputs = {tmp / "in.txt"};
  r.outputs = {tmp / "out.txt"};
  const fs::path stamp = tmp / "stamps" / "solve.json";
  EXPECT_EQ(StaleReason(r, stamp), "not run before");
  WriteStamp(r, stamp, 1.0);
  EXPECT_EQ(StaleReason(r, stamp), "");

  StageRecord changed = r;
  changed.settings["solve"]["budget"] = "best";
  EXPECT_EQ(StaleReason(changed, stamp), "settings changed (solve)");
  changed = r;
  changed.settings.erase("seed");
  EXPECT_EQ(StaleReason(changed, stamp), "settings changed (seed)");

  // An input written after the outputs.
  fs::last_write_time(tmp / "in.txt", fs::last_write_time(tmp / "out.txt") + std::chrono::seconds(1));
  EXPECT_EQ(StaleReason(r, stamp), "input changed: " + (tmp / "in.txt").string());
  // Outputs rewritten after it: up to date again.
  fs::last_write_time(tmp / "out.txt", fs::last_write_time(tmp / "in.txt") + std::chrono::seconds(1));
  EXPECT_EQ(StaleReason(r, stamp), "");

  fs::remove(tmp / "out.txt");
  EXPECT_EQ(StaleReason(r, stamp), "output missing: " + (tmp / "out.txt").string());
  Touch(tmp / "out.txt");
  fs::remove(tmp / "in.txt");
  EXPECT_EQ(StaleReason(r, stamp), "input missing: " + (tmp / "in.txt").string());
}

// ---- End to end (COLMAP) ------------------------------------------------------

std::set<std::string> StagesWithStatus(const RunCaptureResult& r, const std::string& status) {
  std::set<std::string> out;
  for (const auto& s : r.stages)
    if (s.status == status) out.insert(s.name);
  return out;
}

double Psnr(const fs::path& solve_dir) { return ReadJsonFile(solve_dir / "metrics.json")["psnr"].get<double>(); }

// The registered scene with the truth put in: the true camera (lens and hero
// pose), plane and object pose, keeping the photo, mask, mesh and albedo. The
// same solver on it gives the PSNR a perfect registration would.
void WriteTrueScene(const fs::path& registered, const fs::path& dir, const testing::MultiviewCapture& cap) {
  fs::create_directories(dir / "geometry");
  for (const char* f : {"image.exr", "mask.png", "geometry/mesh.obj"}) fs::copy_file(registered / f, dir / f);
  Json j = ReadJsonFile(registered / "scene.json");
  Camera camera = cap.lens;
  camera.c2w = cap.hero_c2w;
  j["camera"] = CameraToJson(camera);
  j["plane"]["xyz"] = ToJson(Eigen::Vector3d(0, 0, 0));
  j["plane"]["normal"] = ToJson(Eigen::Vector3d(0, 0, 1));
  j["plane"]["scale"] = ToJson(Eigen::Vector3d(cap.spec.plane_half, cap.spec.plane_half, 1));
  // box.obj is the box turned as it stands, about its centre.
  Eigen::Matrix4d o2w = Eigen::Matrix4d::Identity();
  o2w.topRightCorner<3, 1>() = cap.scene.objects[0].o2w.topRightCorner<3, 1>();
  j["objects"][0]["o2w"] = ToJson(o2w);
  j["objects"][0].erase("path_to_sph");
  WriteJsonFile(dir / "scene.json", j);
}

TEST(RunCaptureColmap, SyntheticCaptureEndToEndAndResume) {
  if (!FindExecutable("colmap")) GTEST_SKIP() << "colmap is not on PATH";
  // SHADOWSG_COLMAP_TEST_DIR keeps the capture folder there.
  const char* keep = std::getenv("SHADOWSG_COLMAP_TEST_DIR");
  TempDir scratch;
  const fs::path tmp = keep ? fs::path(keep) / "run" : scratch.path();
  fs::remove_all(tmp);
  fs::create_directories(tmp);
  StageContext ctx;
  ctx.threads = 2;
  ctx.seed = 1;
  // The per-stage lines on stdout, the stages' own chatter dropped.
  ctx.log = [](const std::string& line) {
    if (!line.empty() && line[0] == '[') std::printf("  %s\n", line.c_str());
  };
  const Stopwatch total;

  // ---- The capture folder ---------------------------------------------------------
  testing::MultiviewSpec spec;
  // Less texture than the plane test's (SIFT still registers every view): the
  // solver's uniform albedo then fits the plane better, and the PSNR says more
  // about the registration than about the texture (21 dB against 15 at 1.0).
  spec.noise = 0.4;
  const testing::MultiviewCapture cap = testing::MakeMultiviewCapture(spec, 20);
  Json doc = testing::WriteCaptureFolder(cap, tmp);
  // A small ball to insert beside the box (registered world: plane z = 0).
  WriteObj(tmp / "ball.obj", MakeIcosphere(0.06, 2));
  Eigen::Matrix4d ball = Eigen::Matrix4d::Identity();
  ball.topRightCorner<3, 1>() = Eigen::Vector3d(0.3, -0.2, 0.06);
  const Json ball_entry = {{"path_to_mesh", "ball.obj"}, {"o2w", ToJson(ball)}, {"diffuse", {0.7, 0.7, 0.7}}};
  WriteJsonFile(tmp / "virtual.json", Json{{"format", "objects/1"}, {"objects", Json::array({ball_entry})}});
  doc["solve"] = {{"method", "sg"}, {"budget", "fast"}};
  doc["composite"] = {{"objects", "virtual.json"}, {"quality", "final"}, {"spp", 8}, {"bounces", 1}};
  WriteJsonFile(tmp / "capture.json", doc);
  const double render_seconds = total.Seconds();

  // ---- First run: every stage -----------------------------------------------------
  RunCaptureOptions o;
  o.capture = tmp;
  const Stopwatch first_clock;
  const RunCaptureResult first = RunCapture(o, ctx);
  const double first_seconds = first_clock.Seconds();
  const std::set<std::string> all(RunStageNames().begin(), RunStageNames().end());
  EXPECT_EQ(StagesWithStatus(first, "ran"), all);
  std::fputs(FormatRunSummary(first).c_str(), stdout);
  // Every artifact the summary lists is there (the COLMAP workspace is a folder).
  const Json summary = ReadJsonFile(first.summary_json);
  ASSERT_EQ(summary["stages"].size(), all.size());
  for (const auto& s : summary["stages"])
    for (const auto& [what, path] : s["artifacts"].items())
      EXPECT_TRUE(fs::exists(path.get<std::string>())) << s["stage"] << " " << what << ": " << path;

  // ---- Lighting quality against the true scene ------------------------------------
  const fs::path out = tmp / "shadowsg";
  WriteTrueScene(out / "scene", tmp / "true_scene", cap);
  SolveOptions so;
  so.method = "sg";
  so.budget = "fast";
  StageContext quiet = ctx;
  quiet.quiet = true;
  const Stopwatch true_clock;
  RunSolve(tmp / "true_scene", tmp / "true_solve", so, quiet);
  const double true_seconds = true_clock.Seconds();
  const double psnr_run = Psnr(out / "solve"), psnr_true = Psnr(tmp / "true_solve");
  std::printf("hero re-render PSNR: run %.2f dB, true scene %.2f dB (difference %.2f dB); render %.1f s, run %.1f s "
              "(plane %.1f s, solve %.1f s), true-scene solve %.1f s\n",
              psnr_run, psnr_true, psnr_run - psnr_true, render_seconds, first_seconds,
              first.Stage("plane").seconds, first.Stage("solve").seconds, true_seconds);
  RecordProperty("psnr_run_db", std::to_string(psnr_run));
  RecordProperty("psnr_true_scene_db", std::to_string(psnr_true));
  EXPECT_GT(psnr_run, psnr_true - 1.0);

  // ---- Resume: nothing to do ---------------------------------------------------------
  const Stopwatch second_clock;
  const RunCaptureResult second = RunCapture(o, ctx);
  const double second_seconds = second_clock.Seconds();
  EXPECT_EQ(StagesWithStatus(second, "skipped"), all);

  // ---- A new linear hero photo: linearize and what follows it ---------------------------
  fs::last_write_time(tmp / "hero.exr", fs::file_time_type::clock::now());
  const RunCaptureResult third = RunCapture(o, ctx);
  EXPECT_EQ(StagesWithStatus(third, "ran"),
            (std::set<std::string>{"linearize", "register", "solve", "composite"}));
  EXPECT_EQ(StagesWithStatus(third, "skipped"), (std::set<std::string>{"intrinsics", "plane", "pose"}));

  // ---- --force composite: that stage alone ------------------------------------------------
  o.force = {"composite"};
  const RunCaptureResult fourth = RunCapture(o, ctx);
  EXPECT_EQ(StagesWithStatus(fourth, "ran"), std::set<std::string>{"composite"});
  o.force.clear();

  // ---- A changed setting in capture.json: only its stage ------------------------------------
  doc["composite"]["spp"] = 4;
  WriteJsonFile(tmp / "capture.json", doc);
  const RunCaptureResult fifth = RunCapture(o, ctx);
  EXPECT_EQ(StagesWithStatus(fifth, "ran"), std::set<std::string>{"composite"});
  EXPECT_EQ(fifth.Stage("composite").reason, "settings changed (composite)");
  std::printf("second run (all skipped) %.2f s; after touching hero.exr %.1f s; total %.1f s\n", second_seconds,
              third.seconds, total.Seconds());
}

// ---- Interrupted and resumed (the real binary, no COLMAP) -------------------------

// Every file under `dir` (relative name -> bytes), leaving out the folders
// and files named in `skip` (first path component).
std::map<std::string, std::string> Snapshot(const fs::path& dir, const std::set<std::string>& skip) {
  std::map<std::string, std::string> m;
  for (const auto& e : fs::recursive_directory_iterator(dir)) {
    const fs::path rel = fs::relative(e.path(), dir);
    if (skip.count(rel.begin()->string()) || !e.is_regular_file()) continue;
    m[rel.generic_string()] = testing::ReadWholeFile(e.path());
  }
  return m;
}

// The files of `before` that `after` lacks or holds with other bytes ("" when
// none). New files are allowed: solve caches the caster's sphere tree beside
// its mesh in scene/geometry.
std::string ChangedOrRemoved(const std::map<std::string, std::string>& before,
                             const std::map<std::string, std::string>& after) {
  std::string out;
  for (const auto& [name, bytes] : before)
    if (!after.count(name)) out += name + " (removed)\n";
    else if (after.at(name) != bytes) out += name + " (changed)\n";
  return out;
}

std::vector<fs::path> TemporariesUnder(const fs::path& dir) {
  std::vector<fs::path> out;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.path().filename().string().find(".tmp") != std::string::npos) out.push_back(e.path());
  return out;
}

// The sparse model COLMAP would give, from the capture's true cameras, and
// points on the plane and on the box (already metric, in the true world).
ColmapModel TrueColmapModel(const testing::MultiviewCapture& cap) {
  ColmapModel model;
  ColmapCamera camera = CameraToColmapCamera(cap.lens);
  camera.id = 1;
  model.cameras[1] = camera;
  auto add_image = [&](const std::string& name, const Eigen::Matrix4d& c2w) {
    ColmapImage im;
    im.id = static_cast<colmap_image_t>(model.images.size() + 1);
    im.camera_id = 1;
    im.name = name;
    im.pose = C2wToColmapPose(c2w);
    model.images[im.id] = im;
  };
  for (size_t i = 0; i < cap.ring.size(); ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "view_%02zu.png", i);
    add_image(name, cap.ring[i]);
  }
  add_image("hero.png", cap.hero_c2w);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> uni(-1, 1);
  std::normal_distribution<double> gauss(0, 1);
  const double half = 0.9 * cap.spec.plane_half;
  const Eigen::Vector3d& box = cap.spec.box_half;
  uint64_t id = 1;
  auto add_point = [&](const Eigen::Vector3d& x) {
    ColmapPoint3D p;
    p.id = id++;
    p.xyz = x;
    model.points.push_back(p);
  };
  for (int i = 0; i < 400; ++i) {
    const Eigen::Vector3d x(half * uni(rng), half * uni(rng), 0.001 * gauss(rng));
    if (std::abs(x.x()) > box.x() || std::abs(x.y()) > box.y()) add_point(x);
  }
  for (int i = 0; i < 60; ++i) add_point({box.x() * uni(rng), box.y() * uni(rng), box.z() * (1 + uni(rng))});
  return model;
}

// RunCapture's lines on stderr about `stage` ("[i/7] stage: ..."), one per line.
std::string StageLine(const std::string& err, const std::string& stage) {
  std::istringstream in(err);
  std::string line, lines;
  while (std::getline(in, line))
    if (!line.empty() && line[0] == '[' && line.find("] " + stage + ": ") != std::string::npos) lines += line + "\n";
  return lines;
}

TEST(RunCaptureResume, InterruptedRunResumesWhereItStopped) {
  TempDir tmp;
  const fs::path capture = tmp / "capture";
  const Stopwatch total;

  // The synthetic capture folder of the COLMAP test (fewer ring views and one
  // checkerboard photo: neither COLMAP nor the intrinsics stage runs here).
  const testing::MultiviewCapture cap = testing::MakeMultiviewCapture(testing::MultiviewSpec(), 8);
  testing::CaptureFolderOptions folder;
  folder.board_views = 1;
  Json doc = testing::WriteCaptureFolder(cap, capture, folder);
  CameraFile camera_file;
  camera_file.camera = cap.lens;
  WriteJsonFile(capture / "camera.json", CameraFileToJson(camera_file));
  WriteColmapModel(capture / "sparse", TrueColmapModel(cap), ColmapFormat::kText);
  doc["intrinsics"] = {{"camera", "camera.json"}};
  doc["walkaround"] = {{"images", "images"}, {"colmap_model", "sparse"}};
  WriteObj(capture / "ball.obj", MakeIcosphere(0.06, 2));
  Eigen::Matrix4d ball = Eigen::Matrix4d::Identity();
  ball.topRightCorner<3, 1>() = Eigen::Vector3d(0.3, -0.2, 0.06);
  WriteJsonFile(capture / "virtual.json",
                Json{{"format", "objects/1"},
                     {"objects", Json::array({{{"path_to_mesh", "ball.obj"}, {"o2w", ToJson(ball)},
                                               {"diffuse", {0.7, 0.7, 0.7}}}})}});
  doc["solve"] = {{"method", "sg"}, {"budget", "fast"}};
  doc["composite"] = {{"objects", "virtual.json"}, {"quality", "preview"}, {"spp", 4}, {"bounces", 1}};
  WriteJsonFile(capture / "capture.json", doc);
  const double setup_seconds = total.Seconds();

  const fs::path out = capture / "shadowsg", logs = tmp / "logs";
  fs::create_directories(logs);
  const std::vector<std::string> args = {"run", capture.string(), "--threads", "2", "--seed", "1"};

  // ---- First run, interrupted once solve is under way ------------------------------
  std::map<std::string, std::string> before;
  testing::CliRun interrupted;
  {
    const fs::path log_dir = logs / "first";
    fs::create_directories(log_dir);
    testing::CliProcess p(args, log_dir);
    // Its stderr (the only cli_err_* file in log_dir) says when solve starts.
    auto err_so_far = [&] {
      for (const auto& e : fs::directory_iterator(log_dir))
        if (e.path().filename().string().rfind("cli_err_", 0) == 0) return testing::ReadWholeFile(e.path());
      return std::string();
    };
    bool solving = false;
    while (p.Elapsed() < 300 && !solving) {
      siginfo_t ended{};  // WNOWAIT: left for Wait() to collect
      if (waitid(P_PID, p.pid(), &ended, WEXITED | WNOHANG | WNOWAIT) == 0 && ended.si_pid == p.pid()) {
        ADD_FAILURE() << "shadowsg run ended before solve started: " << p.Wait(10).Describe();
        return;
      }
      solving = err_so_far().find("] solve: running") != std::string::npos;
      if (!solving) std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    ASSERT_TRUE(solving) << "solve did not start:\n" << err_so_far();
    // What the finished stages wrote (solve's and composite's folders aside).
    before = Snapshot(out, {"solve", "composite", "run_summary.json"});
    p.Signal(SIGINT);
    interrupted = p.Wait(120);
  }
  const double interrupted_seconds = interrupted.seconds;
  ASSERT_TRUE(interrupted.exited && !interrupted.timed_out) << interrupted.Describe();
  EXPECT_EQ(interrupted.code, 130) << interrupted.Describe();
  EXPECT_NE(interrupted.err.find("interrupted"), std::string::npos) << interrupted.err;
  EXPECT_EQ(StageLine(interrupted.err, "solve"), "[6/7] solve: running (not run before)\n") << interrupted.err;
  EXPECT_EQ(StageLine(interrupted.err, "composite"), "") << interrupted.err;
  for (const char* stage : {"linearize", "plane", "pose", "register"}) {
    EXPECT_NE(StageLine(interrupted.err, stage).find("done in"), std::string::npos) << stage << "\n" << interrupted.err;
    EXPECT_TRUE(before.count(std::string("stamps/") + stage + ".json")) << stage;
  }
  for (const char* f : {"linear.exr", "plane.json", "pose.json", "scene/scene.json", "scene/image.exr"})
    EXPECT_TRUE(before.count(f)) << f;
  // The finished stages' outputs and stamps are untouched; the interrupted
  // stage left no stamp (and the one after it never started); no temporaries.
  EXPECT_EQ(ChangedOrRemoved(before, Snapshot(out, {"solve", "composite", "run_summary.json"})), "");
  EXPECT_FALSE(fs::exists(out / "stamps" / "solve.json"));
  EXPECT_FALSE(fs::exists(out / "stamps" / "composite.json"));
  EXPECT_FALSE(fs::exists(out / "composite" / "composite.exr"));
  EXPECT_EQ(TemporariesUnder(out), std::vector<fs::path>{});

  // ---- Resume: the finished stages are skipped, solve and composite run -------------
  const fs::path log_dir = logs / "second";
  fs::create_directories(log_dir);
  const testing::CliRun resumed = testing::RunCli(args, log_dir, 300);
  ASSERT_TRUE(resumed.exited && resumed.code == 0) << resumed.Describe();
  EXPECT_NE(StageLine(resumed.err, "intrinsics").find("given"), std::string::npos) << resumed.err;
  for (const char* stage : {"linearize", "plane", "pose", "register"})
    EXPECT_NE(StageLine(resumed.err, stage).find("up to date, skipped"), std::string::npos)
        << stage << "\n" << resumed.err;
  EXPECT_NE(StageLine(resumed.err, "solve").find("running (not run before)"), std::string::npos) << resumed.err;
  EXPECT_NE(StageLine(resumed.err, "composite").find("running (not run before)"), std::string::npos)
      << resumed.err;
  const Json summary = ReadJsonFile(out / "run_summary.json");
  std::map<std::string, std::string> status;
  for (const auto& st : summary["stages"]) status[st["stage"].get<std::string>()] = st["status"].get<std::string>();
  EXPECT_EQ(status, (std::map<std::string, std::string>{{"intrinsics", "given"},
                                                        {"linearize", "skipped"},
                                                        {"plane", "skipped"},
                                                        {"pose", "skipped"},
                                                        {"register", "skipped"},
                                                        {"solve", "ran"},
                                                        {"composite", "ran"}}));
  for (const auto& st : summary["stages"]) {
    if (st["stage"] != "solve" && st["stage"] != "composite") continue;
    for (const auto& [what, path] : st["artifacts"].items())
      EXPECT_TRUE(fs::is_regular_file(path.get<std::string>())) << st["stage"] << " " << what << ": " << path;
  }
  EXPECT_TRUE(fs::exists(out / "stamps" / "solve.json"));
  EXPECT_TRUE(fs::exists(out / "stamps" / "composite.json"));
  // Skipping rewrote nothing.
  EXPECT_EQ(ChangedOrRemoved(before, Snapshot(out, {"solve", "composite", "run_summary.json"})), "");
  EXPECT_EQ(TemporariesUnder(out), std::vector<fs::path>{});
  std::printf("setup %.1f s; interrupted run %.1f s; resumed run %.1f s (solve %.1f s, composite %.1f s)\n",
              setup_seconds, interrupted_seconds, resumed.seconds,
              summary["stages"][5]["seconds"].get<double>(), summary["stages"][6]["seconds"].get<double>());
}

}  // namespace
}  // namespace shadowsg
