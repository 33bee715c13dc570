#include "stages/bench/perturbations.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

#include "calib/error.h"
#include "solver/plane_pixels.h"
#include "solver/sampling.h"
#include "solver/sphere_tree_build.h"
#include "stages/bench/runner.h"
#include "stages/eval_stage.h"
#include "stages/io/atomic_file.h"
#include "stages/io/image_io.h"
#include "stages/io/scene_io.h"
#include "stages/io/sph_io.h"
#include "stages/sphere_tree_stage.h"

namespace shadowsg {
namespace fs = std::filesystem;

namespace {

std::string Trim(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%g", v);
  return buf;
}

Perturbation Make(const std::string& family, double size, const std::string& unit, const std::string& label,
                  bool image_only, bool affects_baselines = true) {
  Perturbation p;
  p.family = family;
  p.size = size;
  p.unit = unit;
  // "noise-2", "rotation-3"; albedo errors are signed: "albedo+10", "albedo-10".
  if (unit.empty()) p.name = family;
  else if (family == "albedo") p.name = family + (size > 0 ? "+" : "") + Trim(size);
  else p.name = family + "-" + Trim(size);
  p.label = label;
  p.image_only = image_only;
  p.affects_baselines = affects_baselines;
  return p;
}

// FNV-1a of the perturbation's name, mixed with the seed: the key of its draws.
uint64_t DrawKey(uint64_t seed, const std::string& name) {
  uint64_t h = 1469598103934665603ull;
  for (unsigned char c : name) h = (h ^ c) * 1099511628211ull;
  return Mix64(seed ^ h);
}

// A standard normal variate from two uniforms (Box-Muller).
double Gaussian(RandomStream& rng) {
  const double u1 = std::max(rng.Uniform(), 1e-300);
  const double u2 = rng.Uniform();
  return std::sqrt(-2 * std::log(u1)) * std::cos(2 * M_PI * u2);
}

Eigen::Vector3d RandomUnit(RandomStream& rng) {
  const double z = 2 * rng.Uniform() - 1;
  const double phi = 2 * M_PI * rng.Uniform();
  const double r = std::sqrt(std::max(0.0, 1 - z * z));
  return {r * std::cos(phi), r * std::sin(phi), z};
}

// Copies every file of `from` into `to` (folders created writable: the
// source may be read-only), except scene.json, which the caller writes.
void CopySceneFiles(const fs::path& from, const fs::path& to) {
  std::error_code ec;
  fs::create_directories(to, ec);
  if (ec) throw InputError(to.string(), "cannot create folder: " + ec.message());
  for (auto it = fs::recursive_directory_iterator(from, ec); !ec && it != fs::recursive_directory_iterator();
       it.increment(ec)) {
    const fs::path rel = fs::relative(it->path(), from);
    if (rel == "scene.json") continue;
    const fs::path target = to / rel;
    if (it->is_directory()) {
      fs::create_directories(target, ec);
    } else if (it->is_regular_file()) {
      fs::remove(target, ec);
      fs::copy_file(it->path(), target, fs::copy_options::overwrite_existing, ec);
      if (!ec) fs::permissions(target, fs::perms::owner_write, fs::perm_options::add, ec);
    }
    if (ec) throw InputError(target.string(), "cannot copy " + it->path().string() + ": " + ec.message());
  }
  if (ec) throw InputError(from.string(), "cannot read scene folder: " + ec.message());
}

// Bounding box of the casters in world coordinates.
void CasterBounds(const Scene& scene, Eigen::Vector3d* lo, Eigen::Vector3d* hi) {
  *lo = Eigen::Vector3d::Constant(INFINITY);
  *hi = Eigen::Vector3d::Constant(-INFINITY);
  for (const SceneObject* o : scene.Casters()) {
    Eigen::Vector3d a, b;
    MeshBounds(o->WorldMesh(), &a, &b);
    *lo = lo->cwiseMin(a);
    *hi = hi->cwiseMax(b);
  }
}

double PlaneMax(const Scene& scene, const PlanePixels& pixels) {
  double m = 0;
  for (int p : pixels.pixel) m = std::max(m, static_cast<double>(scene.image.rgb(p).maxCoeff()));
  return m;
}

// The (1 - fraction) quantile of the plane pixels' brightest channel.
double PlaneQuantile(const Scene& scene, const PlanePixels& pixels, double fraction) {
  std::vector<float> v;
  v.reserve(pixels.size());
  for (int p : pixels.pixel) v.push_back(scene.image.rgb(p).maxCoeff());
  if (v.empty()) return 0;
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(std::floor((1 - fraction) * v.size())));
  std::nth_element(v.begin(), v.begin() + k, v.end());
  return v[k];
}

Eigen::Matrix4d RotationAbout(const Eigen::Vector3d& centre, const Eigen::Vector3d& axis, double deg) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  const Eigen::Matrix3d r = Eigen::AngleAxisd(deg * M_PI / 180, axis.normalized()).toRotationMatrix();
  m.block<3, 3>(0, 0) = r;
  m.block<3, 1>(0, 3) = centre - r * centre;
  return m;
}

