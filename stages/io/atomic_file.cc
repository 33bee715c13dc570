#include "stages/io/atomic_file.h"

#include <unistd.h>

#include <atomic>
#include <csignal>
#include <cstring>
#include <fstream>
#include <mutex>
#include <set>

#include "calib/error.h"

namespace shadowsg {
namespace {

std::atomic<bool> g_interrupted{false};
std::mutex g_mutex;
// Fixed-size table readable from a signal handler without allocation.
constexpr int kMaxPending = 64;
char g_pending[kMaxPending][4096];
std::atomic<bool> g_used[kMaxPending];

int Register(const std::string& tmp) {
  std::lock_guard<std::mutex> lock(g_mutex);
  for (int i = 0; i < kMaxPending; ++i)
    if (!g_used[i]) {
      std::strncpy(g_pending[i], tmp.c_str(), sizeof(g_pending[i]) - 1);
      g_pending[i][sizeof(g_pending[i]) - 1] = 0;
      g_used[i] = true;
      return i;
    }
  return -1;
}

void Unregister(int slot) {
  if (slot >= 0) g_used[slot] = false;
}

extern "C" void OnSignal(int sig) {
  for (int i = 0; i < kMaxPending; ++i)
    if (g_used[i]) unlink(g_pending[i]);
  if (g_interrupted.exchange(true)) _exit(128 + sig);
  static const char msg[] = "\ninterrupted: finishing cleanly (press again to abort)\n";
  ssize_t ignored = write(2, msg, sizeof(msg) - 1);
  (void)ignored;
}

}  // namespace

void WriteAtomically(const std::filesystem::path& path,
                     const std::function<void(const std::filesystem::path& tmp)>& write) {
  namespace fs = std::filesystem;
  if (path.has_parent_path()) fs::create_directories(path.parent_path());
  const fs::path tmp = path.parent_path() /
                       (path.stem().string() + ".tmp" + std::to_string(getpid()) + path.extension().string());
  const int slot = Register(tmp.string());
  try {
    write(tmp);
    ThrowIfInterrupted();
    fs::rename(tmp, path);
  } catch (...) {
    std::error_code ec;
    fs::remove(tmp, ec);
    Unregister(slot);
    throw;
  }
  Unregister(slot);
}

void WriteTextAtomically(const std::filesystem::path& path, const std::string& text) {
  WriteAtomically(path, [&](const std::filesystem::path& tmp) {
    std::ofstream out(tmp, std::ios::binary);
    out << text;
    out.close();
    if (!out) throw InputError(path.string(), "cannot write file");
  });
}

void InstallInterruptHandlers() {
  struct sigaction sa {};
  sa.sa_handler = OnSignal;
  sigemptyset(&sa.sa_mask);
  sigaction(SIGINT, &sa, nullptr);
  sigaction(SIGTERM, &sa, nullptr);
}

bool InterruptRequested() { return g_interrupted.load(std::memory_order_relaxed); }

void ThrowIfInterrupted() {
  if (InterruptRequested()) throw Interrupted();
}

}  // namespace shadowsg
