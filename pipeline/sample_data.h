// The bundled sample scene (data/sample: Spot the cow, CC0), used by `demo`
// and `bench --quick`.
#pragma once

#include <filesystem>

namespace shadowsg {

// data/sample/sample.json: $SHADOWSG_DATA_DIR/sample, then beside the binary
// (build/ or build/pipeline/ under the source tree, or an install's share/),
// then the source tree the binary was built from. InputError when none has it.
std::filesystem::path FindSampleSpec();

}  // namespace shadowsg
