#include "stages/colmap_runner.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <regex>
#include <sstream>

#include "calib/colmap_model.h"
#include "calib/error.h"
#include "stages/io/atomic_file.h"
#include "stages/stage_util.h"

extern char** environ;

namespace shadowsg {
namespace fs = std::filesystem;

namespace {

// Poll period of the output pipe, so that an interrupt is noticed promptly.
constexpr int kPollMs = 200;

// Share of the progress bar for each program (feature extraction, matching,
// mapping): rough shares of their run times on small captures.
constexpr double kExtractShare = 0.3, kMatchShare = 0.3;

std::string FormatDouble(double v) {
  std::ostringstream ss;
  ss.precision(17);
  ss << v;
  return ss.str();
}

// Ceres' per-iteration table rows ("  12  3.7e+01  1.4e-02 ...") and its
// header: thousands of lines that carry nothing for a user; they still go to
// colmap.log.
bool IsSolverTableLine(const std::string& line) {
  std::istringstream ss(line);
  std::string first, second;
  if (!(ss >> first)) return true;  // blank
  if (first == "iter") return true;
  if (!std::all_of(first.begin(), first.end(), [](unsigned char c) { return std::isdigit(c); })) return false;
  return (ss >> second) && second.find_first_of("eE") != std::string::npos;
}

}  // namespace

std::string ColmapRunOptions::Validate() const {
  if (executable.empty()) return "--colmap: the program name is empty";
  if (images.empty()) return "--images: the photo folder is required";
  if (workspace.empty()) return "--workspace: a folder for COLMAP's files is required";
  if (matcher != "exhaustive" && matcher != "sequential")
    return "--matcher: expected exhaustive or sequential, got \"" + matcher + "\"";
  if (!camera && ColmapModelParamCount(camera_model) < 0)
    return "--camera-model: unknown COLMAP camera model \"" + camera_model + "\"";
  if (max_image_size < 16) return "--max-image-size must be at least 16";
  if (max_features < 16) return "--max-features must be at least 16";
  if (threads < 1) return "threads must be at least 1";
  return "";
}

std::vector<std::vector<std::string>> ColmapCommands(const ColmapRunOptions& o) {
  const std::string db = (o.workspace / "database.db").string();
  const std::string threads = std::to_string(o.threads);
  const std::string seed = std::to_string(o.seed);
  std::vector<std::string> extract = {o.executable,
                                      "feature_extractor",
                                      "--random_seed", seed,
                                      "--database_path", db,
                                      "--image_path", o.images.string()};
  if (!o.image_names.empty()) {
    extract.push_back("--image_list_path");
    extract.push_back((o.workspace / "image_list.txt").string());
  }
  extract.insert(extract.end(), {"--ImageReader.single_camera", "1"});
  if (o.camera) {
    const ColmapCamera c = CameraToColmapCamera(*o.camera);
    std::string params;
    for (double p : c.params) params += (params.empty() ? "" : ",") + FormatDouble(p);
    extract.insert(extract.end(), {"--ImageReader.camera_model", c.model, "--ImageReader.camera_params", params});
  } else {
    extract.insert(extract.end(), {"--ImageReader.camera_model", o.camera_model});
  }
  extract.insert(extract.end(), {"--SiftExtraction.use_gpu", "0", "--SiftExtraction.num_threads", threads,
                                 "--SiftExtraction.max_image_size", std::to_string(o.max_image_size),
                                 "--SiftExtraction.max_num_features", std::to_string(o.max_features)});

  std::vector<std::string> match = {o.executable, o.matcher + "_matcher", "--random_seed", seed, "--database_path", db,
                                    "--SiftMatching.use_gpu", "0", "--SiftMatching.num_threads", threads};

  std::vector<std::string> map = {o.executable,    "mapper",
                                  "--random_seed", seed,
                                  "--database_path", db,
                                  "--image_path",  o.images.string(),
                                  "--output_path", (o.workspace / "sparse").string(),
                                  "--Mapper.num_threads", threads};
  if (!o.image_names.empty()) {
    map.push_back("--image_list_path");
    map.push_back((o.workspace / "image_list.txt").string());
  }
  if (o.camera)  // calibrated: keep the intrinsics as given (the principal point is fixed by default)
    map.insert(map.end(), {"--Mapper.ba_refine_focal_length", "0", "--Mapper.ba_refine_principal_point", "0",
                           "--Mapper.ba_refine_extra_params", "0"});
  return {extract, match, map};
}

std::optional<fs::path> FindExecutable(const std::string& name) {
  if (name.empty()) return std::nullopt;
  if (name.find('/') != std::string::npos) {
    if (access(name.c_str(), X_OK) == 0) return fs::path(name);
    return std::nullopt;
  }
  const char* path = std::getenv("PATH");
  std::istringstream dirs(path ? path : "");
  std::string dir;
  while (std::getline(dirs, dir, ':')) {
    if (dir.empty()) dir = ".";
    const fs::path candidate = fs::path(dir) / name;
    std::error_code ec;
    if (fs::is_regular_file(candidate, ec) && access(candidate.c_str(), X_OK) == 0) return candidate;
  }
  return std::nullopt;
}

int RunProcess(const std::vector<std::string>& argv, const std::vector<std::string>& extra_env,
               const std::function<void(const std::string& line)>& on_line) {
  SHADOWSG_CHECK(!argv.empty());
  int fds[2];
  if (pipe2(fds, O_CLOEXEC) != 0) throw std::runtime_error(std::string("pipe: ") + std::strerror(errno));

  // Environment: ours, with extra_env overriding same-named entries.
  std::vector<std::string> env_strings;
  auto name_of = [](const std::string& kv) { return kv.substr(0, kv.find('=')); };
  for (char** e = environ; e && *e; ++e) {
    const std::string kv(*e);
    const bool overridden = std::any_of(extra_env.begin(), extra_env.end(),
                                        [&](const std::string& x) { return name_of(x) == name_of(kv); });
    if (!overridden) env_strings.push_back(kv);
  }
  env_strings.insert(env_strings.end(), extra_env.begin(), extra_env.end());
  std::vector<char*> envp, args;
  for (auto& s : env_strings) envp.push_back(s.data());
  envp.push_back(nullptr);
  std::vector<std::string> argv_copy = argv;
  for (auto& s : argv_copy) args.push_back(s.data());
  args.push_back(nullptr);

  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_adddup2(&actions, fds[1], 1);
  posix_spawn_file_actions_adddup2(&actions, fds[1], 2);
  pid_t pid = 0;
  const int spawn_error = posix_spawnp(&pid, args[0], &actions, nullptr, args.data(), envp.data());
  posix_spawn_file_actions_destroy(&actions);
  close(fds[1]);
  if (spawn_error != 0) {
    close(fds[0]);
    throw InputError(argv[0], std::string("cannot start: ") + std::strerror(spawn_error));
  }

  std::string pending;
  char buf[4096];
  bool interrupted = false;
  auto flush_lines = [&](bool all) {
    size_t start = 0;
    for (size_t i = 0; i < pending.size(); ++i)
      if (pending[i] == '\n' || pending[i] == '\r') {
        if (i > start) on_line(pending.substr(start, i - start));
        start = i + 1;
      }
    pending.erase(0, start);
    if (all && !pending.empty()) {
      on_line(pending);
      pending.clear();
    }
  };
  for (;;) {
    pollfd p{fds[0], POLLIN, 0};
    const int ready = poll(&p, 1, kPollMs);
    if (InterruptRequested()) {
      interrupted = true;
      kill(pid, SIGTERM);
      break;
    }
    if (ready < 0) {
      if (errno == EINTR) continue;
      break;
    }
    if (ready == 0) continue;
    const ssize_t n = read(fds[0], buf, sizeof buf);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;  // EOF: the child closed its output
    pending.append(buf, static_cast<size_t>(n));
    flush_lines(false);
  }
  flush_lines(true);
  close(fds[0]);
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  if (interrupted) throw Interrupted();
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  if (WIFSIGNALED(status)) return 128 + WTERMSIG(status);
  return 1;
}

ColmapRunResult RunColmap(const ColmapRunOptions& o, const StageContext& ctx) {
  const std::string bad = o.Validate();
  if (!bad.empty()) throw InputError("colmap", bad);
  const std::optional<fs::path> exe = FindExecutable(o.executable);
  if (!exe)
    throw InputError(o.executable, o.executable.find('/') == std::string::npos
                                       ? "COLMAP not found on PATH (install Debian's colmap package, or reuse an "
                                         "existing sparse model with --colmap-model DIR)"
                                       : "COLMAP program not found or not executable");
  EnsureOutputDir(o.workspace);
  std::error_code ec;
  // A database from an earlier run would make COLMAP skip images and add matches.
  fs::remove(o.workspace / "database.db", ec);
  fs::remove(o.workspace / "database.db-shm", ec);
  fs::remove(o.workspace / "database.db-wal", ec);
  fs::remove_all(o.workspace / "sparse", ec);
  fs::create_directories(o.workspace / "sparse", ec);
  if (!o.image_names.empty()) {
    std::string list;
    for (const auto& n : o.image_names) list += n + "\n";
    WriteTextAtomically(o.workspace / "image_list.txt", list);
  }

  ColmapRunResult r;
  r.sparse_dir = o.workspace / "sparse";
  r.log = o.workspace / "colmap.log";
  std::ofstream log(r.log, std::ios::trunc);
  const ProgressFn progress = ctx.Progress("sfm");
  const Stopwatch watch;
  const std::vector<std::vector<std::string>> commands = ColmapCommands(o);
  const double share[3] = {kExtractShare, kMatchShare, 1.0 - kExtractShare - kMatchShare};
  const char* labels[3] = {"features", "matching", "mapping"};
  const std::regex processed(R"(Processed file \[(\d+)/(\d+)\])");
  const std::regex block(R"(Matching block \[(\d+)/(\d+), (\d+)/(\d+)\])");
  const std::regex image(R"(Matching image \[(\d+)/(\d+)\])");
  const std::regex registering(R"(Registering image #\d+ \((\d+)\))");
  double base = 0;
  int total_images = static_cast<int>(o.image_names.size());
  std::string last_line;
  for (int step = 0; step < 3; ++step) {
    std::vector<std::string> argv = commands[step];
    argv[0] = exe->string();
    std::string shown;
    for (const auto& a : commands[step]) shown += (shown.empty() ? "" : " ") + a;
    ctx.Log("colmap: $ " + shown);
    log << "$ " << shown << "\n";
    Report(progress, base, labels[step]);
    auto on_line = [&](const std::string& line) {
      log << line << "\n";
      if (line.find_first_not_of(" \t=") == std::string::npos) return;
      last_line = line;
      std::smatch m;
      double f = -1;
      if (std::regex_search(line, m, processed)) {
        total_images = std::stoi(m[2]);
        f = std::stod(m[1]) / std::stod(m[2]);
      } else if (std::regex_search(line, m, block)) {
        const double a = std::stod(m[1]) - 1, na = std::stod(m[2]), b = std::stod(m[3]), nb = std::stod(m[4]);
        f = (a * nb + b) / (na * nb);
      } else if (std::regex_search(line, m, image)) {
        f = std::stod(m[1]) / std::stod(m[2]);
      } else if (std::regex_search(line, m, registering) && total_images > 0) {
        f = std::min(1.0, std::stod(m[1]) / total_images);
      }
      if (f >= 0) Report(progress, base + share[step] * std::min(f, 1.0), labels[step]);
      if (!IsSolverTableLine(line)) ctx.Log("colmap: " + line);
    };
    const int status = RunProcess(argv, {"QT_QPA_PLATFORM=offscreen"}, on_line);
    log.flush();
    if (status != 0)
      throw InputError("colmap " + commands[step][1],
                       "failed with exit status " + std::to_string(status) +
                           (last_line.empty() ? "" : " (last output: \"" + last_line + "\")") + "; full log: " +
                           r.log.string());
    base += share[step];
  }
  Report(progress, 1.0, "done");
  r.seconds = watch.Seconds();
  return r;
}

}  // namespace shadowsg
