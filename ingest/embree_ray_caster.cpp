// Embree 3 implementation of RayCaster for triangle meshes.
#include "ingest/ingest.h"

#include <embree3/rtcore.h>

#include <string>

namespace apo {
namespace {

void recordEmbreeError(void* userPtr, RTCError code, const char* message) {
  auto* last = static_cast<std::string*>(userPtr);
  *last = fmt::format("Embree error {}: {}", static_cast<int>(code), message ? message : "");
}

class EmbreeMeshCaster final : public RayCaster {
 public:
  ~EmbreeMeshCaster() override {
    if (scene_) rtcReleaseScene(scene_);
    if (device_) rtcReleaseDevice(device_);
  }

  Status build(const Scan& mesh) {
    device_ = rtcNewDevice(nullptr);
    if (!device_) return internalError("Embree: cannot create a device (error {})", static_cast<int>(rtcGetDeviceError(nullptr)));
    rtcSetDeviceErrorFunction(device_, recordEmbreeError, &lastError_);
    scene_ = rtcNewScene(device_);
    rtcSetSceneBuildQuality(scene_, RTC_BUILD_QUALITY_HIGH);
    RTCGeometry geometry = rtcNewGeometry(device_, RTC_GEOMETRY_TYPE_TRIANGLE);
    // Embree may read 16 bytes at the last vertex: one float of padding.
    auto* vertices = static_cast<float*>(rtcSetNewGeometryBuffer(
        geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), mesh.points.size() + 1));
    auto* indices = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
        geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), mesh.triangles.size()));
    if (!vertices || !indices) {
      rtcReleaseGeometry(geometry);
      return internalError("Embree: cannot allocate buffers: {}", lastError_);
    }
    for (std::size_t i = 0; i < mesh.points.size(); ++i)
      for (int c = 0; c < 3; ++c) vertices[3 * i + c] = mesh.points.positions[i][c];
    for (int c = 0; c < 3; ++c) vertices[3 * mesh.points.size() + c] = 0.0f;
    for (std::size_t i = 0; i < mesh.triangles.size(); ++i)
      for (int c = 0; c < 3; ++c) indices[3 * i + c] = mesh.triangles[i][c];
    rtcCommitGeometry(geometry);
    rtcAttachGeometry(scene_, geometry);
    rtcReleaseGeometry(geometry);
    rtcCommitScene(scene_);
    if (!lastError_.empty()) return internalError("{}", lastError_);
    return okStatus();
  }

  void intersect(const std::vector<Ray>& rays, std::vector<RayHit>& hits) const override {
    hits.assign(rays.size(), RayHit{});
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    for (std::size_t i = 0; i < rays.size(); ++i) {
      RTCRayHit query{};
      const Ray& ray = rays[i];
      query.ray.org_x = ray.origin.x();
      query.ray.org_y = ray.origin.y();
      query.ray.org_z = ray.origin.z();
      query.ray.dir_x = ray.direction.x();
      query.ray.dir_y = ray.direction.y();
      query.ray.dir_z = ray.direction.z();
      query.ray.tnear = ray.tNear;
      query.ray.tfar = ray.tFar;
      query.ray.mask = ~0u;
      query.hit.geomID = RTC_INVALID_GEOMETRY_ID;
      rtcIntersect1(scene_, &context, &query);
      if (query.hit.geomID == RTC_INVALID_GEOMETRY_ID) continue;
      RayHit& hit = hits[i];
      hit.primitive = query.hit.primID;
      hit.t = query.ray.tfar;
      hit.u = query.hit.u;
      hit.v = query.hit.v;
      hit.geometricNormal = Vec3f(query.hit.Ng_x, query.hit.Ng_y, query.hit.Ng_z);
    }
  }

 private:
  RTCDevice device_ = nullptr;
  RTCScene scene_ = nullptr;
  std::string lastError_;
};

}  // namespace

Result<std::unique_ptr<RayCaster>> makeEmbreeMeshCaster(const Scan& mesh) {
  if (!mesh.isMesh()) return badInput("ray casting needs a triangle mesh, got {} points and no triangles", mesh.points.size());
  auto caster = std::make_unique<EmbreeMeshCaster>();
  APO_RETURN_IF_ERROR(caster->build(mesh));
  return std::unique_ptr<RayCaster>(std::move(caster));
}

}  // namespace apo
