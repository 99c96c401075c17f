#include "pipeline/bake_seams.h"

#include "adapters/embree/embree_ray_caster.h"
#include "adapters/flann/flann_search.h"
#include "core/file_io.h"
#include "core/timing.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <tbb/task_group.h>

#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace apo {
namespace {

// faceOrderSpread beyond which M's triangles are taken in Morton order.
// Measured: meshes in subdivision or reconstruction order 0.5-6 (the 1.2M
// bunny 0.92, the 7.2M torus 0.50, advancing front's M of
// table_scene_lms400 0.59, an icosphere's subdivision 5.7), the bundled
// CGAL meshes 1-46 (armadillo and diplodocus 46, bunny00 14), the 1.2M
// bunny shuffled 288. Only the last was measured to pay
// (docs/benchmarks.md): the line is kept well above the files as found.
constexpr double kShuffledFaceOrder = 100.0;

// A search structure built on a TBB task beside the bake, waited on only by
// the thread that started it (the bake's): with one thread, the task runs at
// that wait. `what` names it in the log line giving its time.
template <class T>
class BuiltAside {
 public:
  void start(std::string what, std::function<Result<T>()> make) {
    building_.run([this, what = std::move(what), make = std::move(make)] {
      const Stopwatch building;
      built_.emplace(make());
      spdlog::info("bake: {} built in {:.2f} s, beside the bake", what, building.seconds());
    });
  }
  // A failure was reported by ready(), or the bake failed before it.
  ~BuiltAside() noexcept {
    try {
      building_.wait();
    } catch (...) {
    }
  }

  Status ready() const {
    building_.wait();
    if (!built_) return internalError("bake: a search structure over M was never started");
    if (!built_->ok()) return built_->error();
    return okStatus();
  }
  const T& get() const { return **built_; }  // after ready()

 private:
  mutable tbb::task_group building_;
  std::optional<Result<T>> built_;
};

// M's ray caster, built when the bake first asks for it (ready(), before
// the sampling's first ray: only the sampling casts rays on M). By then the
// octree's build has freed what it held (M's records for the metric, the
// candidates' lists), and Embree's BVH takes that memory again. Built beside
// the octree, as it was, the BVH raised the 1.2M bunny's peak from 458 to
// 585 MB and the 7.2M torus's from 1.43 to 2.18 GB, and that fresh memory
// cost more wall time than the build now adds, alone on every core
// (docs/bake.md, "A faster build").
class CasterBuiltWhenAsked final : public RayCaster {
 public:
  void prepare(std::string what, std::function<Result<std::unique_ptr<RayCaster>>()> make) {
    what_ = "M's ray caster (" + what + ")";
    make_ = std::move(make);
  }
  // On the bake's thread only, as bakeWith calls it.
  Status ready() const override {
    if (!built_) {
      if (!make_) return internalError("bake: M's ray caster was asked for before it was prepared");
      const Stopwatch building;
      built_.emplace(make_());
      spdlog::info("bake: {} built in {:.2f} s", what_, building.seconds());
    }
    if (!built_->ok()) return built_->error();
    return built_->value()->ready();
  }
  void intersect(const std::vector<Ray>& rays, std::vector<RayHit>& hits) const override {
    built_->value()->intersect(rays, hits);
  }

 private:
  std::string what_;
  std::function<Result<std::unique_ptr<RayCaster>>()> make_;
  mutable std::optional<Result<std::unique_ptr<RayCaster>>> built_;
};

// A point scan's k-d tree (nanoflann: the discs' radii, and the closest point
// where both rays of a sample miss every disc) built beside the bake from the
// start: the bake projects M's points onto m meanwhile, and needs the radii
// only after that, to weigh the points (the tree's build is serial: 0.3 s
// of the 2M points' bake, now beside the projection's rays).
class PointsSearchAside final : public ClosestPointFinder {
 public:
  explicit PointsSearchAside(const PointSet& points) {
    aside_.start(fmt::format("the disc radii of {} points (nanoflann k-d tree, nearest neighbours)", points.size()),
                 [&points] { return makeFlannPointsSearch(points); });
  }
  Status ready() const override { return aside_.ready(); }
  const std::vector<float>& radii() const { return aside_.get().radii; }  // after ready()
  std::optional<SurfacePoint> closest(const Vec3f& query) const override { return aside_.get().closest->closest(query); }

 private:
  BuiltAside<PointsSearch> aside_;
};

// M's caster and closest-point finder. A mesh: its triangles' BVH built
// when the sampling asks, and the finder built on its first query (the rays
// rarely miss M). Points: a disc per point whose area is the point's share
// of the surface, the radii and the finder from one k-d tree built beside
// the bake from the start (a second tree over 2M points cost 0.3 s, for 54
// samples whose rays missed every disc); the discs' BVH is prepared once the
// radii are known, when the bake asks for the points' areas
// (DetailSurface::awaitPointAreas), and built when the sampling asks.
struct DetailSearch {
  std::unique_ptr<ClosestPointFinder> closest;
  // After `closest`, so destroyed first: the discs' builder reads the radii `closest` holds.
  std::unique_ptr<CasterBuiltWhenAsked> caster = std::make_unique<CasterBuiltWhenAsked>();
};

Result<DetailSearch> detailSearch(const Scan& M, DetailSurface& surface) {
  DetailSearch search;
  if (M.isMesh()) {
    auto closest = makeFlannClosestPointOnDemand(M);
    if (!closest) return closest.error();
    search.closest = std::move(closest).value();
    // About one ray per triangle of M: the BVH's build costs more than the
    // rays lose to a quicker one's lower quality.
    search.caster->prepare(fmt::format("Embree BVH over {} triangles", M.triangles.size()),
                           [&M] { return makeQuickBuiltEmbreeMeshCaster(M); });
    return search;
  }
  auto points = std::make_unique<PointsSearchAside>(M.points);
  // Called by the bake on its own thread, the only one that waits on either task.
  surface.awaitPointAreas = [&M, &surface, points = points.get(), caster = search.caster.get()]() -> Status {
    APO_RETURN_IF_ERROR(points->ready());
    surface.pointAreas.clear();
    for (const float r : points->radii()) surface.pointAreas.push_back(r * r);
    caster->prepare(fmt::format("Embree BVH over {} discs", M.points.size()),
                    [&M, points] { return makeEmbreeDiscCaster(M.points, points->radii()); });
    return okStatus();
  };
  search.closest = std::move(points);
  return search;
}

}  // namespace

