// Atomic output: every file the tool writes goes to a temporary name in the
// same folder and is renamed over the target only when complete, so an
// interrupted or failed run never leaves a half-written file where a good one
// was. Temporaries still open when a signal arrives are removed.
#pragma once

#include <filesystem>
#include <functional>
#include <string>

namespace shadowsg {

// Calls write(tmp) with a temporary path next to `path` that keeps its
// extension, then renames tmp to path. On any exception the temporary is
// removed and the exception propagates; `path` is untouched.
void WriteAtomically(const std::filesystem::path& path,
                     const std::function<void(const std::filesystem::path& tmp)>& write);
void WriteTextAtomically(const std::filesystem::path& path, const std::string& text);

// Installs SIGINT/SIGTERM handlers that remove pending temporaries, set the
// interrupt flag and, on a second signal, exit at once.
void InstallInterruptHandlers();
bool InterruptRequested();
// Throws Interrupted when a signal has arrived; long loops call it.
void ThrowIfInterrupted();

}  // namespace shadowsg
