// Embree 3 implementations of RayCaster: triangle meshes and oriented discs
// around points (the bake's point-cloud detail surface). Both share one
// scene owner and one intersect loop; only the geometry buffers differ.
#include "adapters/embree/embree_ray_caster.h"

#include "core/triangle_geometry.h"

#include <embree3/rtcore.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <string>
#include <utility>

namespace apo {
namespace {

void recordEmbreeError(void* userPtr, RTCError code, const char* message) {
  auto* last = static_cast<std::string*>(userPtr);
  *last = fmt::format("Embree error {}: {}", static_cast<int>(code), message ? message : "");
}

// Fills the buffers of a fresh geometry; false when Embree could not allocate one.
using FillGeometry = std::function<bool(RTCGeometry)>;

// One Embree scene holding one geometry. intersect() is const and safe to call
// from several threads at once: rtcIntersect1 only reads a committed scene,
// and the intersect context lives on each call's stack.
class EmbreeCaster final : public RayCaster {
 public:
  ~EmbreeCaster() override {
    if (scene_) rtcReleaseScene(scene_);
    if (device_) rtcReleaseDevice(device_);
  }

  // `streams`: rays go to Embree as coherent streams (rtcIntersect1M),
  // whose packets make a ray's hit depend, in its last bits, on the rays
  // beside it; otherwise one at a time, each hit a function of its ray
  // alone, which the bake in bricks needs (its rays come in other batches
  // than the one-piece bake's, docs/bake.md "Bricks"). Streams pay only on
  // M's triangles: the bumpy bunny's sampling 0.17 s against 0.24 s one at
  // a time; on discs and m, nothing measurable.
  Status build(RTCGeometryType type, const FillGeometry& fill, bool quickBuild = false, bool streams = false) {
    streams_ = streams;
    device_ = rtcNewDevice(nullptr);
    if (!device_) return internalError("Embree: cannot create a device (error {})", static_cast<int>(rtcGetDeviceError(nullptr)));
    rtcSetDeviceErrorFunction(device_, recordEmbreeError, &lastError_);
    scene_ = rtcNewScene(device_);
    // Medium (binned SAH) builds 1M triangles several times faster than high
    // (spatial splits) and traces our short rays about as fast. Low (a
    // Morton-code build) is faster still: the geometry's quality counts only
    // in a scene built at low quality, so both are set (docs/benchmarks.md).
    rtcSetSceneBuildQuality(scene_, quickBuild ? RTC_BUILD_QUALITY_LOW : RTC_BUILD_QUALITY_MEDIUM);
    // Watertight triangle tests: rays from m's edges and vertices meet M's
    // shared edges there (the paper's closest-point origins often lie on them).
    rtcSetSceneFlags(scene_, RTC_SCENE_FLAG_ROBUST);
    RTCGeometry geometry = rtcNewGeometry(device_, type);
    if (!geometry) return internalError("Embree: cannot create a geometry: {}", lastError_);
    if (quickBuild) rtcSetGeometryBuildQuality(geometry, RTC_BUILD_QUALITY_LOW);
    if (!fill(geometry)) {
      rtcReleaseGeometry(geometry);
      return internalError("Embree: cannot allocate buffers: {}", lastError_);
    }
    rtcCommitGeometry(geometry);
    rtcAttachGeometry(scene_, geometry);
    rtcReleaseGeometry(geometry);
    rtcCommitScene(scene_);
    // After the build no callback may write lastError_: intersect() runs on
    // several threads and must not share a mutable string.
    rtcSetDeviceErrorFunction(device_, nullptr, nullptr);
    if (!lastError_.empty()) return internalError("{}", lastError_);
    return okStatus();
  }

  void intersect(const std::vector<Ray>& rays, std::vector<RayHit>& hits) const override {
    hits.assign(rays.size(), RayHit{});
    RTCIntersectContext context;
    rtcInitIntersectContext(&context);
    context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    // In batches: Embree's stream call takes an unsigned count and crashed
    // beyond about 27 million rays at once (a 100-million-point simulated
    // scan's view); a batch's queries also stay small.
    std::vector<RTCRayHit> queries;
    for (std::size_t begin = 0; begin < rays.size(); begin += kBatchRays) {
      const std::size_t end = std::min(rays.size(), begin + kBatchRays);
      queries.resize(end - begin);
      for (std::size_t i = begin; i < end; ++i) queries[i - begin] = embreeQuery(rays[i]);
      if (streams_) {
        rtcIntersect1M(scene_, &context, queries.data(), static_cast<unsigned>(queries.size()), sizeof(RTCRayHit));
      } else {
        for (RTCRayHit& query : queries) rtcIntersect1(scene_, &context, &query);
      }
      for (std::size_t i = begin; i < end; ++i) {
        const RTCRayHit& query = queries[i - begin];
        if (query.hit.geomID == RTC_INVALID_GEOMETRY_ID) continue;
        RayHit& hit = hits[i];
        hit.primitive = query.hit.primID;
        hit.t = query.ray.tfar;
        hit.u = query.hit.u;  // triangles: barycentrics; discs: Embree reports 0
        hit.v = query.hit.v;
        hit.geometricNormal = Vec3f(query.hit.Ng_x, query.hit.Ng_y, query.hit.Ng_z);
      }
    }
  }