BrickedPoints brickedPoints(std::uint64_t count, std::function<Result<PointSet>(const Aabb& box)> pointsIn) {
  BrickedPoints source;
  source.count = count;
  source.pointsIn = std::move(pointsIn);
  source.areasOf = [](const PointSet& points) -> Result<std::vector<float>> {
    auto radii = discRadii(points);
    if (!radii) return radii.error();
    for (float& r : *radii) r *= r;
    return radii;
  };
  source.searchOver = [](const PointSet& points) -> Result<BrickSearch> {
    auto search = makeFlannPointsSearch(points);
    if (!search) return search.error();
    auto caster = makeEmbreeDiscCaster(points, search->radii);
    if (!caster) return caster.error();
    BrickSearch brick{std::move(caster).value(), std::move(search->closest), std::move(search->radii)};
    for (float& r : brick.areas) r *= r;
    return brick;
  };
  return source;
}

BrickJournal brickJournalIn(const std::filesystem::path& folder) {
  BrickJournal journal;
  journal.read = [folder](const std::string& name) -> Result<std::optional<std::string>> {
    std::error_code error;
    if (!std::filesystem::exists(folder / name, error)) return std::optional<std::string>{};
    auto bytes = readFileBytes(folder / name);
    if (!bytes) return bytes.error();
    return std::optional<std::string>{std::move(bytes).value()};
  };
  journal.write = [folder](const std::string& name, const std::string& bytes) {
    return writeFileAtomically(folder / name, bytes);
  };
  return journal;
}

// M's points held in memory, served a box at a time to the bake in bricks.
BrickedPoints pointsInMemory(const Scan& M) {
  return brickedPoints(M.points.size(), [&M](const Aabb& box) -> Result<PointSet> {
    PointSet inside;
    for (std::size_t i = 0; i < M.points.size(); ++i) {
      const Vec3f& p = M.points.positions[i];
      if ((p.array() < box.min.array()).any() || (p.array() > box.max.array()).any()) continue;
      inside.positions.push_back(p);
      inside.normals.push_back(M.points.normals[i]);
    }
    return inside;
  });
}

Result<Bake> bakeApoInBricks(const BrickedPoints& detail, const Scan& coarse, const Checked<BakeOptions>& options,
                             const ProgressCallback& onProgress) {
  auto coarseCaster = makeEmbreeMeshCaster(coarse);
  if (!coarseCaster) return coarseCaster.error();
  return bakeInBricks(detail, {&coarse, coarseCaster->get()}, options, onProgress);
}

Result<Bake> bakeApo(const Scan& detail, const Scan& coarse, const Checked<BakeOptions>& options,
                     const ProgressCallback& onProgress) {
  Stopwatch setup;
  // M as given, or a copy with vertex normals when a mesh has none (a copy
  // of 2M points costs the bake 0.1 s for nothing otherwise), or with its
  // triangles in Morton order when the list follows no order in space
  // (shuffled by some tool): the error metric reads M's triangles cell by
  // cell and the rays go out in M's order, and the 1.2M bunny shuffled took
  // 20% longer (docs/bake.md, "A faster build").
  const double spread = faceOrderSpread(detail);
  const bool needsNormals = detail.isMesh() && detail.points.normals.size() != detail.points.size();
  const bool reorder = spread > kShuffledFaceOrder;
  Scan copy;
  if (needsNormals || reorder) {
    copy = detail;
    if (needsNormals) copy.points.normals = areaWeightedVertexNormals(copy);  // in the file's order, as without
    if (reorder) {
      copy.triangles = trianglesInMortonOrder(copy);
      spdlog::info("bake: M's consecutive triangles lie {:.0f} edges apart (median): baked in Morton order", spread);
    }
  }
  const Scan& M = needsNormals || reorder ? copy : detail;
  if (!M.isMesh() && !M.points.hasNormals())
    return badInput("the detail points have no normals: run `apo ingest` first, which estimates and orients them");
  APO_RETURN_IF_ERROR(validateBakeInputs(M, coarse));
  if (options->brickDepth > 0 && !M.isMesh()) return bakeApoInBricks(pointsInMemory(M), coarse, options, onProgress);
  if (options->brickDepth > 0)
    spdlog::info("bake: M is a mesh, baked in one piece (--brick-depth {} bakes points brick by brick)",
                 options->brickDepth);

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
  bake->report.detailFaceOrderSpread = spread;
  bake->report.detailFacesReordered = reorder;
  bake->report.seconds.setup += setupSeconds;
  bake->report.totalSeconds += setupSeconds;
  return bake;
}

Result<std::unique_ptr<ClosestPointFinder>> meshClosestPoint(Scan mesh) {
  if (!mesh.isMesh()) return badInput("a closest point with its normal needs a triangle mesh, not points");
  addVertexNormalsIfMissing(mesh);
  return makeEmbreeClosestPoint(std::move(mesh));
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
