#include "solver/shadow_plane.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <numeric>

#include "calib/error.h"
#include "solver/plane_pixels.h"
#include "solver/sg_shading.h"

namespace shadowsg {
namespace {

// Points shaded per SignedAngles call: bounds the theta matrix's memory.
constexpr size_t kRenderChunk = 8192;
// Fixed reduction chunks of MseAndGradient (independent of the thread count).
constexpr int kReductionChunks = 32;

// The lobes that take part, and their axes.
std::vector<size_t> ActiveLobes(const ShadowPlaneModel& model, const SgLighting& lighting,
                                std::vector<Eigen::Vector3d>* axes) {
  std::vector<size_t> active;
  axes->clear();
  for (size_t i = 0; i < lighting.lobes.size(); ++i) {
    if (model.upper_hemisphere_only && lighting.lobes[i].axis.dot(model.normal) <= 0) continue;
    active.push_back(i);
    axes->push_back(lighting.lobes[i].axis);
  }
  return active;
}

}  // namespace

float VisibilityCap(const ProductLobe& product, double saturation) {
  return static_cast<float>(saturation / product.steepness());
}

std::vector<float> OccluderConeCosines(const std::vector<SphereTree>& trees, const std::vector<Eigen::Vector3d>& points) {
  std::vector<Sphere> bounds;
  for (const auto& t : trees)
    if (!t.nodes.empty()) bounds.push_back(SubtreeBounds(t)[0]);
  std::vector<float> out(points.size(), 1.0f);
  for (size_t i = 0; i < points.size(); ++i) {
    double c = 1;
    for (const Sphere& b : bounds) {
      if (b.empty()) continue;
      const double d = (b.centre - points[i]).norm();
      // Inside the bound: the caster may cover the whole hemisphere.
      c = std::min(c, d > b.radius ? std::sqrt(1 - (b.radius / d) * (b.radius / d)) : 0.0);
    }
    out[i] = static_cast<float>(c);
  }
  return out;
}

void PlaneAngles(const ShadowPlaneModel& model, const std::vector<Eigen::Vector3d>& axes,
                 const std::vector<float>& caps, Eigen::MatrixXf* theta, std::vector<Eigen::Vector3f>* witness,
                 OccluderCones::AngleHints* hints) {
  if (model.HasCones()) {
    model.cones.Angles(axes, theta, witness, &caps, hints, CapSides::kBoth);
    return;
  }
  if (hints) *hints = {};  // none learnt
  SignedAnglesWithWitness(model.occluders, model.points, axes, theta, witness, model.search, &caps, CapSides::kBoth);
}

void PlaneAngles(const ShadowPlaneModel& model, const std::vector<Eigen::Vector3d>& axes,
                 const std::vector<float>& caps, Eigen::MatrixXf* theta, std::vector<Eigen::Vector3f>* witness,
                 const std::vector<OccluderCones::AngleHints*>& lobe_hints) {
  SHADOWSG_CHECK(lobe_hints.size() == axes.size());
  OccluderCones::AngleHints hints = JoinHints(lobe_hints, model.points.size());
  PlaneAngles(model, axes, caps, theta, witness, &hints);
  SplitHints(hints, lobe_hints);
}

ShadowPlaneModel MakeShadowPlaneModel(const Plane& plane, const std::vector<Eigen::Vector3d>& points,
                                      std::vector<SphereTree> occluders, ShadingModel shading) {
  ShadowPlaneModel model;
  if (shading == ShadingModel::kSg) {
    model.cosine = CosineModel::kExact;
    // Uncapped, the plane's PSNR rises on three of the four development
    // scenes (fast: pub_cone_area1 15.12 -> 15.71 dB) by lighting that is
    // worse (angular error 39 -> 88 degrees there, 5.5 -> 8.6 on sunsky), and
    // sunrise loses 0.6 dB with a 4 dB seed spread (solver/EXPERIMENTS.md).
    model.cap_occlusion = true;
    model.upper_hemisphere_only = false;
    model.max_steepness = kSgMaxVisibilitySteepness;
  }
  model.points = points;
  model.normal = plane.normal;
  model.albedo.reserve(points.size());
  for (const auto& p : points) model.albedo.push_back(PlaneAlbedo(plane, p).cast<float>());
  model.occluders = std::move(occluders);
  model.occluder_cos = OccluderConeCosines(model.occluders, model.points);
  return model;
}

ShadowPlaneModel MakeShadowPlaneModel(const Scene& scene, const PlanePixels& pixels, ShadingModel shading) {
  std::vector<SphereTree> occluders;
  for (const SceneObject* o : scene.Casters()) {
    SHADOWSG_CHECK(o->sphere_tree.has_value());
    occluders.push_back(TransformSphereTree(*o->sphere_tree, o->o2w));
  }
  return MakeShadowPlaneModel(scene.plane, pixels.point, std::move(occluders), shading);
}

void AddCasterBounce(const Scene& scene, const RayCaster& casters, ShadowPlaneModel* model) {
  std::vector<TriangleMesh> meshes;
  std::vector<Eigen::Vector3d> albedo;
  for (const SceneObject* o : scene.Casters()) meshes.push_back(o->WorldMesh()), albedo.push_back(o->diffuse);
  model->bounce = std::make_shared<const CasterBounce>(meshes, albedo, casters, scene.plane.xyz, model->normal);
  ShadowPlaneModel ground = *model;
  ground.bounce.reset();
  ground.bounce_form = {};
  ground.points = model->bounce->ground();
  ground.albedo.clear();
  for (const Eigen::Vector3d& p : ground.points) ground.albedo.push_back(PlaneAlbedo(scene.plane, p).cast<float>());
  ground.occluder_cos = OccluderConeCosines(ground.occluders, ground.points);
  if (ground.exact) ground.PrepareExactTable();
  else ground.PrepareCones();
  model->bounce_ground = std::make_shared<const ShadowPlaneModel>(std::move(ground));
}

Eigen::MatrixXf DirectLobeShading(const ShadowPlaneModel& model, const std::vector<Eigen::Vector3d>& axes,
                                  const std::vector<double>& sharpness,
                                  std::vector<OccluderCones::AngleHints>* lobe_hints) {
  const long np = static_cast<long>(model.points.size()), nl = static_cast<long>(axes.size());
  Eigen::MatrixXf out(np, nl);
  if (model.exact) {
    std::vector<ExactVisibility::Lobe> lobes;
    for (long i = 0; i < nl; ++i) lobes.push_back(model.exact->Prepare(axes[i], sharpness[i]));
    SHADOWSG_CHECK(model.HasExactTable());  // the ground and fit models always have theirs
#pragma omp parallel for schedule(dynamic, 16)
    for (long k = 0; k < np; ++k)
      for (long i = 0; i < nl; ++i)
        out(k, i) = static_cast<float>(model.exact->Shade(model.exact_table->View(k), lobes[i], false).value);
    return out;
  }
  // The exact cosine integral takes ~20 us a lobe: a dictionary's worth runs in parallel.
  std::vector<ProductLobe> products(nl);
  std::vector<float> caps(nl);
#pragma omp parallel for schedule(static) if (nl > 16)
  for (long i = 0; i < nl; ++i) {
    products[i] = EvalProductLobe(axes[i], sharpness[i], model.normal, model.cosine, /*derivatives=*/false,
                                  model.max_steepness);
    caps[i] = VisibilityCap(products[i]);
  }
  std::vector<long> column(nl);  // theta's column of each lobe
  Eigen::MatrixXf theta;
  if (lobe_hints) {  // hints are per lobe: each lobe its own search
    std::vector<OccluderCones::AngleHints*> one_axis;
    for (auto& h : *lobe_hints) one_axis.push_back(&h);
    PlaneAngles(model, axes, caps, &theta, nullptr, one_axis);
    std::iota(column.begin(), column.end(), 0L);
  } else {
    // theta depends on the axis alone: a dictionary repeats each axis once
    // per sharpness, so search each distinct axis once, as far as its widest
    // cap (beyond a lobe's own cap its sigmoid is 1 either way).
    std::vector<Eigen::Vector3d> unique_axes;
    std::vector<float> unique_caps;
    std::map<std::array<double, 3>, long> seen;
    for (long i = 0; i < nl; ++i) {
      const auto [it, added] = seen.try_emplace({axes[i].x(), axes[i].y(), axes[i].z()}, unique_axes.size());
      if (added) unique_axes.push_back(axes[i]), unique_caps.push_back(caps[i]);
      column[i] = it->second;
      unique_caps[it->second] = std::max(unique_caps[it->second], caps[i]);
    }
    PlaneAngles(model, unique_axes, unique_caps, &theta, nullptr);
  }
#pragma omp parallel for schedule(static)
  for (long k = 0; k < np; ++k)
    for (long i = 0; i < nl; ++i)
      out(k, i) = static_cast<float>(ShadeLobe(products[i], theta(k, column[i]), Eigen::Vector3d::Zero(),
                                               model.cap_occlusion ? model.occluder_cos[k] : kNoOcclusionCap)
                                         .value);
  return out;
}

std::array<Eigen::MatrixXf, 3> BounceIrradiance(const ShadowPlaneModel& model, const std::vector<Eigen::Vector3d>& axes,
                                                const std::vector<double>& sharpness,
                                                std::vector<OccluderCones::AngleHints>* ground_hints) {
  SHADOWSG_CHECK(model.bounce);
  if (!model.bounce_ground) return model.bounce->Irradiance(axes, sharpness, nullptr);
  const ShadowPlaneModel& g = *model.bounce_ground;
  const Eigen::MatrixXf s = DirectLobeShading(g, axes, sharpness, ground_hints);
  std::array<Eigen::MatrixXf, 3> radiance;
  for (int c = 0; c < 3; ++c) {
    radiance[c] = s;
    for (long p = 0; p < s.rows(); ++p) radiance[c].row(p) *= g.albedo[p][c];
  }
  return model.bounce->Irradiance(axes, sharpness, &radiance);
}

namespace {

std::vector<Eigen::Vector3f> RenderDirect(const ShadowPlaneModel& model, const SgLighting& lighting);

}  // namespace

namespace {

// K (radiance): the patches' radiance carried to the model's points.
Eigen::MatrixXf GatherBounce(const ShadowPlaneModel& model, const Eigen::MatrixXf& radiance) {
  if (model.HasBounceForm()) return model.bounce_form.Times(radiance);
  return RowParallelProduct(model.bounce->FormFactors(model.points), radiance);
}

}  // namespace

Eigen::MatrixXf BounceLobeShading(const ShadowPlaneModel& model, const std::array<Eigen::MatrixXf, 3>& irradiance) {
  SHADOWSG_CHECK(model.bounce);
  Eigen::MatrixXf radiance = Eigen::MatrixXf::Zero(irradiance[0].rows(), irradiance[0].cols());
  for (int c = 0; c < 3; ++c)
    for (long j = 0; j < radiance.rows(); ++j)
      radiance.row(j) += model.bounce->patches()[j].albedo_over_pi[c] / 3 * irradiance[c].row(j);
  return GatherBounce(model, radiance);
}

LobeShadingColumns LobeColumns(const ShadowPlaneModel& model, const std::vector<Eigen::Vector3d>& axes,
                               const std::vector<double>& sharpness,
                               std::vector<OccluderCones::AngleHints>* lobe_hints,
                               const std::array<Eigen::MatrixXf, 3>* bounce_irradiance) {
  LobeShadingColumns s;
  s.direct = DirectLobeShading(model, axes, sharpness, lobe_hints);
  if (model.bounce) {
    SHADOWSG_CHECK(!bounce_irradiance || (*bounce_irradiance)[0].cols() == static_cast<long>(axes.size()));
    s.bounce = BounceLobeShadingRgb(model, bounce_irradiance ? *bounce_irradiance : BounceIrradiance(model, axes, sharpness));
  }
  return s;
}

Eigen::MatrixXd LobeShadingColumns::Weighted(const ShadowPlaneModel& model, const std::vector<double>& weight,
                                             int c) const {
  SHADOWSG_CHECK(weight.size() == model.points.size() && direct.rows() == static_cast<long>(weight.size()));
  const long rows = direct.rows(), cols = direct.cols();
  const bool with_bounce = bounce.size() > 0;
  SHADOWSG_CHECK(!with_bounce || (bounce.rows() == rows && bounce.cols() == 3 * cols));
  Eigen::VectorXd row_scale(rows);
  for (long k = 0; k < rows; ++k) row_scale[k] = std::sqrt(weight[k]) * model.albedo[k][c] / M_PI;
  // Column by column on the threads: the scan's few hundred candidates
  // made this a serial 1 % of a `fast` solve.
  Eigen::MatrixXd out(rows, cols);
#pragma omp parallel for schedule(static) if (rows * cols > 65536)
  for (long j = 0; j < cols; ++j)
    for (long k = 0; k < rows; ++k)
      out(k, j) = row_scale[k] * static_cast<double>(with_bounce ? direct(k, j) + bounce(k, c * cols + j) : direct(k, j));
  return out;
}

Eigen::MatrixXf BouncePatchRadianceRgb(const ShadowPlaneModel& model, const std::array<Eigen::MatrixXf, 3>& irradiance) {
  SHADOWSG_CHECK(model.bounce);
  const long m = irradiance[0].rows(), nl = irradiance[0].cols();
  Eigen::MatrixXf radiance(m, 3 * nl);  // one product for the three channels
  for (int c = 0; c < 3; ++c)
    for (long j = 0; j < m; ++j)
      radiance.block(j, c * nl, 1, nl) = model.bounce->patches()[j].albedo_over_pi[c] * irradiance[c].row(j);
  return radiance;
}

Eigen::MatrixXf BounceLobeShadingRgb(const ShadowPlaneModel& model, const std::array<Eigen::MatrixXf, 3>& irradiance) {
  return GatherBounce(model, BouncePatchRadianceRgb(model, irradiance));
}

namespace {

// The bounce's share of RenderShadowPlane (model.bounce set).
std::vector<Eigen::Vector3f> RenderBounce(const ShadowPlaneModel& model, const SgLighting& lighting) {
  std::vector<Eigen::Vector3f> out(model.points.size(), Eigen::Vector3f::Zero());
  if (!model.bounce || lighting.lobes.empty()) return out;
  std::vector<Eigen::Vector3d> axes;
  std::vector<double> sharpness;
  SplitLobes(lighting.lobes, &axes, &sharpness);
  const std::array<Eigen::MatrixXf, 3> e = BounceIrradiance(model, axes, sharpness);
  Eigen::MatrixXf radiance(e[0].rows(), 3);  // what each patch sends, per channel
  for (int c = 0; c < 3; ++c) {
    Eigen::VectorXf amp(static_cast<long>(lighting.lobes.size()));
    for (size_t i = 0; i < lighting.lobes.size(); ++i) amp[static_cast<long>(i)] = static_cast<float>(lighting.lobes[i].amplitude[c]);
    radiance.col(c) = e[c] * amp;
    for (long j = 0; j < radiance.rows(); ++j) radiance(j, c) *= model.bounce->patches()[j].albedo_over_pi[c];
  }
  if (model.HasBounceForm()) {
    const Eigen::MatrixXf b = GatherBounce(model, radiance);
    for (size_t k = 0; k < out.size(); ++k) out[k] = b.row(static_cast<long>(k)).transpose();
  } else {
    out = model.bounce->Gather(model.points, radiance);
  }
  for (size_t k = 0; k < out.size(); ++k) out[k] = model.albedo[k].cwiseProduct(out[k]) / static_cast<float>(M_PI);
  return out;
}

}  // namespace

std::vector<Eigen::Vector3f> RenderShadowPlane(const ShadowPlaneModel& model, const SgLighting& lighting,
                                               std::vector<Eigen::Vector3f>* bounce_share) {
  std::vector<Eigen::Vector3f> out = RenderDirect(model, lighting);
  if (!model.bounce) return out;
  std::vector<Eigen::Vector3f> b = RenderBounce(model, lighting);
  for (size_t k = 0; k < out.size(); ++k) out[k] += b[k];
  if (bounce_share) *bounce_share = std::move(b);
  return out;
}

namespace {

// What a closed-form render of the model's points under `lighting` shades
// with: the lobes that take part, their product lobes and visibility caps.
struct DirectLobes {
  std::vector<size_t> active;
  std::vector<Eigen::Vector3d> axes;
  std::vector<ProductLobe> products;
  std::vector<float> caps;
};
DirectLobes PrepareDirectLobes(const ShadowPlaneModel& model, const SgLighting& lighting) {
  DirectLobes d;
  d.active = ActiveLobes(model, lighting, &d.axes);
  for (size_t i : d.active)
    d.products.push_back(EvalProductLobe(lighting.lobes[i].axis, lighting.lobes[i].sharpness, model.normal,
                                         model.cosine, /*derivatives=*/false, model.max_steepness));
  for (const ProductLobe& p : d.products) d.caps.push_back(VisibilityCap(p));
  return d;
}

// The radiance of the model's points [begin, begin + theta.rows()) from
// their theta (rows) and occluder cone cosines (occluder_cos[k] for point
// begin + k), into out[begin + k].
void ShadeDirect(const ShadowPlaneModel& model, const SgLighting& lighting, const DirectLobes& d, size_t begin,
                 const Eigen::MatrixXf& theta, const float* occluder_cos, std::vector<Eigen::Vector3f>* out) {
#pragma omp parallel for schedule(static)
  for (long k = 0; k < theta.rows(); ++k) {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (size_t j = 0; j < d.active.size(); ++j) {
      const LobeShading s = ShadeLobe(d.products[j], theta(k, j), Eigen::Vector3d::Zero(),
                                      model.cap_occlusion ? occluder_cos[k] : kNoOcclusionCap);
      sum += s.value * lighting.lobes[d.active[j]].amplitude;
    }
    (*out)[begin + k] = (model.albedo[begin + k].cast<double>().cwiseProduct(sum) / M_PI).cast<float>();
  }
}

std::vector<Eigen::Vector3f> RenderDirect(const ShadowPlaneModel& model, const SgLighting& lighting) {
  if (model.exact)
    return model.exact->Render(model.points, model.albedo, lighting, model.upper_hemisphere_only,
                               model.HasExactTable() ? model.exact_table.get() : nullptr);
  const DirectLobes d = PrepareDirectLobes(model, lighting);
  std::vector<Eigen::Vector3f> out(model.points.size(), Eigen::Vector3f::Zero());
  Eigen::MatrixXf theta;
  const size_t chunk_size = model.HasCones() ? model.points.size() : kRenderChunk;
  for (size_t begin = 0; begin < model.points.size(); begin += chunk_size) {
    const size_t end = std::min(model.points.size(), begin + chunk_size);
    const std::vector<Eigen::Vector3d> chunk(model.points.begin() + begin, model.points.begin() + end);
    if (model.HasCones()) model.cones.Angles(d.axes, &theta, nullptr, &d.caps, nullptr, CapSides::kBoth);
    else SignedAnglesWithWitness(model.occluders, chunk, d.axes, &theta, nullptr, model.search, &d.caps, CapSides::kBoth);
    ShadeDirect(model, lighting, d, begin, theta, model.occluder_cos.data() + begin, &out);
  }
  return out;
}

}  // namespace

void RenderShadowPlaneAdding(const ShadowPlaneModel& model, const std::vector<SphereTree>& more,
                             const SgLighting& lighting, std::vector<Eigen::Vector3f>* without,
                             std::vector<Eigen::Vector3f>* with) {
  SHADOWSG_CHECK(!model.exact && !model.bounce && !model.HasCones());
  const DirectLobes d = PrepareDirectLobes(model, lighting);
  without->assign(model.points.size(), Eigen::Vector3f::Zero());
  with->assign(model.points.size(), Eigen::Vector3f::Zero());
  Eigen::MatrixXf theta, theta_more;
  for (size_t begin = 0; begin < model.points.size(); begin += kRenderChunk) {
    const size_t end = std::min(model.points.size(), begin + kRenderChunk);
    const std::vector<Eigen::Vector3d> chunk(model.points.begin() + begin, model.points.begin() + end);
    SignedAnglesWithWitness(model.occluders, chunk, d.axes, &theta, nullptr, model.search, &d.caps, CapSides::kBoth);
    ShadeDirect(model, lighting, d, begin, theta, model.occluder_cos.data() + begin, without);
    // theta and the cap's cone over every occluder are the smaller of the
    // model's and `more`'s.
    SignedAnglesWithWitness(more, chunk, d.axes, &theta_more, nullptr, model.search, &d.caps, CapSides::kBoth, &theta);
    theta.swap(theta_more);
    std::vector<float> cos_with = OccluderConeCosines(more, chunk);
    for (size_t k = 0; k < cos_with.size(); ++k) cos_with[k] = std::min(cos_with[k], model.occluder_cos[begin + k]);
    ShadeDirect(model, lighting, d, begin, theta, cos_with.data(), with);
  }
}

double MseAndGradient(const ShadowPlaneModel& model, const SgLighting& lighting, const std::vector<size_t>& points,
                      const std::vector<Eigen::Vector3f>& targets, Eigen::MatrixXd* grad) {
  SHADOWSG_CHECK(!model.bounce);  // the paper's model: direct light only
  std::vector<Eigen::Vector3d> axes;
  const std::vector<size_t> active = ActiveLobes(model, lighting, &axes);
  const size_t na = active.size();
  std::vector<ProductLobe> products;
  for (size_t i : active)
    products.push_back(EvalProductLobe(lighting.lobes[i].axis, lighting.lobes[i].sharpness, model.normal, model.cosine,
                                       /*derivatives=*/true, model.max_steepness));
  std::vector<Eigen::Vector3d> xs;
  xs.reserve(points.size());
  for (size_t i : points) xs.push_back(model.points[i]);
  std::vector<float> caps;
  for (const ProductLobe& p : products) caps.push_back(VisibilityCap(p));
  Eigen::MatrixXf theta;
  std::vector<Eigen::Vector3f> witness;
  SignedAnglesWithWitness(model.occluders, xs, axes, &theta, &witness, model.search, &caps);

  std::vector<Eigen::MatrixXd> chunk_grad(kReductionChunks, Eigen::MatrixXd::Zero(static_cast<long>(na), 7));
  std::vector<double> chunk_loss(kReductionChunks, 0.0);
#pragma omp parallel for schedule(dynamic, 1)
  for (int c = 0; c < kReductionChunks; ++c) {
    std::vector<LobeShading> shade(na);
    for (size_t k = c; k < points.size(); k += kReductionChunks) {
      const size_t i = points[k];
      const Eigen::Vector3d rho_over_pi = model.albedo[i].cast<double>() / M_PI;
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      for (size_t j = 0; j < na; ++j) {
        const SgLobe& lobe = lighting.lobes[active[j]];
        const Eigen::Vector3d u = witness[k * na + j].cast<double>();
        const double cosine = std::clamp(u.dot(lobe.axis), -1.0, 1.0);
        const Eigen::Vector3d dtheta = u.isZero() ? Eigen::Vector3d::Zero()
                                                   : Eigen::Vector3d(-u / std::max(std::sqrt(1 - cosine * cosine), 1e-9));
        shade[j] = ShadeLobe(products[j], theta(static_cast<long>(k), static_cast<long>(j)), dtheta,
                             model.cap_occlusion ? model.occluder_cos[i] : kNoOcclusionCap);
        sum += shade[j].value * lobe.amplitude;
      }
      const Eigen::Vector3d r = rho_over_pi.cwiseProduct(sum) - targets[i].cast<double>();
      chunk_loss[c] += r.squaredNorm();
      // d(r.r)/d(param) = 2 sum_c r_c dL_c/d(param).
      const Eigen::Vector3d w = 2 * r.cwiseProduct(rho_over_pi);
      for (size_t j = 0; j < na; ++j) {
        const Eigen::Vector3d& a = lighting.lobes[active[j]].amplitude;
        const double wa = w.dot(a);
        auto row = chunk_grad[c].row(static_cast<long>(j));
        row.segment<3>(0) += wa * shade[j].dvalue_dmu.transpose();
        row[3] += wa * shade[j].dvalue_dlambda;
        row.segment<3>(4) += shade[j].value * w.transpose();
      }
    }
  }
  Eigen::MatrixXd g = Eigen::MatrixXd::Zero(static_cast<long>(lighting.lobes.size()), 7);
  double loss = 0;
  const double denom = 3.0 * std::max<size_t>(1, points.size());
  for (int c = 0; c < kReductionChunks; ++c) {
    loss += chunk_loss[c];
    for (size_t j = 0; j < na; ++j) g.row(static_cast<long>(active[j])) += chunk_grad[c].row(static_cast<long>(j));
  }
  if (grad) *grad = g / denom;
  return loss / denom;
}

}  // namespace shadowsg
