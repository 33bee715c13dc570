// Lighting files. `lighting.json` ("format": "sg-lighting/1", scene-format.md)
// holds SG lobes; an `.exr` is an equirectangular radiance map; a
// "lights/1" JSON describes analytic suns and area lights for synthesis:
//   {"format": "lights/1",
//    "suns":  [{"direction": [x,y,z], "irradiance": [r,g,b], "angular_radius_deg": 0.5}],
//    "areas": [{"centre": [..], "half_u": [..], "half_v": [..], "radiance": [r,g,b]}],
//    "env": "map.exr", "env_scale": 1.0, "lobes": [ ...SG lobes... ]}
#pragma once

#include <filesystem>

#include "solver/lights.h"
#include "solver/sg.h"
#include "stages/io/json_util.h"

namespace shadowsg {

LightSet ReadLighting(const std::filesystem::path& path);
SgLighting ParseSgLighting(const JsonReader& doc);
LightSet ParseLights(const JsonReader& doc, const std::filesystem::path& base_dir);
Json SgLightingToJson(const SgLighting& lighting);
// A LightSet as "lights/1" (inverse of ParseLights); the env map, if any, is
// referred to as `env_file` (relative to the JSON), which the caller writes.
Json LightsToJson(const LightSet& lights, const std::string& env_file = "");
void WriteSgLighting(const std::filesystem::path& path, const SgLighting& lighting);

}  // namespace shadowsg
