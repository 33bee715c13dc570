#include "stages/io/lighting_io.h"

#include <algorithm>
#include <cmath>

#include "calib/error.h"
#include "stages/io/image_io.h"

namespace shadowsg {
namespace fs = std::filesystem;

namespace {

// Beyond these a lobe is no lighting a camera recorded, and products of
// values overflow in the renderers (a 0.01-degree sun has sharpness ~3e7).
constexpr double kMaxSharpness = 1e9;
constexpr double kMaxRadiance = 1e12;

void CheckRadiance(const JsonReader& r, const std::string& key, const Eigen::Vector3d& v) {
  if ((v.array() < 0).any()) r.Fail(key, key + " must be non-negative");
  if (v.maxCoeff() > kMaxRadiance) r.Fail(key, key + " is unreasonably large (> 1e12)");
}

std::vector<SgLobe> ParseLobes(const JsonReader& doc) {
  std::vector<SgLobe> lobes;
  if (!doc.Has("lobes")) return lobes;
  const JsonReader arr = doc.Child("lobes");
  for (size_t i = 0; i < arr.Size(); ++i) {
    const JsonReader l = arr.Element(i);
    SgLobe lobe;
    lobe.axis = l.Vec3("axis");
    if (lobe.axis.norm() < 1e-9) l.Fail("axis", "axis is zero");
    lobe.axis.normalize();
    lobe.sharpness = l.Number("sharpness");
    if (lobe.sharpness <= 0) l.Fail("sharpness", "sharpness must be positive");
    if (lobe.sharpness > kMaxSharpness) l.Fail("sharpness", "sharpness is unreasonably large (> 1e9)");
    lobe.amplitude = l.Vec3("amplitude");
    CheckRadiance(l, "amplitude", lobe.amplitude);
    lobes.push_back(lobe);
  }
  return lobes;
}

}  // namespace

SgLighting ParseSgLighting(const JsonReader& doc) {
  const std::string format = doc.String("format", "sg-lighting/1");
  if (format != "sg-lighting/1") doc.Fail("format", "expected \"sg-lighting/1\", got \"" + format + "\"");
  SgLighting sg;
  if (doc.Has("up")) {
    sg.up = doc.Vec3("up");
    if (sg.up.norm() < 1e-9) doc.Fail("up", "up vector is zero");
    sg.up.normalize();
  }
  if (!doc.Has("lobes")) doc.Fail("lobes", "missing key");
  sg.lobes = ParseLobes(doc);
  return sg;
}

LightSet ParseLights(const JsonReader& doc, const fs::path& base_dir) {
  LightSet set;
  if (doc.Has("suns")) {
    const JsonReader suns = doc.Child("suns");
    for (size_t i = 0; i < suns.Size(); ++i) {
      const JsonReader s = suns.Element(i);
      SunLight sun;
      sun.direction = s.Vec3("direction");
      if (sun.direction.norm() < 1e-9) s.Fail("direction", "direction is zero");
      sun.direction.normalize();
      sun.irradiance = s.Vec3("irradiance");
      CheckRadiance(s, "irradiance", sun.irradiance);
      sun.angular_radius = s.Number("angular_radius_deg", 0) * M_PI / 180;
      if (sun.angular_radius < 0 || sun.angular_radius > M_PI / 4)
        s.Fail("angular_radius_deg", "expected 0 to 45 degrees");
      set.suns.push_back(sun);
    }
  }
  if (doc.Has("areas")) {
    const JsonReader areas = doc.Child("areas");
    for (size_t i = 0; i < areas.Size(); ++i) {
      const JsonReader a = areas.Element(i);
      AreaLight light;
      light.centre = a.Vec3("centre");
      light.half_u = a.Vec3("half_u");
      light.half_v = a.Vec3("half_v");
      light.radiance = a.Vec3("radiance");
      CheckRadiance(a, "radiance", light.radiance);
      if (light.half_u.cross(light.half_v).norm() < 1e-12) a.Fail("half_u", "area light has zero area");
      set.areas.push_back(light);
    }
  }
  if (doc.Has("env")) {
    Image env = ReadEnvMapExr(base_dir / doc.String("env"));
    const double scale = doc.Number("env_scale", 1.0);
    if (!(scale >= 0 && scale <= kMaxRadiance)) doc.Fail("env_scale", "expected a non-negative scale up to 1e12");
    const float s = static_cast<float>(scale);
    for (float& v : env.data) v *= s;
    set.env = std::move(env);
  }
  std::vector<SgLobe> lobes = ParseLobes(doc);
  if (!lobes.empty()) set.sg = SgLighting{Eigen::Vector3d::UnitZ(), lobes};
  return set;
}

LightSet ReadLighting(const fs::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), ::tolower);
  LightSet set;
  if (ext == ".exr") {
    Image env = ReadEnvMapExr(path, EnvMapSign::kSigned);
    set.env = std::move(env);
    return set;
  }
  const Json doc = ReadJsonFile(path);
  const JsonReader r(doc, path.string());
  const std::string format = r.String("format", "sg-lighting/1");
  if (format == "sg-lighting/1") set.sg = ParseSgLighting(r);
  else if (format == "lights/1") set = ParseLights(r, path.parent_path());
  else r.Fail("format", "unknown lighting format \"" + format + "\" (expected sg-lighting/1 or lights/1)");
  if (set.empty() || (set.sg && set.sg->lobes.empty() && !set.env && set.suns.empty() && set.areas.empty()))
    throw InputError(path.string(), "lighting file holds no light (no lobes, suns, areas or env map)");
  return set;
}

Json SgLightingToJson(const SgLighting& lighting) {
  Json j{{"format", "sg-lighting/1"}, {"up", ToJson(lighting.up)}, {"lobes", Json::array()}};
  for (const auto& l : lighting.lobes)
    j["lobes"].push_back(
        Json{{"axis", ToJson(l.axis)}, {"sharpness", l.sharpness}, {"amplitude", ToJson(l.amplitude)}});
  return j;
}

Json LightsToJson(const LightSet& lights, const std::string& env_file) {
  Json j{{"format", "lights/1"}};
  if (!lights.suns.empty()) {
    j["suns"] = Json::array();
    for (const auto& s : lights.suns)
      j["suns"].push_back(Json{{"direction", ToJson(s.direction)},
                               {"irradiance", ToJson(s.irradiance)},
                               {"angular_radius_deg", s.angular_radius * 180 / M_PI}});
  }
  if (!lights.areas.empty()) {
    j["areas"] = Json::array();
    for (const auto& a : lights.areas)
      j["areas"].push_back(Json{{"centre", ToJson(a.centre)},
                                {"half_u", ToJson(a.half_u)},
                                {"half_v", ToJson(a.half_v)},
                                {"radiance", ToJson(a.radiance)}});
  }
  if (lights.env && !env_file.empty()) j["env"] = env_file;
  if (lights.sg) j["lobes"] = SgLightingToJson(*lights.sg)["lobes"];
  return j;
}

void WriteSgLighting(const fs::path& path, const SgLighting& lighting) {
  WriteJsonFile(path, SgLightingToJson(lighting));
}

}  // namespace shadowsg
