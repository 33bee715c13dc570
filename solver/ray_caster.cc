#include "solver/ray_caster.h"

#include <embree3/rtcore.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>

#include "calib/error.h"

namespace shadowsg {

struct RayCaster::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  int meshes = 0;
  bool committed = false;

  Impl() {
    device = rtcNewDevice(nullptr);
    if (!device) throw std::runtime_error("Embree: cannot create a device");
    scene = rtcNewScene(device);
    // Medium, not high: on a scanned mesh of 1.1M faces (2 threads) high took
    // 0.8-1.1 s to build and medium 0.23-0.24 s, and a million rays cost the
    // same (0.04 s) either way; a run casts about that many (solver/EXPERIMENTS.md,
    // "Stop 59").
    rtcSetSceneBuildQuality(scene, RTC_BUILD_QUALITY_MEDIUM);
  }
  ~Impl() {
    if (scene) rtcReleaseScene(scene);
    if (device) rtcReleaseDevice(device);
  }
};

RayCaster::RayCaster() : impl_(std::make_unique<Impl>()) {}
RayCaster::~RayCaster() = default;
RayCaster::RayCaster(RayCaster&&) noexcept = default;
RayCaster& RayCaster::operator=(RayCaster&&) noexcept = default;

int RayCaster::AddMesh(const TriangleMesh& mesh) {
  SHADOWSG_CHECK(!impl_->committed);
  RTCGeometry geom = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                        3 * sizeof(float), mesh.vertices.size()));
  for (size_t i = 0; i < mesh.vertices.size(); ++i)
    for (int k = 0; k < 3; ++k) v[3 * i + k] = static_cast<float>(mesh.vertices[i][k]);
  auto* f = static_cast<unsigned*>(rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                           3 * sizeof(unsigned), mesh.faces.size()));
  for (size_t i = 0; i < mesh.faces.size(); ++i)
    for (int k = 0; k < 3; ++k) f[3 * i + k] = static_cast<unsigned>(mesh.faces[i][k]);
  rtcCommitGeometry(geom);
  const unsigned id = rtcAttachGeometry(impl_->scene, geom);
  rtcReleaseGeometry(geom);
  ++impl_->meshes;
  return static_cast<int>(id);
}

void RayCaster::Commit() {
  rtcCommitScene(impl_->scene);
  impl_->committed = true;
}

bool RayCaster::empty() const { return impl_->meshes == 0; }

namespace {

void FillRay(RTCRay* ray, const Eigen::Vector3d& o, const Eigen::Vector3d& d, double tnear, double tfar) {
  ray->org_x = static_cast<float>(o.x());
  ray->org_y = static_cast<float>(o.y());
  ray->org_z = static_cast<float>(o.z());
  ray->dir_x = static_cast<float>(d.x());
  ray->dir_y = static_cast<float>(d.y());
  ray->dir_z = static_cast<float>(d.z());
  ray->tnear = static_cast<float>(tnear);
  ray->tfar = tfar >= 1e30 ? std::numeric_limits<float>::infinity() : static_cast<float>(tfar);
  ray->time = 0;
  ray->mask = 0xFFFFFFFFu;
  ray->id = 0;
  ray->flags = 0;
}

}  // namespace

std::optional<RayHit> RayCaster::Intersect(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir,
                                           double tnear, double tfar) const {
  SHADOWSG_CHECK(impl_->committed);
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRayHit rh;
  FillRay(&rh.ray, origin, dir, tnear, tfar);
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(impl_->scene, &context, &rh);
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return std::nullopt;
  RayHit hit;
  hit.t = rh.ray.tfar;
  hit.geometry = static_cast<int>(rh.hit.geomID);
  hit.primitive = static_cast<int>(rh.hit.primID);
  hit.u = rh.hit.u;
  hit.v = rh.hit.v;
  hit.normal = Eigen::Vector3d(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z).normalized();
  if (hit.normal.dot(dir) > 0) hit.normal = -hit.normal;
  return hit;
}

bool RayCaster::Occluded(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double tnear,
                         double tfar) const {
  SHADOWSG_CHECK(impl_->committed);
  if (impl_->meshes == 0) return false;
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  RTCRay ray;
  FillRay(&ray, origin, dir, tnear, tfar);
  rtcOccluded1(impl_->scene, &context, &ray);
  return ray.tfar < 0;  // Embree sets tfar = -inf on a hit
}

void RayCaster::Visible(const Eigen::Vector3d& origin, const std::vector<Eigen::Vector3d>& dirs, double tnear,
                        std::vector<char>* visible) const {
  SHADOWSG_CHECK(impl_->committed);
  visible->assign(dirs.size(), 1);
  if (impl_->meshes == 0) return;
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
  constexpr int kPacket = 16;
  for (size_t start = 0; start < dirs.size(); start += kPacket) {
    const int n = static_cast<int>(std::min<size_t>(kPacket, dirs.size() - start));
    alignas(64) int valid[kPacket];
    alignas(64) RTCRay16 rays;
    for (int i = 0; i < kPacket; ++i) {
      valid[i] = i < n ? -1 : 0;
      const Eigen::Vector3d& d = dirs[start + std::min(i, n - 1)];
      rays.org_x[i] = static_cast<float>(origin.x());
      rays.org_y[i] = static_cast<float>(origin.y());
      rays.org_z[i] = static_cast<float>(origin.z());
      rays.dir_x[i] = static_cast<float>(d.x());
      rays.dir_y[i] = static_cast<float>(d.y());
      rays.dir_z[i] = static_cast<float>(d.z());
      rays.tnear[i] = static_cast<float>(tnear);
      rays.tfar[i] = std::numeric_limits<float>::infinity();
      rays.time[i] = 0;
      rays.mask[i] = 0xFFFFFFFFu;
      rays.id[i] = i;
      rays.flags[i] = 0;
    }
    rtcOccluded16(valid, impl_->scene, &context, &rays);
    for (int i = 0; i < n; ++i) (*visible)[start + i] = rays.tfar[i] >= 0;
  }
}

}  // namespace shadowsg
