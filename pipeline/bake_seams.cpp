#include "pipeline/bake_seams.h"

#include "adapters/embree/embree_ray_caster.h"
#include "adapters/flann/flann_search.h"
#include "core/timing.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <tbb/task_group.h>

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace apo {
namespace {

// M's ray caster built on a TBB task beside the bake: rays are cast on M only
// once the octree is built (the sampling), so Embree's BVH (0.45 s of the
// 1.2M-triangle bunny's 4 s) is built while the projection onto m and the
// octree's serial rounds leave a core idle. With one thread the task runs
// when the sampling first waits on it, as before.
class CasterBuiltAside final : public RayCaster {
 public:
  using Make = std::function<Result<std::unique_ptr<RayCaster>>()>;

  explicit CasterBuiltAside(Make make) {
    building_.run([this, make = std::move(make)] { built_.emplace(make()); });
  }
  // A failed build was reported by ready(), or the bake failed before it.
  ~CasterBuiltAside() noexcept override {
    try {
      building_.wait();
    } catch (...) {
    }
  }

  Status ready() const override {
    building_.wait();
    if (!built_->ok()) return built_->error();
    return (**built_)->ready();
  }
  void intersect(const std::vector<Ray>& rays, std::vector<RayHit>& hits) const override {
    (**built_)->intersect(rays, hits);
  }

 private:
  mutable tbb::task_group building_;
  std::optional<Result<std::unique_ptr<RayCaster>>> built_;
};

// M's caster and closest-point finder. A mesh: its triangles, and the
// finder built on its first query (the rays rarely miss M). Points: a disc
// per point whose area is the point's share of the surface, the radii and
// the finder from one k-d tree (a second tree over 2M points cost 0.3 s,
// for 54 samples whose rays missed every disc); the metric needs the radii
// (the points' areas) before the build, the discs only the sampling.
struct DetailSearch {
  std::unique_ptr<RayCaster> caster;
  std::unique_ptr<ClosestPointFinder> closest;
};

// Builds the caster aside, logging how long it took.
std::unique_ptr<RayCaster> casterBuiltAside(std::string what, CasterBuiltAside::Make make) {
  return std::make_unique<CasterBuiltAside>([what = std::move(what), make = std::move(make)] {
    const Stopwatch building;
    auto caster = make();
    spdlog::info("bake: M's ray caster ({}) built in {:.2f} s, beside the octree", what, building.seconds());
    return caster;
  });
}

Result<DetailSearch> detailSearch(const Scan& M, DetailSurface& surface) {
  if (M.isMesh()) {
    auto closest = makeFlannClosestPointOnDemand(M);
    if (!closest) return closest.error();
    return DetailSearch{casterBuiltAside(fmt::format("Embree BVH over {} triangles", M.triangles.size()),
                                         [&M] { return makeEmbreeMeshCaster(M); }),
                        std::move(closest).value()};
  }
  const Stopwatch radii;
  auto points = makeFlannPointsSearch(M.points);
  if (!points) return points.error();
  spdlog::info("bake: disc radii of {} points (FLANN k-d tree, nearest neighbours) in {:.2f} s", M.points.size(),
               radii.seconds());
  for (const float r : points->radii) surface.pointAreas.push_back(r * r);
  auto caster = casterBuiltAside(fmt::format("Embree BVH over {} discs", M.points.size()),
                                 [&M, radii = std::move(points->radii)] { return makeEmbreeDiscCaster(M.points, radii); });
  return DetailSearch{std::move(caster), std::move(points->closest)};
}

}  // namespace

Result<Bake> bakeApo(const Scan& detail, const Scan& coarse, const BakeOptions& options, const ProgressCallback& onProgress) {
  APO_RETURN_IF_ERROR(validateBakeOptions(options));
  Stopwatch setup;
  // M as given, or a copy with vertex normals when a mesh has none (a copy
  // of 2M points costs the bake 0.1 s for nothing otherwise).
  Scan withNormals;
  const bool needsNormals = detail.isMesh() && detail.points.normals.size() != detail.points.size();
  if (needsNormals) {
    withNormals = detail;
    withNormals.points.normals = areaWeightedVertexNormals(withNormals);
  }
  const Scan& M = needsNormals ? withNormals : detail;
  if (!M.isMesh() && !M.points.hasNormals())
    return badInput("the detail points have no normals: run `apo ingest` first, which estimates and orients them");
  APO_RETURN_IF_ERROR(validateBakeInputs(M, coarse));

  DetailSurface surface;
  surface.detail = &M;
  auto search = detailSearch(M, surface);
  if (!search) return search.error();
  auto coarseCaster = makeEmbreeMeshCaster(coarse);
  if (!coarseCaster) return coarseCaster.error();
  surface.caster = search->caster.get();
  surface.closest = search->closest.get();
  const double setupSeconds = setup.seconds();

  auto bake = bakeWith(surface, {&coarse, coarseCaster->get()}, options, onProgress);
  if (!bake) return bake;
  bake->report.seconds.setup += setupSeconds;
  bake->report.totalSeconds += setupSeconds;
  return bake;
}

Result<std::unique_ptr<ClosestPointFinder>> meshClosestPoint(const Scan& mesh) {
  if (!mesh.isMesh()) return badInput("a closest point with its normal needs a triangle mesh, not points");
  Scan withNormals = mesh;
  if (withNormals.points.normals.size() != withNormals.points.size())
    withNormals.points.normals = areaWeightedVertexNormals(withNormals);
  return makeEmbreeClosestPoint(withNormals);
}

Result<std::vector<Vec3f>> coarseNormalsAt(const Scan& coarse, const std::vector<Vec3f>& points) {
  // Exact (Embree's point query): across a part thinner than m's triangles,
  // the nearest vertices may lie on the other side.
  auto closest = meshClosestPoint(coarse);
  if (!closest) return closest.error();
  std::vector<Vec3f> normals(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    const std::optional<SurfacePoint> found = (*closest)->closest(points[i]);
    if (!found) return internalError("the closest-point search over m failed");
    normals[i] = found->normal;
  }
  return normals;
}

}  // namespace apo
