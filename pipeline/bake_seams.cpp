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

// Waits for a task building a search structure, from its owner's destructor:
// a failure was reported by the owner's ready(), or the bake failed before.
void finishBuilding(tbb::task_group& building) noexcept {
  try {
    building.wait();
  } catch (...) {
  }
}

// M's ray caster built on a TBB task beside the bake: rays are cast on M only
// once the octree is built (the sampling), so Embree's BVH (0.45 s of the
// 1.2M-triangle bunny's 4 s) is built while the projection onto m and the
// octree's serial rounds leave a core idle. With one thread the task runs
// when the sampling first waits on it, as before. Only the thread that
// starts it waits on it (the bake's).
class CasterBuiltAside final : public RayCaster {
 public:
  using Make = std::function<Result<std::unique_ptr<RayCaster>>()>;

  // Starts the build, logging how long it took as `what`.
  void start(std::string what, Make make) {
    building_.run([this, what = std::move(what), make = std::move(make)] {
      const Stopwatch building;
      built_.emplace(make());
      spdlog::info("bake: M's ray caster ({}) built in {:.2f} s, beside the octree", what, building.seconds());
    });
  }
  ~CasterBuiltAside() noexcept override { finishBuilding(building_); }

  Status ready() const override {
    building_.wait();
    if (!built_) return internalError("bake: M's ray caster was never started");
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

// A point scan's k-d tree (FLANN: the discs' radii, and the closest point
// where both rays of a sample miss every disc) built on a TBB task from the
// start: the bake projects M's points onto m meanwhile, and needs the radii
// only after that, to weigh the points (the tree's build is serial: 0.3 s
// of the 2M points' bake, now beside the projection's rays).
class PointsSearchAside final : public ClosestPointFinder {
 public:
  explicit PointsSearchAside(const PointSet& points) {
    building_.run([this, &points] {
      const Stopwatch radii;
      built_.emplace(makeFlannPointsSearch(points));
      spdlog::info("bake: disc radii of {} points (FLANN k-d tree, nearest neighbours) in {:.2f} s", points.size(),
                   radii.seconds());
    });
  }
  ~PointsSearchAside() noexcept override { finishBuilding(building_); }

  Status ready() const override {
    building_.wait();
    if (!built_->ok()) return built_->error();
    return okStatus();
  }
  // After ready().
  const std::vector<float>& radii() const { return (*built_)->radii; }
  std::optional<SurfacePoint> closest(const Vec3f& query) const override { return (*built_)->closest->closest(query); }

 private:
  mutable tbb::task_group building_;
  std::optional<Result<PointsSearch>> built_;
};

// M's caster and closest-point finder, both made beside the bake. A mesh:
// its triangles, and the finder built on its first query (the rays rarely
// miss M). Points: a disc per point whose area is the point's share of the
// surface, the radii and the finder from one k-d tree (a second tree over 2M
// points cost 0.3 s, for 54 samples whose rays missed every disc); the
// discs' BVH starts once the radii are known, when the bake asks for the
// points' areas (DetailSurface::awaitPointAreas).
struct DetailSearch {
  std::unique_ptr<ClosestPointFinder> closest;
  // After `closest`, so destroyed first: the discs' build reads the radii.
  std::unique_ptr<CasterBuiltAside> caster = std::make_unique<CasterBuiltAside>();
};

Result<DetailSearch> detailSearch(const Scan& M, DetailSurface& surface) {
  DetailSearch search;
  if (M.isMesh()) {
    auto closest = makeFlannClosestPointOnDemand(M);
    if (!closest) return closest.error();
    search.closest = std::move(closest).value();
    search.caster->start(fmt::format("Embree BVH over {} triangles", M.triangles.size()),
                         [&M] { return makeEmbreeMeshCaster(M); });
    return search;
  }
  auto points = std::make_unique<PointsSearchAside>(M.points);
  // Called by the bake on its own thread, the only one that waits on either task.
  surface.awaitPointAreas = [&M, &surface, points = points.get(), caster = search.caster.get()]() -> Status {
    APO_RETURN_IF_ERROR(points->ready());
    surface.pointAreas.clear();
    for (const float r : points->radii()) surface.pointAreas.push_back(r * r);
    caster->start(fmt::format("Embree BVH over {} discs", M.points.size()),
                  [&M, points] { return makeEmbreeDiscCaster(M.points, points->radii()); });
    return okStatus();
  };
  search.closest = std::move(points);
  return search;
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
