// `shadowsg export --lighting FILE --out PATH --format F`: the estimated
// lighting in the forms other tools read (README.md, "Compositing and
// export"). Every lat-long layout goes through calib/conventions.h
// (LatLongConvention) and solver/envmap.h (EnvMapToLatLong):
//   exr      PATH.exr (+ .png): our convention (scene-format.md), any height
//   openexr  PATH.exr (+ .png): OpenEXR / USD lat-long, y-up, tagged envmap = LATLONG
//   usd      PATH.usda: a y-up stage with a DomeLight on PATH's stem + .exr (openexr layout)
//   blender  PATH.py: a Blender script that makes the lighting the scene's world,
//            with PATH's stem + .exr in Blender's layout beside it
//   json     PATH.json: the SG lobes ("sg-lighting/1"; SG lighting only)
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include "calib/image.h"
#include "solver/lights.h"
#include "stages/stage_context.h"

namespace shadowsg {

struct ExportOptions {
  std::string format = "exr";  // exr | openexr | usd | blender | json
  // Map height H (width 2H); 0: the lighting's own map height, or
  // kEnvMapOutputHeight (256) for SG lobes and analytic lights.
  int height = 0;
  std::string Validate() const;
};

// The files written, main file first.
std::vector<std::filesystem::path> RunExport(const std::filesystem::path& lighting_file,
                                             const std::filesystem::path& out, const ExportOptions& options,
                                             const StageContext& ctx);

// The lighting as our map of height H (0: as ExportOptions::height says):
// SG lobes at texel centres, env maps area-averaged, suns rasterised with
// their power (solver/light_envmap.h).
Image ExportEnvMap(const LightSet& lights, int height);

// The Blender script's text for a map file (an absolute path is tried first,
// then the file name next to the script).
std::string BlenderWorldScript(const std::filesystem::path& map_file);

}  // namespace shadowsg