 private:
  static constexpr std::size_t kBatchRays = std::size_t{1} << 20;

  static RTCRayHit embreeQuery(const Ray& ray) {
    RTCRayHit query{};
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
    return query;
  }

  friend class EmbreeClosestPoint;
  RTCDevice device_ = nullptr;
  RTCScene scene_ = nullptr;
  bool streams_ = false;
  std::string lastError_;
};


bool fillTriangles(RTCGeometry geometry, const std::vector<Vec3f>& positions, const std::vector<Triangle>& triangles) {
  // Embree may read 16 bytes at the last vertex: one float of padding.
  auto* vertices = static_cast<float*>(rtcSetNewGeometryBuffer(
      geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), positions.size() + 1));
  auto* indices = static_cast<unsigned*>(rtcSetNewGeometryBuffer(
      geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), triangles.size()));
  if (!vertices || !indices) return false;
  for (std::size_t i = 0; i < positions.size(); ++i)
    for (int c = 0; c < 3; ++c) vertices[3 * i + c] = positions[i][c];
  for (int c = 0; c < 3; ++c) vertices[3 * positions.size() + c] = 0.0f;
  for (std::size_t i = 0; i < triangles.size(); ++i)
    for (int c = 0; c < 3; ++c) indices[3 * i + c] = triangles[i][c];
  return true;
}

bool fillDiscs(RTCGeometry geometry, const PointSet& points, const std::vector<float>& radii) {
  // A point geometry has as many primitives as vertex-buffer items, so no
  // padding item here; none is needed, as (x, y, z, r) items are 16 bytes
  // already. Normals get a 16-byte stride too, so that an SSE load at the
  // last one stays inside its buffer.
  constexpr std::size_t kNormalStride = 4;
  auto* vertices = static_cast<float*>(rtcSetNewGeometryBuffer(
      geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4, 4 * sizeof(float), points.size()));
  auto* normals = static_cast<float*>(rtcSetNewGeometryBuffer(
      geometry, RTC_BUFFER_TYPE_NORMAL, 0, RTC_FORMAT_FLOAT3, kNormalStride * sizeof(float), points.size()));
  if (!vertices || !normals) return false;
  for (std::size_t i = 0; i < points.size(); ++i) {
    for (int c = 0; c < 3; ++c) {
      vertices[4 * i + c] = points.positions[i][c];
      normals[kNormalStride * i + c] = points.normals[i][c];
    }
    vertices[4 * i + 3] = radii[i];
    normals[kNormalStride * i + 3] = 0.0f;
  }
  return true;
}

Status checkDiscInput(const PointSet& points, const std::vector<float>& radii) {
  if (points.size() == 0) return badInput("disc ray casting needs at least one point");
  if (points.normals.size() != points.size())
    return badInput("disc ray casting needs a normal per point: {} points, {} normals", points.size(), points.normals.size());
  if (radii.size() != points.size())
    return badInput("disc ray casting needs a radius per point: {} points, {} radii", points.size(), radii.size());
  for (std::size_t i = 0; i < radii.size(); ++i)
    if (!std::isfinite(radii[i]) || radii[i] <= 0.0f)
      return badInput("disc ray casting: point {} has radius {}, not a finite positive number", i, radii[i]);
  return okStatus();
}

// Point queries over a triangle scene: Embree visits the triangles whose
// boxes meet the query's sphere, the callback shrinks the sphere to each
// closer triangle point. Const and thread-safe like intersect().
class EmbreeClosestPoint final : public ClosestPointFinder {
 public:
  explicit EmbreeClosestPoint(Scan mesh)
      : positions_(std::move(mesh.points.positions)),
        normals_(std::move(mesh.points.normals)),
        triangles_(std::move(mesh.triangles)) {}

  Status build() {
    return scene_.build(RTC_GEOMETRY_TYPE_TRIANGLE, [&](RTCGeometry g) { return fillTriangles(g, positions_, triangles_); });
  }