std::string SphText(const SphereTree& tree) {
  std::ostringstream out;
  WriteSph(out, tree);
  return out.str();
}

}  // namespace

std::vector<Perturbation> StabilityPerturbations(bool quick, int seeds) {
  std::vector<Perturbation> out;
  auto pick = [&](auto const& sizes) {
    std::vector<double> v(std::begin(sizes), std::end(sizes));
    if (quick) v = {v.back()};
    return v;
  };
  for (double s : pick(kNoisePercent))
    out.push_back(Make("noise", s, "%", "image noise " + Trim(s) + " %", true));
  for (double s : pick(kClipPercent))
    out.push_back(Make("clip", s, "%", "highlights clipped, top " + Trim(s) + " %", true));
  for (double s : pick(kRotationDeg))
    out.push_back(Make("rotation", s, "deg", "caster rotation " + Trim(s) + " deg", false));
  for (double s : pick(kTranslationPercent))
    out.push_back(Make("translation", s, "%", "caster translation " + Trim(s) + " %", false));
  for (double s : pick(kNormalDeg))
    out.push_back(Make("normal", s, "deg", "plane normal " + Trim(s) + " deg", false));
  for (double s : pick(kAlbedoPercent))
    out.push_back(Make("albedo", s, "%", std::string("plane albedo ") + (s > 0 ? "+" : "") + Trim(s) + " %", false));
  out.push_back(Make("texture", 0, "", "textured plane (undeclared)", true));
  Perturbation tree = Make("spheretree", kCoarseTreeLevels, "", "sphere tree L=" + std::to_string(kCoarseTreeLevels),
                           false, false);
  tree.name = "spheretree-L" + std::to_string(kCoarseTreeLevels);
  out.push_back(tree);
  const int n = quick ? std::min(seeds, 3) : seeds;
  for (int s = 1; s <= n; ++s) {
    Perturbation p = Make("seed", s, "", "seed " + std::to_string(s), true);
    p.name = "seed-" + std::to_string(s);
    out.push_back(p);
  }
  return out;
}

void WritePerturbedScene(const fs::path& scene_dir, const Perturbation& p, const fs::path& out_dir, uint64_t seed,
                         const StageContext& ctx) {
  if (p.family == "seed") throw InputError(p.name, "seeds re-solve the clean scene; there is nothing to write");
  const fs::path json_path = scene_dir / "scene.json";
  Json doc = ReadJsonFile(json_path);
  Scene scene = LoadScene(scene_dir);
  const RayCaster casters = BuildRayCaster(scene.Casters());
  const PlanePixels pixels = FindPlanePixels(scene, casters);
  RandomStream rng(DrawKey(seed, p.name), 0, 0);

  std::error_code ec;
  fs::remove(out_dir / "scene.json", ec);  // incomplete until rewritten
  CopySceneFiles(scene_dir, out_dir);

  bool image_changed = false;
  Image& img = scene.image;
  if (p.family == "noise") {
    const double sigma = p.size / 100 * PlaneMax(scene, pixels);
    const uint64_t key = DrawKey(seed, p.name);
    for (size_t i = 0; i < img.pixels(); ++i) {
      RandomStream px(key, i, 0);
      for (int c = 0; c < std::min(img.channels, 3); ++c)
        img.data[i * img.channels + c] += static_cast<float>(sigma * Gaussian(px));
    }
    image_changed = true;
  } else if (p.family == "clip") {
    const float level = static_cast<float>(PlaneQuantile(scene, pixels, p.size / 100));
    for (float& v : img.data) v = std::min(v, level);
    image_changed = true;
  } else if (p.family == "texture") {
    // A checkerboard on the plane (its own frame), mean 1, not declared in
    // scene.json: the solver sees albedo variation it does not model.
    Eigen::Vector3d lo, hi;
    CasterBounds(scene, &lo, &hi);
    const double period = std::max(1e-9, kTexturePeriodOfDiagonal * (hi - lo).norm());
    const Eigen::Vector3d n = scene.plane.normal;
    const Eigen::Vector3d u = n.unitOrthogonal(), v = n.cross(u);
    const Eigen::Vector2d phase = rng.Uniform2() * period;
    for (size_t k = 0; k < pixels.size(); ++k) {
      const Eigen::Vector3d d = pixels.point[k] - scene.plane.xyz;
      const long a = static_cast<long>(std::floor((d.dot(u) + phase.x()) / period));
      const long b = static_cast<long>(std::floor((d.dot(v) + phase.y()) / period));
      const float t = static_cast<float>(((a + b) & 1) ? 1 + kTextureContrast : 1 - kTextureContrast);
      img.set_rgb(pixels.pixel[k], img.rgb(pixels.pixel[k]) * t);
    }
    image_changed = true;
  } else if (p.family == "rotation" || p.family == "translation") {
    Eigen::Vector3d lo, hi;
    CasterBounds(scene, &lo, &hi);
    const Eigen::Vector3d dir = RandomUnit(rng);
    Eigen::Matrix4d t = Eigen::Matrix4d::Identity();
    if (p.family == "rotation") t = RotationAbout(0.5 * (lo + hi), dir, p.size);
    else t.block<3, 1>(0, 3) = dir * (p.size / 100 * (hi - lo).norm());
    for (size_t i = 0; i < scene.objects.size(); ++i)
      if (scene.objects[i].is_train) doc["objects"][i]["o2w"] = ToJson(Eigen::Matrix4d(t * scene.objects[i].o2w));
  } else if (p.family == "normal") {
    const Eigen::Vector3d n = scene.plane.normal;
    const double phi = 2 * M_PI * rng.Uniform();
    const Eigen::Vector3d u = n.unitOrthogonal(), v = n.cross(u);
    const Eigen::Vector3d axis = std::cos(phi) * u + std::sin(phi) * v;
    doc["plane"]["normal"] = ToJson(Eigen::Vector3d(Eigen::AngleAxisd(p.size * M_PI / 180, axis) * n));
  } else if (p.family == "albedo") {
    doc["plane"]["diffuse"] = ToJson(Eigen::Vector3d(scene.plane.diffuse * (1 + p.size / 100)));
  } else if (p.family == "spheretree") {
    SphereTreeBuildOptions options = SceneSphereTreeOptions();
    options.levels = static_cast<int>(p.size);
    for (size_t i = 0; i < scene.objects.size(); ++i) {
      SceneObject& o = scene.objects[i];
      if (!o.is_train) continue;
      const fs::path mesh = o.mesh_path;
      const std::string name =
          (mesh.parent_path() / (mesh.stem().string() + "_sphere_L" + std::to_string(options.levels) + ".sph"))
              .string();
      const SphereTree tree = BuildSphereTree(o.mesh, options, ctx.Progress("sphere tree L" + std::to_string(options.levels)));
      WriteTextAtomically(out_dir / name, SphText(tree));
      doc["objects"][i]["path_to_sph"] = name;
    }
  } else {
    throw InputError(p.name, "unknown perturbation family '" + p.family + "'");
  }
  if (image_changed) {
    WriteExr(out_dir / "image.exr", img);
    doc["image"] = "image.exr";
  }
  WriteJsonFile(out_dir / "scene.json", doc);
}

