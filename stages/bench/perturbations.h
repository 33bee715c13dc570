// The stability study of `shadowsg bench --stability`: each perturbation
// writes a perturbed copy of a scene folder (DIR/perturbed/<scene>/<name>/),
// every method re-solves it (DIR/stability/<scene>/<name>/<setting>/), and
// the estimate is scored on the UNPERTURBED scene by `eval`
// (.../<setting>/clean_eval/metrics.json): the re-render under the estimated
// lighting, with the true geometry, against the true image. Seeds re-solve
// the clean scene with another --seed and are scored by the solve itself.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "stages/bench/bench_report.h"
#include "stages/stage_context.h"

namespace shadowsg {

// Perturbation sizes (README "Benchmark (bench)"). Noise sigma and the texture
// contrast are fractions of the maximum of the clean image over the plane
// pixels / of the albedo; translations are fractions of the caster's
// bounding-box diagonal.
inline constexpr double kNoisePercent[] = {0.5, 2, 5};
inline constexpr double kClipPercent[] = {1, 5};          // share of plane pixels saturated
inline constexpr double kRotationDeg[] = {1, 3};          // caster rotation about its bbox centre
inline constexpr double kTranslationPercent[] = {1, 3};   // caster translation, % of its bbox diagonal
inline constexpr double kNormalDeg[] = {1, 3};            // plane normal tilt
inline constexpr double kAlbedoPercent[] = {-10, 10};     // plane albedo error
inline constexpr double kTextureContrast = 0.15;          // albedo x (1 +- 0.15), a checkerboard
inline constexpr double kTexturePeriodOfDiagonal = 0.5;   // checker square = half the caster diagonal
inline constexpr int kCoarseTreeLevels = 2;               // the coarser sphere tree (root + 8 leaves)
inline constexpr int kDefaultStabilitySeeds = 10;

// The perturbations in table order; `quick`: one size per family and at most
// 3 seeds.
std::vector<Perturbation> StabilityPerturbations(bool quick, int seeds);

// Writes the perturbed copy of scene_dir into out_dir: every file copied,
// then image.exr and scene.json rewritten (scene.json last, so a folder with
// scene.json is complete). Seeds need no copy (InputError if asked).
// Random draws (noise, rotation axes, texture phase) depend on `seed` and the
// perturbation's name only.
void WritePerturbedScene(const std::filesystem::path& scene_dir, const Perturbation& perturbation,
                         const std::filesystem::path& out_dir, uint64_t seed, const StageContext& ctx);

// Solves the perturbed scene with `setting` and scores the lighting on the
// clean scene; skips steps whose outputs exist unless `force`. Failures are
// recorded in StabilityRun::error; Interrupted propagates.
StabilityRun RunPerturbedSetting(const BenchScene& scene, const BenchSetting& setting,
                                 const Perturbation& perturbation, double clean_psnr,
                                 const std::filesystem::path& bench_dir, bool force, const std::string& tag,
                                 const StageContext& ctx);

}  // namespace shadowsg
