#include "pipeline/sample_data.h"

#include <cstdlib>
#include <vector>

#include "calib/error.h"

namespace shadowsg {
namespace fs = std::filesystem;

fs::path FindSampleSpec() {
  std::vector<fs::path> candidates;
  if (const char* env = std::getenv("SHADOWSG_DATA_DIR")) candidates.push_back(fs::path(env) / "sample");
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec)
    for (fs::path dir = exe.parent_path(); !dir.empty() && dir != dir.root_path(); dir = dir.parent_path()) {
      candidates.push_back(dir / "data" / "sample");
      candidates.push_back(dir / "share" / "shadowsg" / "sample");
    }
#ifdef SHADOWSG_SOURCE_DIR
  candidates.push_back(fs::path(SHADOWSG_SOURCE_DIR) / "data" / "sample");
#endif
  for (const auto& c : candidates)
    if (fs::is_regular_file(c / "sample.json", ec)) return c / "sample.json";
  throw InputError("data/sample/sample.json",
                   "sample scene not found (set SHADOWSG_DATA_DIR to the repository's data/ folder)");
}

}  // namespace shadowsg