StabilityRun RunPerturbedSetting(const BenchScene& scene, const BenchSetting& setting, const Perturbation& p,
                                 double clean_psnr, const fs::path& bench_dir, bool force, const std::string& tag,
                                 const StageContext& ctx) {
  StabilityRun run;
  run.scene = &scene;
  run.setting = setting;
  run.perturbation = p;
  run.clean_psnr = clean_psnr;
  run.run_dir = fs::path("stability") / scene.name / p.name / setting.Name();
  const fs::path dir = bench_dir / run.run_dir;
  const fs::path eval_dir = dir / "clean_eval";
  const bool seed = p.family == "seed";
  const fs::path scored = seed ? dir / "metrics.json" : eval_dir / "metrics.json";
  const std::string what = "stability " + tag + " " + scene.name + " " + p.name + " " + setting.Name();
  if (!force)
    if (auto previous = ReadPreviousJson(scored)) {
      run.metrics = std::move(*previous);
      run.reused = true;
    }
  if (!run.reused) {
    try {
      const StageContext inner = InnerContext(ctx);
      StageContext solve_ctx = inner;
      fs::path solve_scene = bench_dir / "perturbed" / scene.name / p.name;
      if (seed) {
        solve_ctx.seed = ctx.seed + static_cast<uint64_t>(p.size);
        solve_scene = scene.dir;
      }
      if (force || !ReadPreviousJson(dir / "metrics.json")) {
        ctx.Log(what + ": solving");
        RunSolve(solve_scene, dir, setting.solve, solve_ctx);
      }
      if (!seed) {
        const bool sg = setting.method == "sg" || setting.method == "sg-paper";
        EvalOptions eo;
        eo.sg_model = setting.method == "sg-paper" ? "paper" : "sg";
        if (!sg) eo.map_height = setting.solve.map_height;
        RunEval(scene.dir, dir / (sg ? "lighting.json" : "envmap.exr"), eval_dir, eo, inner);
      }
      run.metrics = ReadJsonFile(scored);
    } catch (const Interrupted&) {
      throw;
    } catch (const std::exception& e) {
      run.error = e.what();
      ctx.Warn(what + ": failed: " + run.error);
      return run;
    }
  }
  if (run.ok()) {
    char line[200];
    std::snprintf(line, sizeof line, ": %.2f dB on the clean scene (clean solve %.2f dB, drop %.2f dB)%s", run.Psnr(),
                  clean_psnr, clean_psnr - run.Psnr(), run.reused ? " (reused)" : "");
    ctx.Log(what + line);
  }
  return run;
}

}  // namespace shadowsg
