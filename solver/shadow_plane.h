// The shadow plane as the SG solvers see it: the plane points of the pixels
// in use, their albedo, the plane normal, and the casters as sphere trees;
// and the closed-form renderer of method-notes.md ("The forward model"):
//   L(x) = albedo(x)/pi * sum_i a_i * scale_i * sigma(k(lambda'_i) theta_i(x)).
#pragma once

#include <Eigen/Dense>
#include <memory>
#include <vector>

#include "solver/caster_bounce.h"
#include "solver/exact_visibility.h"
#include "solver/plane_pixels.h"
#include "solver/scene.h"
#include "solver/sg.h"
#include "solver/sg_shading.h"
#include "solver/sphere_tree.h"
#include "solver/ssdf.h"

namespace shadowsg {

struct ShadowPlaneModel {
  std::vector<Eigen::Vector3d> points;  // world-space plane points
  std::vector<Eigen::Vector3f> albedo;  // plane albedo at each point (textures allowed)
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  std::vector<SphereTree> occluders;    // world-space sphere trees of the casters
  SsdfSearch search = SsdfSearch::kExact;
  CosineModel cosine = CosineModel::kSgProduct;
  // The reference code drops any lobe whose axis lies below the plane.
  bool upper_hemisphere_only = true;
  // Cap broad lobes' occlusion by the caster's cone (ShadeLobe): per point the
  // cosine of the half-angle of a cone around every caster.
  bool cap_occlusion = false;
  std::vector<float> occluder_cos;
  // The visibility sigmoid's steepness is capped here (ProductLobe::max_steepness):
  // `sg` caps it (kSgMaxVisibilitySteepness), the paper's model does not.
  double max_steepness = kUncappedSteepness;
  // Optional cone tables of `points` (PrepareCones): repeated renders of the
  // same points then skip the per-point table set-up.
  OccluderCones cones;

  // `--visibility exact` (solver/exact_visibility.h): when set, the `sg`
  // solver and RenderShadowPlane shade with the casters' real meshes (ray
  // cast) instead of the sphere trees' sigmoid; exact_table, when it holds
  // `points`, saves re-casting their rays.
  std::shared_ptr<const ExactVisibility> exact;
  std::shared_ptr<const OccludedTable> exact_table;

  // Light the casters reflect onto the plane (solver/caster_bounce.h), added
  // to whichever visibility shades the direct light; bounce_form, when it
  // holds `points`, saves recomputing their form factors (factored:
  // FactorFormFactors).
  std::shared_ptr<const CasterBounce> bounce;
  FactoredFormFactors bounce_form;
  // The bounce's ground points as a model of their own (same visibility,
  // cones or exact table prepared): their direct light feeds the second bounce.
  std::shared_ptr<const ShadowPlaneModel> bounce_ground;