  std::optional<SurfacePoint> closest(const Vec3f& query) const override {
    Found found{this, query, kNone, {}};
    RTCPointQuery point{};
    point.x = query.x();
    point.y = query.y();
    point.z = query.z();
    point.radius = std::numeric_limits<float>::infinity();
    RTCPointQueryContext context;
    rtcInitPointQueryContext(&context);
    rtcPointQuery(scene_.scene_, &point, &context, visit, &found);
    if (found.triangle == kNone) return std::nullopt;
    const Triangle& t = triangles_[found.triangle];
    const Vec3f& w = found.point.weights;
    const Vec3f n = w[0] * normals_[t[0]] + w[1] * normals_[t[1]] + w[2] * normals_[t[2]];
    return SurfacePoint{found.point.position, n.squaredNorm() > 0.0f ? Vec3f(n.normalized()) : Vec3f(Vec3f::Zero())};
  }

 private:
  static constexpr std::uint32_t kNone = ~0u;
  struct Found {
    const EmbreeClosestPoint* finder;
    Vec3f query;
    std::uint32_t triangle = kNone;
    TrianglePoint point;
  };

  static bool visit(RTCPointQueryFunctionArguments* args) {
    auto* found = static_cast<Found*>(args->userPtr);
    const EmbreeClosestPoint& self = *found->finder;
    const Triangle& t = self.triangles_[args->primID];
    const TrianglePoint point = closestPointOnTriangle(found->query, self.positions_[t[0]], self.positions_[t[1]],
                                                      self.positions_[t[2]]);
    const float distance = std::sqrt(point.squaredDistance);
    // Ties go to the lower triangle index: the answer does not depend on
    // the order Embree visits them in.
    if (distance > args->query->radius ||
        (distance == args->query->radius && found->triangle != kNone && args->primID > found->triangle))
      return false;
    args->query->radius = distance;
    found->triangle = args->primID;
    found->point = point;
    return true;
  }

  std::vector<Vec3f> positions_, normals_;
  std::vector<Triangle> triangles_;
  EmbreeCaster scene_;
};

Result<std::unique_ptr<RayCaster>> meshCaster(const Scan& mesh, bool quickBuild) {
  if (!mesh.isMesh()) return badInput("ray casting needs a triangle mesh, got {} points and no triangles", mesh.points.size());
  return catchLibraryErrors("Embree triangle BVH", [&]() -> Result<std::unique_ptr<RayCaster>> {
    auto caster = std::make_unique<EmbreeCaster>();
    const auto fill = [&](RTCGeometry g) { return fillTriangles(g, mesh.points.positions, mesh.triangles); };
    // The quick build is M's, whose rays are the bake's many: in streams.
    APO_RETURN_IF_ERROR(caster->build(RTC_GEOMETRY_TYPE_TRIANGLE, fill, quickBuild, quickBuild));
    return std::unique_ptr<RayCaster>(std::move(caster));
  });
}

}  // namespace

Result<std::unique_ptr<RayCaster>> makeEmbreeMeshCaster(const Scan& mesh) { return meshCaster(mesh, false); }

Result<std::unique_ptr<RayCaster>> makeQuickBuiltEmbreeMeshCaster(const Scan& mesh) { return meshCaster(mesh, true); }

Result<std::unique_ptr<ClosestPointFinder>> makeEmbreeClosestPoint(Scan mesh) {
  if (!mesh.isMesh()) return badInput("the closest point of a mesh needs triangles, got {} points and none", mesh.points.size());
  if (mesh.points.normals.size() != mesh.points.size())
    return badInput("the closest point of a mesh needs a normal per vertex: {} vertices, {} normals", mesh.points.size(),
                    mesh.points.normals.size());
  return catchLibraryErrors("Embree point query BVH", [&]() -> Result<std::unique_ptr<ClosestPointFinder>> {
    auto finder = std::make_unique<EmbreeClosestPoint>(std::move(mesh));
    APO_RETURN_IF_ERROR(finder->build());
    return std::unique_ptr<ClosestPointFinder>(std::move(finder));
  });
}

Result<std::unique_ptr<RayCaster>> makeEmbreeDiscCaster(const PointSet& points, const std::vector<float>& radii) {
  APO_RETURN_IF_ERROR(checkDiscInput(points, radii));
  return catchLibraryErrors("Embree disc BVH", [&]() -> Result<std::unique_ptr<RayCaster>> {
    auto caster = std::make_unique<EmbreeCaster>();
    APO_RETURN_IF_ERROR(caster->build(RTC_GEOMETRY_TYPE_ORIENTED_DISC_POINT,
                                      [&](RTCGeometry g) { return fillDiscs(g, points, radii); }));
    return std::unique_ptr<RayCaster>(std::move(caster));
  });
}

}  // namespace apo
