#include "stages/stage_util.h"

#include "calib/error.h"

namespace shadowsg {

void EnsureOutputDir(const std::filesystem::path& dir) {
  std::error_code ec;
  if (std::filesystem::exists(dir, ec) && !std::filesystem::is_directory(dir, ec))
    throw InputError(dir.string(), "output path exists and is not a folder");
  std::filesystem::create_directories(dir, ec);
  if (ec) throw InputError(dir.string(), "cannot create output folder: " + ec.message());
}

}  // namespace shadowsg