  bool HasCones() const { return cones.size() == points.size() && !points.empty(); }
  void PrepareCones() { cones = OccluderCones(occluders, points, search); }
  bool HasExactTable() const { return exact && exact_table && exact_table->size() == points.size(); }
  bool HasBounceForm() const {
    return bounce && bounce_form.left.rows() == static_cast<long>(points.size()) && !points.empty();
  }
  // tolerance: FactorFormFactors's (0: K exactly, unfactored).
  void PrepareBounceForm(double tolerance = 0) {
    if (bounce) bounce_form = FactorFormFactors(bounce->FormFactors(points), tolerance);
  }
  void PrepareExactTable() { exact_table = std::make_shared<const OccludedTable>(exact->Tabulate(points)); }
};

// theta (and witness directions, when non-null) of every point of the model for
// the lobes' axes, using the prepared cones when there are. theta is only
// resolved up to where the lobe's visibility sigmoid saturates (VisibilityCap),
// both ways (CapSides::kBoth): at or below minus the cap it is some leaf's.
// hints: OccluderCones::Angles's, used with prepared cones only.
void PlaneAngles(const ShadowPlaneModel& model, const std::vector<Eigen::Vector3d>& axes,
                 const std::vector<float>& caps, Eigen::MatrixXf* theta, std::vector<Eigen::Vector3f>* witness,
                 OccluderCones::AngleHints* hints = nullptr);
// The same with one-axis hints per lobe (in and out), as solvers keep them.
void PlaneAngles(const ShadowPlaneModel& model, const std::vector<Eigen::Vector3d>& axes,
                 const std::vector<float>& caps, Eigen::MatrixXf* theta, std::vector<Eigen::Vector3f>* witness,
                 const std::vector<OccluderCones::AngleHints*>& lobe_hints);

// Per point, the cosine of the half-angle of the cone around each caster's
// bounding sphere (the smallest over casters; 0 inside a bound).
std::vector<float> OccluderConeCosines(const std::vector<SphereTree>& trees, const std::vector<Eigen::Vector3d>& points);

// The theta beyond which sigmoid(k(lambda') theta) is 1 (and its derivative 0)
// to double precision, and below minus which it is 0: no occluder search
// needs to look further (ShadeLobe's value there no longer depends on theta).
// A caller whose shading is float may pass a lower saturation (z at which the
// sigmoid is within an ulp of 1 in float).
float VisibilityCap(const ProductLobe& product, double saturation = kSigmoidSaturation);

// Which shading the model uses: the paper's (cosine as one SG, plain sigmoid
// visibility, lobes below the plane dropped) or `sg`'s (exact cosine,
// occlusion capped by the caster's cone, every lobe kept).
enum class ShadingModel { kPaper, kSg };

// The model of a scene's plane pixels; every caster must have a sphere tree.
ShadowPlaneModel MakeShadowPlaneModel(const Scene& scene, const PlanePixels& pixels,
                                      ShadingModel shading = ShadingModel::kPaper);
// The model of any points of `plane` under `occluders` (the compositor's
// points, with or without the virtual objects): the one place that says what
// each ShadingModel sets.
ShadowPlaneModel MakeShadowPlaneModel(const Plane& plane, const std::vector<Eigen::Vector3d>& points,
                                      std::vector<SphereTree> occluders, ShadingModel shading);

// Adds the casters' bounce (solver/caster_bounce.h) to a model whose
// visibility (spheres or exact) is already set; `sg` only. casters: the
// scene's casters (BuildRayCaster(scene.Casters())), which the caller has
// built already: a scanned mesh's build is not free.
void AddCasterBounce(const Scene& scene, const RayCaster& casters, ShadowPlaneModel* model);

// Direct shading of each lobe at every point of the model, per unit amplitude
// and unit albedo/pi, without the bounce: points x lobes. lobe_hints (one per
// lobe, optional, in and out): each lobe's visibility search hints
// (OccluderCones::AngleHints) over the model's points.
Eigen::MatrixXf DirectLobeShading(const ShadowPlaneModel& model, const std::vector<Eigen::Vector3d>& axes,
                                  const std::vector<double>& sharpness,
                                  std::vector<OccluderCones::AngleHints>* lobe_hints = nullptr);

// Per channel, the irradiance per unit amplitude of each lobe at the casters'
// patches (patches x lobes), the plane's second bounce included.
// ground_hints (one per lobe, optional, in and out): DirectLobeShading's
// lobe_hints for the bounce's ground points.
std::array<Eigen::MatrixXf, 3> BounceIrradiance(const ShadowPlaneModel& model, const std::vector<Eigen::Vector3d>& axes,
                                                const std::vector<double>& sharpness,
                                                std::vector<OccluderCones::AngleHints>* ground_hints = nullptr);

// The bounce's shading of each lobe at the model's points (points x lobes),
// per unit amplitude and unit plane albedo/pi, averaged over the channels,
// from BounceIrradiance's result; and per channel (points x 3 lobes, in
// BouncePatchRadianceRgb's column order). The channels stay in the one
// product's result: split into three matrices they doubled the largest
// allocation of a solve (a grid search's 441 candidates: 32 MB a copy).
Eigen::MatrixXf BounceLobeShading(const ShadowPlaneModel& model, const std::array<Eigen::MatrixXf, 3>& irradiance);
Eigen::MatrixXf BounceLobeShadingRgb(const ShadowPlaneModel& model, const std::array<Eigen::MatrixXf, 3>& irradiance);
// What BounceLobeShadingRgb gathers: the patches' radiance per unit amplitude
// (patches x 3 lobes; channel c's lobes in columns [c lobes, (c + 1) lobes)).
Eigen::MatrixXf BouncePatchRadianceRgb(const ShadowPlaneModel& model, const std::array<Eigen::MatrixXf, 3>& irradiance);

// Each lobe's shading at the model's points, per unit amplitude and unit
// albedo/pi: direct light, and per channel the casters' bounce when the model
// has it. Weighted(c) gives channel c's columns as the rows of a weighted
// least-squares system, sqrt(w_k) rho_kc/pi (direct + bounce): what the
// solvers' amplitude NNLS works on.
struct LobeShadingColumns {
  Eigen::MatrixXf direct;                 // points x lobes
  Eigen::MatrixXf bounce;  // points x 3 lobes (BounceLobeShadingRgb); empty without the bounce
  Eigen::MatrixXd Weighted(const ShadowPlaneModel& model, const std::vector<double>& weight, int c) const;
};
// bounce_irradiance (optional): BounceIrradiance of these lobes, which does
// not depend on the model's points (callers with several point sets share it).
LobeShadingColumns LobeColumns(const ShadowPlaneModel& model, const std::vector<Eigen::Vector3d>& axes,
                               const std::vector<double>& sharpness,
                               std::vector<OccluderCones::AngleHints>* lobe_hints = nullptr,
                               const std::array<Eigen::MatrixXf, 3>* bounce_irradiance = nullptr);

// Closed-form radiance of every point (direct light, plus the casters'
// bounce when the model has it; bounce_share, when given, receives that
// part alone). Multithreaded.
std::vector<Eigen::Vector3f> RenderShadowPlane(const ShadowPlaneModel& model, const SgLighting& lighting,
                                               std::vector<Eigen::Vector3f>* bounce_share = nullptr);

// The model's points rendered as RenderShadowPlane renders them (*without)
// and with the occluders `more` beside the model's (*with): the compositor's
// plane without and with the virtual objects. The second render searches
// only `more`, below the first's theta (SignedAnglesWithWitness' known), so
// the pair costs little more than one render. The model: sphere-tree visibility, no bounce, no
// prepared cones. (Where the sigmoid is saturated at 0 both ways, a theta may
// be another leaf's than a search of every tree returns, both at or below
// minus the cap.)
void RenderShadowPlaneAdding(const ShadowPlaneModel& model, const std::vector<SphereTree>& more,
                             const SgLighting& lighting, std::vector<Eigen::Vector3f>* without,
                             std::vector<Eigen::Vector3f>* with);

// Mean squared error over the listed points and the three channels, against
// targets[point], and its gradient with respect to each lobe's
// [axis mu (3, as a free vector at |mu| = 1) | sharpness (1) | amplitude (3)]
// in grad (lobes x 7). Sums are reduced in a fixed order: the result does not
// depend on the thread count.
double MseAndGradient(const ShadowPlaneModel& model, const SgLighting& lighting, const std::vector<size_t>& points,
                      const std::vector<Eigen::Vector3f>& targets, Eigen::MatrixXd* grad);

}  // namespace shadowsg
