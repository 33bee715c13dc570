// Runs the real `shadowsg` binary from tests: a child process with its own
// stdout/stderr files, a wall-clock limit, and optional signals sent after a
// delay (interrupt tests). The path comes from CMake (SHADOWSG_BINARY).
#pragma once

#include <signal.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <utility>
#include <vector>

namespace shadowsg::testing {

// A tiny synth/1 scene for tests that run the binary: 32x24, a sun and a
// sky lobe, an icosphere resting on the plane (its shadow in view).
inline constexpr const char* kTinySceneSpec = R"({
  "format": "synth/1",
  "camera": {"width": 32, "height": 24, "fov_deg": 50,
             "look_from": [0.4, -2.0, 1.3], "look_at": [0, 0, 0.2]},
  "plane": {"xyz": [0, 0, 0], "normal": [0, 0, 1], "scale": [4, 4, 1], "diffuse": [0.8, 0.8, 0.8]},
  "objects": [{"mesh": {"primitive": "icosphere", "radius": 0.3, "subdivisions": 1},
               "position": [0, 0, 0], "rest_on_plane": true}],
  "lights": {"suns": [{"direction": [0.4, 0.2, 0.9], "irradiance": [3, 3, 2.5]}],
             "lobes": [{"axis": [0, 0, 1], "sharpness": 2, "amplitude": [0.2, 0.3, 0.5]}]},
  "render": {"spp": 2, "bounces": 1, "seed": 3},
  "env_gt_height": 8
})";

struct CliRun {
  bool started = false;
  bool exited = false;   // normal exit (then `code`)
  int code = -1;
  int signal = 0;        // killed by this signal
  bool timed_out = false;
  double seconds = 0;
  std::string out, err;

  std::vector<std::string> ErrLines() const {
    std::vector<std::string> lines;
    std::istringstream in(err);
    std::string l;
    while (std::getline(in, l))
      if (!l.empty()) lines.push_back(l);
    return lines;
  }
  std::string Describe() const {
    std::ostringstream s;
    s << (timed_out ? "timed out; " : "") << (exited ? "exit " + std::to_string(code) : "signal " + std::to_string(signal))
      << " after " << seconds << " s\n--- stderr ---\n" << err << "--- stdout ---\n" << out;
    return s.str();
  }
};

inline std::string ReadWholeFile(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// A started child; Wait() collects it.
class CliProcess {
 public:
  CliProcess(const std::vector<std::string>& args, const std::filesystem::path& log_dir) {
    static int counter = 0;
    const std::string tag = std::to_string(getpid()) + "_" + std::to_string(counter++);
    out_path_ = log_dir / ("cli_out_" + tag + ".txt");
    err_path_ = log_dir / ("cli_err_" + tag + ".txt");
    std::vector<std::string> argv_s;
    argv_s.push_back(SHADOWSG_BINARY);
    argv_s.insert(argv_s.end(), args.begin(), args.end());
    std::vector<char*> argv;
    for (auto& a : argv_s) argv.push_back(a.data());
    argv.push_back(nullptr);
    start_ = std::chrono::steady_clock::now();
    pid_ = fork();
    if (pid_ == 0) {
      if (!freopen(out_path_.c_str(), "w", stdout) || !freopen(err_path_.c_str(), "w", stderr)) _exit(126);
      setenv("ASAN_OPTIONS", "detect_leaks=0", 0);
      execv(argv[0], argv.data());
      _exit(127);
    }
  }
  ~CliProcess() {
    if (pid_ > 0 && !reaped_) {
      kill(pid_, SIGKILL);
      int st;
      waitpid(pid_, &st, 0);
    }
  }
  pid_t pid() const { return pid_; }
  void Signal(int sig) const {
    if (pid_ > 0 && !reaped_) kill(pid_, sig);
  }
  // Polls until the child ends or `timeout_s` passes (then SIGKILL).
  CliRun Wait(double timeout_s) {
    CliRun r;
    r.started = pid_ > 0;
    if (!r.started) return r;
    int status = 0;
    for (;;) {
      const pid_t w = waitpid(pid_, &status, WNOHANG);
      if (w == pid_) break;
      if (Elapsed() > timeout_s) {
        r.timed_out = true;
        kill(pid_, SIGKILL);
        waitpid(pid_, &status, 0);
        break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    reaped_ = true;
    r.seconds = Elapsed();
    if (WIFEXITED(status)) {
      r.exited = true;
      r.code = WEXITSTATUS(status);
    } else if (WIFSIGNALED(status)) {
      r.signal = WTERMSIG(status);
    }
    r.out = ReadWholeFile(out_path_);
    r.err = ReadWholeFile(err_path_);
    std::error_code ec;
    std::filesystem::remove(out_path_, ec);
    std::filesystem::remove(err_path_, ec);
    return r;
  }
  double Elapsed() const {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  }
  // Polls the child's stderr until it holds `text` (true) or the child ended
  // or `timeout_s` passed (false). A signal sent before the command is under
  // way tests the loader, not the command: under the sanitizers on a loaded
  // 2-core machine, reaching main() alone took over a second.
  bool WaitForStderr(const std::string& text, double timeout_s) const {
    while (Elapsed() < timeout_s) {
      if (ReadWholeFile(err_path_).find(text) != std::string::npos) return true;
      siginfo_t info{};
      if (waitid(P_PID, pid_, &info, WEXITED | WNOHANG | WNOWAIT) == 0 && info.si_pid == pid_) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return false;
  }

 private:
  pid_t pid_ = -1;
  bool reaped_ = false;
  std::string out_path_, err_path_;
  std::chrono::steady_clock::time_point start_;
};

inline CliRun RunCli(const std::vector<std::string>& args, const std::filesystem::path& log_dir,
                     double timeout_s = 60) {
  CliProcess p(args, log_dir);
  return p.Wait(timeout_s);
}

}  // namespace shadowsg::testing
