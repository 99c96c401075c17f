// Embree's own options on one mesh, as the bake uses Embree: the BVH's build
// and rays from the triangles' centres along their normals, both ways, in the
// mesh's order (about one ray per triangle, as the bake's sampling casts).
// Prints the CPU seconds of each (process CPU time, so the threads Embree
// builds with are counted) and the hits, for each variant:
//   sah        binned SAH (RTC_BUILD_QUALITY_MEDIUM), robust: the default caster
//   morton     Morton codes (low quality on the scene and the geometry), robust:
//              the bake's caster of M
//   sah-fast   binned SAH without the robust flag (rays may slip between triangles)
//   morton-compact  Morton codes, robust, RTC_SCENE_FLAG_COMPACT
// Usage: embree_options MESH [THREADS] [REPEATS] [VARIANT] (VARIANT: that one only)
#include "core/geometry.h"
#include "ingest/ingest.h"

#include <embree3/rtcore.h>
#include <fmt/format.h>

#include <time.h>

#include <algorithm>
#include <cstdlib>
#include <iterator>
#include <string>
#include <vector>

namespace {

double cpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

struct Variant {
  const char* name;
  RTCBuildQuality quality;
  RTCSceneFlags flags;
};

std::vector<RTCRayHit> raysFromCentres(const apo::Scan& mesh, float reach) {
  std::vector<RTCRayHit> rays;
  rays.reserve(2 * mesh.triangles.size());
  for (const float sign : {1.0f, -1.0f})
    for (const apo::Triangle& t : mesh.triangles) {
      const auto& p = mesh.points.positions;
      const apo::Vec3f centre = (p[t[0]] + p[t[1]] + p[t[2]]) / 3.0f;
      const apo::Vec3f normal = (p[t[1]] - p[t[0]]).cross(p[t[2]] - p[t[0]]).normalized();
      // From just off the surface back through it, as a sample's ray from m.
      const apo::Vec3f origin = centre + sign * 0.25f * reach * normal;
      RTCRayHit ray{};
      ray.ray.org_x = origin.x();
      ray.ray.org_y = origin.y();
      ray.ray.org_z = origin.z();
      ray.ray.dir_x = -sign * normal.x();
      ray.ray.dir_y = -sign * normal.y();
      ray.ray.dir_z = -sign * normal.z();
      ray.ray.tfar = reach;
      ray.ray.mask = ~0u;
      ray.hit.geomID = RTC_INVALID_GEOMETRY_ID;
      rays.push_back(ray);
    }
  return rays;
}

void measure(const apo::Scan& mesh, const Variant& variant, const std::string& config, float reach) {
  RTCDevice device = rtcNewDevice(config.c_str());
  RTCScene scene = rtcNewScene(device);
  rtcSetSceneBuildQuality(scene, variant.quality);
  rtcSetSceneFlags(scene, variant.flags);
  RTCGeometry geometry = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
  rtcSetGeometryBuildQuality(geometry, variant.quality);
  auto* vertices = static_cast<float*>(rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                               3 * sizeof(float), mesh.points.size() + 1));
  auto* indices = static_cast<unsigned*>(rtcSetNewGeometryBuffer(geometry, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                                 3 * sizeof(unsigned), mesh.triangles.size()));
  for (std::size_t i = 0; i < mesh.points.size(); ++i)
    for (int c = 0; c < 3; ++c) vertices[3 * i + c] = mesh.points.positions[i][c];
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i)
    for (int c = 0; c < 3; ++c) indices[3 * i + c] = mesh.triangles[i][c];
  rtcCommitGeometry(geometry);
  rtcAttachGeometry(scene, geometry);
  rtcReleaseGeometry(geometry);
  const double beforeBuild = cpuSeconds();
  rtcCommitScene(scene);
  const double build = cpuSeconds() - beforeBuild;

  std::vector<RTCRayHit> rays = raysFromCentres(mesh, reach);
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  context.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
  const double beforeRays = cpuSeconds();
  rtcIntersect1M(scene, &context, rays.data(), static_cast<unsigned>(rays.size()), sizeof(RTCRayHit));
  const double cast = cpuSeconds() - beforeRays;
  std::size_t hits = 0;
  for (const RTCRayHit& ray : rays) hits += ray.hit.geomID != RTC_INVALID_GEOMETRY_ID;
  fmt::print("{:<15} build {:.3f} s  rays {:.3f} s  ({} rays, {} hits)\n", variant.name, build, cast, rays.size(), hits);
  rtcReleaseScene(scene);
  rtcReleaseDevice(device);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    fmt::print(stderr, "usage: embree_options MESH [THREADS] [REPEATS] [VARIANT]\n");
    return 2;
  }
  auto mesh = apo::readScan(argv[1]);
  if (!mesh || !mesh->isMesh()) {
    fmt::print(stderr, "{}: {}\n", argv[1], mesh ? "not a triangle mesh" : mesh.error().message);
    return 1;
  }
  const int threads = argc > 2 ? std::atoi(argv[2]) : 1;
  const int repeats = argc > 3 ? std::atoi(argv[3]) : 3;
  const std::string only = argc > 4 ? argv[4] : "";
  const std::string config = fmt::format("threads={}", threads);
  const float reach = 0.01f * apo::boundingBox(mesh->points.positions).diagonal();
  const Variant variants[] = {
      {"sah", RTC_BUILD_QUALITY_MEDIUM, RTC_SCENE_FLAG_ROBUST},
      {"morton", RTC_BUILD_QUALITY_LOW, RTC_SCENE_FLAG_ROBUST},
      {"sah-fast", RTC_BUILD_QUALITY_MEDIUM, RTC_SCENE_FLAG_NONE},
      {"morton-compact", RTC_BUILD_QUALITY_LOW, static_cast<RTCSceneFlags>(RTC_SCENE_FLAG_ROBUST | RTC_SCENE_FLAG_COMPACT)},
  };
  if (!only.empty() && std::none_of(std::begin(variants), std::end(variants), [&](const Variant& v) { return only == v.name; })) {
    fmt::print(stderr, "unknown variant '{}': sah, morton, sah-fast or morton-compact\n", only);
    return 2;
  }
  fmt::print("{}: {} triangles, {} thread(s), CPU seconds\n", argv[1], mesh->triangles.size(), threads);
  for (int r = 0; r < repeats; ++r)
    for (const Variant& variant : variants)
      if (only.empty() || only == variant.name) measure(*mesh, variant, config, reach);
  return 0;
}
