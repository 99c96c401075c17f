// The bake of M's points brick by brick (docs/bake.md, "Bricks"). Three
// passes over the bricks, each holding one brick's points at a time:
//   1. the points' areas, for their mean (the metric's unit);
//   2. each brick's octree build over its own points, recording the L2,1
//      errors of its cells; then the whole tree is built from the records,
//      as the one-piece build would build it from M (octree_build.h,
//      ErrorExchange); a brick whose records fall short is built again with
//      more texels;
//   3. each brick's leaves sampled against its points' discs.
#include "bake/bake.h"

#include "bake/bake_steps.h"
#include "bake/cell_clip.h"
#include "bake/l21_metric.h"
#include "bake/sampling.h"
#include "core/timing.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace apo {
namespace {

using octree::Cell;
using octree::CellId;

// A cell of the brick depth holding some of m.
struct Brick {
  CellId id = 0;
  Cell cell;
  std::uint64_t coarseCells = 0;  // of m's coarse cells, those inside it
};

Cell cellOfId(CellId id) {
  const int depth = static_cast<int>(id >> octree::kCellIdDepthShift);
  return octree::gridCell(id & ((CellId{1} << octree::kCellIdDepthShift) - 1), depth);
}

// The bricks, sorted by id: the ancestors of the coarse cells m's triangles
// meet, binned as buildOctree bins them.
std::vector<Brick> bricksHoldingCoarse(const octree::CoarseMesh& m, int coarseDepth, int brickDepth) {
  const auto pairs = octree::binIntoGrid(
      m.triangles.size(), coarseDepth,
      [&](std::uint32_t t) {
        const Triangle& tri = m.triangles[t];
        return octree::triangleBounds(m.positions[tri[0]], m.positions[tri[1]], m.positions[tri[2]]);
      },
      [&](std::uint32_t t, const Cell& cell) {
        const Triangle& tri = m.triangles[t];
        return octree::triangleOverlapsBox(m.positions[tri[0]], m.positions[tri[1]], m.positions[tri[2]], cell);
      });
  std::vector<CellId> coarseCells;
  for (const auto& [key, triangle] : pairs)
    coarseCells.push_back((static_cast<CellId>(coarseDepth) << octree::kCellIdDepthShift) | key);
  std::sort(coarseCells.begin(), coarseCells.end());
  coarseCells.erase(std::unique(coarseCells.begin(), coarseCells.end()), coarseCells.end());
  std::vector<Brick> bricks;
  for (const CellId coarse : coarseCells) {
    const CellId id = octree::ancestorId(coarse, brickDepth);
    const auto at = std::lower_bound(bricks.begin(), bricks.end(), id, [](const Brick& b, CellId i) { return b.id < i; });
    if (at == bricks.end() || at->id != id) {
      bricks.insert(at, Brick{id, cellOfId(id), 1});
    } else {
      ++at->coarseCells;
    }
  }
  return bricks;
}

std::size_t brickIndex(const std::vector<Brick>& bricks, CellId id) {
  return static_cast<std::size_t>(
      std::lower_bound(bricks.begin(), bricks.end(), id, [](const Brick& b, CellId i) { return b.id < i; }) -
      bricks.begin());
}

// A unit-cube box in world coordinates, grown by `margin` (world units);
// `openFaces`: a side on the unit cube's face is opened to infinity (the
// points beyond the cube belong to the cells along its faces).
Aabb worldBoxOf(const Cell& cell, float margin, const UnitCubeTransform& transform, bool openFaces) {
  Aabb box;
  box.extend(transform.toWorld(cell.lower()));
  box.extend(transform.toWorld(cell.upper()));
  const float far = std::numeric_limits<float>::max();
  for (int axis = 0; axis < 3; ++axis) {
    box.min[axis] = openFaces && cell.lower()[axis] <= 0.0f ? -far : box.min[axis] - margin;
    box.max[axis] = openFaces && cell.upper()[axis] >= 1.0f ? far : box.max[axis] + margin;
  }
  return box;
}

// The cell of depth `depth` a point is counted in for the mean area: its
// unit-cube position's, clamped into the cube.
CellId ownerOf(const Vec3f& world, int depth, const UnitCubeTransform& transform) {
  const Vec3f unit = transform.toUnit(world);
  const int cells = 1 << depth;
  std::array<int, 3> xyz{};
  for (int axis = 0; axis < 3; ++axis)
    xyz[axis] = std::clamp(static_cast<int>(std::floor(unit[axis] * static_cast<float>(cells))), 0, cells - 1);
  return (static_cast<CellId>(depth) << octree::kCellIdDepthShift) | octree::gridKey(xyz[0], xyz[1], xyz[2], depth);
}

// What the three passes share.
class BrickBake {
 public:
  BrickBake(const BrickedPoints& source, const CoarseSurface& coarse, const BakeOptions& options,
            const ProgressCallback& onProgress)
      : source_(source), coarse_(coarse), options_(options), onProgress_(onProgress),
        frame_(bake_steps::frameOf(*coarse.mesh, options)),
        bricks_(bricksHoldingCoarse(frame_.coarseUnit, options.coarseDepth, options.brickDepth)) {
    report_.depth = options.brickDepth;
    report_.bricks = bricks_.size();
  }

  // Pass 1: every point's area, counted once, in the cell of the brick
  // depth holding it (bricks or not), among its neighbours within `reach`.
  Result<double> meanArea() {
    const int depth = options_.brickDepth;
    const int cells = 1 << depth;
    bake_steps::OrderFreeSum total;
    std::uint64_t counted = 0;
    for (int x = 0; x < cells; ++x)
      for (int y = 0; y < cells; ++y)
        for (int z = 0; z < cells; ++z) {
          const CellId id = (static_cast<CellId>(depth) << octree::kCellIdDepthShift) | octree::gridKey(x, y, z, depth);
          auto points = load(worldBoxOf(cellOfId(id), frame_.reach, frame_.transform, true));
          if (!points) return points.error();
          std::vector<std::size_t> owned;
          for (std::size_t i = 0; i < points->size(); ++i)
            if (ownerOf(points->positions[i], depth, frame_.transform) == id) owned.push_back(i);
          if (owned.empty()) continue;
          auto areas = source_.areasOf(*points);
          if (!areas) return areas.error();
          for (const std::size_t i : owned) total.add((*areas)[i]);
          counted += owned.size();
        }
    if (counted != source_.count)
      return internalError("bake in bricks: the cells gave {} of M's {} points", counted, source_.count);
    return counted > 0 ? total.value() / static_cast<double>(counted) : 1.0;
  }

  // Pass 2: the errors recorded brick by brick, then the whole tree from them.
  Result<octree::BuiltOctree> buildFromRecords(double meanArea) {
    const octree::BuildSettings settings = bake_steps::buildSettingsOf(options_, frame_);
    std::vector<std::uint64_t> caps = firstCaps(settings);
    std::vector<char> complete(bricks_.size(), 0);
    for (std::size_t b = 0; b < bricks_.size(); ++b) {
      auto done = recordBrick(b, caps[b], meanArea, settings);
      if (!done) return done.error();
      complete[b] = *done;
      reportProgress(onProgress_, 0.1 + 0.4 * static_cast<double>(b + 1) / static_cast<double>(bricks_.size()));
    }
    for (;;) {
      records_.seal();
      report_.recordedCells = records_.size();
      std::vector<CellId> missing;
      octree::ErrorExchange replay;
      replay.replay = &records_;
      replay.missing = &missing;
      octree::BuiltOctree built = octree::buildOctree(frame_.coarseUnit, octree::DetailPrimitives{}, settings, replay);
      if (missing.empty()) return built;
      std::vector<std::size_t> again;
      for (const CellId cell : missing) again.push_back(brickIndex(bricks_, octree::ancestorId(cell, options_.brickDepth)));
      std::sort(again.begin(), again.end());
      again.erase(std::unique(again.begin(), again.end()), again.end());
      for (const std::size_t b : again) {
        if (b >= bricks_.size() || complete[b])
          return internalError("bake in bricks: the whole tree needs {} cells no brick recorded", missing.size());
        // Twice the texels, and no cap once the brick could spend the
        // whole budget (then its build goes as far as any split helps).
        caps[b] = caps[b] >= settings.budgetTexels ? 0 : std::min(2 * caps[b], settings.budgetTexels);
        auto done = recordBrick(b, caps[b], meanArea, settings);
        if (!done) return done.error();
        complete[b] = *done;
      }
      spdlog::info("bake: {} bricks built again with more texels ({} cells were missing)", again.size(), missing.size());
    }
  }

  // Pass 3: each brick's leaves against its points' discs.
  Result<sampling::SampleCounts> sample(octree::BuiltOctree& built) {
    const Octree& octree = built.octree;
    const std::vector<Cell> cells = cellsOf(octree);
    std::vector<std::vector<std::uint32_t>> leaves(bricks_.size());
    for (std::uint32_t n = 0; n < octree.nodes.size(); ++n) {
      if (!octree.nodes[n].isLeaf()) continue;
      const std::size_t b = brickIndex(bricks_, octree::ancestorId(octree::cellIdOf(cells[n]), options_.brickDepth));
      if (b >= bricks_.size()) return internalError("bake in bricks: a leaf outside every brick");
      leaves[b].push_back(n);
    }
    std::vector<sampling::SampleMoments> moments(octree.nodes.size());
    const sampling::SamplingSettings settings{options_.samples, frame_.reach, options_.budget > 0};
    const sampling::CoarseFrames coarse{&frame_.coarseUnit, &coarse_.mesh->points.positions, &frame_.coarseNormals};
    sampling::SampleCounts total;
    for (std::size_t b = 0; b < bricks_.size(); ++b) {
      if (leaves[b].empty()) continue;
      // A ray reaches the larger of `reach` and its leaf's diagonal, and
      // meets discs no wider than `reach`, whose radii (the spacing of
      // their neighbours) were found among points within `reach` of them.
      float farthest = frame_.reach;
      for (const std::uint32_t n : leaves[b])
        farthest = std::max(farthest, std::sqrt(3.0f) * cells[n].width / static_cast<float>(frame_.transform.scale));
      const float margin = farthest + 2.0f * frame_.reach;
      report_.marginWorld = std::max(report_.marginWorld, static_cast<double>(margin));
      auto points = load(worldBoxOf(bricks_[b].cell, margin, frame_.transform, false));
      if (!points) return points.error();
      auto search = source_.searchOver(*points);
      if (!search) return search.error();
      // Counted once, in the brick holding the disc's centre.
      const Aabb own = worldBoxOf(bricks_[b].cell, 0.0f, frame_.transform, false);
      for (std::size_t i = 0; i < points->size(); ++i)
        if (std::sqrt(search->areas[i]) > frame_.reach && (points->positions[i].array() >= own.min.array()).all() &&
            (points->positions[i].array() < own.max.array()).all())
          ++report_.discsWiderThanReach;
      Scan scan;
      scan.points = std::move(points).value();
      DetailSurface surface;
      surface.detail = &scan;
      surface.caster = search->caster.get();
      surface.closest = search->closest.get();
      APO_RETURN_IF_ERROR(surface.caster->ready());
      APO_RETURN_IF_ERROR(surface.closest->ready());
      const sampling::SampleCounts counts = sampling::sampleLeaves(built, leaves[b], coarse, surface, settings, moments);
      total.rays += counts.rays;
      total.hits += counts.hits;
      total.fallbacks += counts.fallbacks;
      total.unanswered += counts.unanswered;
      reportProgress(onProgress_, 0.5 + 0.45 * static_cast<double>(b + 1) / static_cast<double>(bricks_.size()));
    }
    sampling::averageInternalNodes(built.octree, moments, settings.internalNodesMayShowCoarse);
    return total;
  }

  const bake_steps::Frame& frame() const { return frame_; }
  BrickReport& report() { return report_; }

 private:
  Result<PointSet> load(const Aabb& box) {
    auto points = source_.pointsIn(box);
    if (!points) return points.error();
    report_.pointsLoaded += points->size();
    report_.largestBrickPoints = std::max<std::uint64_t>(report_.largestBrickPoints, points->size());
    if (points->normals.size() != points->size())
      return badInput("the detail points have no normals: run `apo ingest` first, which estimates and orients them");
    return points;
  }

  // Each brick's first texel cap: the texels of the levels every brick's
  // build shares, and twice the brick's share of the rest by its coarse
  // cells (0: no budget, no cap).
  std::vector<std::uint64_t> firstCaps(const octree::BuildSettings& settings) const {
    std::vector<std::uint64_t> caps(bricks_.size(), 0);
    if (settings.budgetTexels == 0) return caps;
    // The coarse levels' texels, which every brick's build counts first: a
    // build over no points stops there.
    const std::uint64_t shared =
        octree::buildOctree(frame_.coarseUnit, octree::DetailPrimitives{}, settings).refinement.texels;
    const std::uint64_t rest = settings.budgetTexels - std::min(settings.budgetTexels, shared);
    std::uint64_t coarseCells = 0;
    for (const Brick& brick : bricks_) coarseCells += brick.coarseCells;
    for (std::size_t b = 0; b < bricks_.size(); ++b) {
      const double share = static_cast<double>(bricks_[b].coarseCells) / static_cast<double>(coarseCells);
      caps[b] = std::min(settings.budgetTexels,
                         shared + kLeastFirstCap + static_cast<std::uint64_t>(kFirstShare * share * static_cast<double>(rest)));
    }
    return caps;
  }

  // The brick's build over the points that project into it, capped at
  // `cap` texels (0: none); its cells' errors go to the records. Returns
  // whether it went as far as any split helps (so it recorded every cell
  // the whole tree's build may ask for).
  Result<bool> recordBrick(std::size_t b, std::uint64_t cap, double meanArea, octree::BuildSettings settings) {
    const Brick& brick = bricks_[b];
    // A point moves at most `reach` onto m, and its area is its spacing
    // among the points within `reach` of it.
    auto points = load(worldBoxOf(brick.cell, 2.0f * frame_.reach, frame_.transform, false));
    if (!points) return points.error();
    auto areas = source_.areasOf(*points);
    if (!areas) return areas.error();
    const octree::DetailPrimitives all = bake_steps::pointsForErrorMetric(*points, *areas, meanArea, coarse_, frame_);
    octree::DetailPrimitives inBrick;
    inBrick.coarseKnown = all.coarseKnown;
    for (std::size_t i = 0; i < all.positions.size(); ++i) {
      if (octree::pointCellId(all.positions[i], options_.brickDepth) != brick.id) continue;
      inBrick.positions.push_back(all.positions[i]);
      inBrick.normals.push_back(all.normals[i]);
      inBrick.weights.push_back(all.weights[i]);
      inBrick.coarseNormals.push_back(all.coarseNormals[i]);
    }
    settings.budgetTexels = cap;
    std::vector<std::pair<CellId, octree::LeafError>> found;
    octree::ErrorExchange record;
    record.within = &brick.cell;
    record.recorded = &found;
    const octree::BuiltOctree built = octree::buildOctree(frame_.coarseUnit, inBrick, settings, record);
    records_.add(found);
    ++report_.refinementRuns;
    return built.refinement.stoppedBy != "budget";
  }

  static std::vector<Cell> cellsOf(const Octree& octree) {
    std::vector<Cell> cells(octree.nodes.size());
    for (std::uint32_t n = 0; n < octree.nodes.size(); ++n) {
      const OctreeNode& node = octree.nodes[n];
      std::uint32_t child = node.firstChild;
      for (int c = 0; c < 8 && !node.isLeaf(); ++c)
        if (node.childMask & (1u << c)) cells[child++] = cells[n].child(c);
    }
    return cells;
  }

  // A brick's first build may spend kFirstShare times its share of the
  // budget by m's coarse cells, and kLeastFirstCap texels more.
  static constexpr double kFirstShare = 2.0;
  static constexpr std::uint64_t kLeastFirstCap = 256;

  const BrickedPoints& source_;
  const CoarseSurface& coarse_;
  const BakeOptions& options_;
  const ProgressCallback& onProgress_;
  bake_steps::Frame frame_;
  std::vector<Brick> bricks_;
  octree::RecordedErrors records_;
  BrickReport report_;
};

}  // namespace

Result<Bake> bakeInBricks(const BrickedPoints& detail, const CoarseSurface& coarseSurface,
                          const Checked<BakeOptions>& checkedOptions, const ProgressCallback& onProgress) {
  const BakeOptions& options = *checkedOptions;
  if (options.brickDepth < 1) return usageError("a bake in bricks needs --brick-depth 1 or more");
  if (!coarseSurface.mesh || !coarseSurface.caster || !detail.pointsIn || !detail.areasOf || !detail.searchOver)
    return internalError("bake in bricks: a seam is missing");
  if (detail.count == 0) return badInput("the detail surface M is empty");
  const Scan& coarse = *coarseSurface.mesh;
  APO_RETURN_IF_ERROR(bake_steps::validateCoarseMesh(coarse));
  const Stopwatch total;
  BrickBake bricks(detail, coarseSurface, options, onProgress);
  Bake bake;
  BakeReport& report = bake.report;
  report.detailKind = "points";
  report.detailPrimitives = detail.count;
  report.coarseTriangles = coarse.triangles.size();

  Stopwatch phase;
  auto meanArea = bricks.meanArea();
  if (!meanArea) return meanArea.error();
  report.seconds.setup = bricks.report().areaSeconds = phase.seconds();
  reportProgress(onProgress, 0.1);
  spdlog::info("bake: {} bricks of depth {}; the points' mean area found in {:.2f} s", bricks.report().bricks,
               options.brickDepth, report.seconds.setup);

  phase = Stopwatch();
  auto built = bricks.buildFromRecords(*meanArea);
  if (!built) return built.error();
  APO_RETURN_IF_ERROR(bake_steps::checkBudgetMet(*built, options));
  report.refinement = bake_steps::refinementReport(built->refinement, options);
  built->octree.transform = bricks.frame().transform;
  report.seconds.build = bricks.report().refineSeconds = phase.seconds();
  spdlog::info("bake: octree of {} nodes built from {} recorded cells of {} brick builds in {:.2f} s",
               built->octree.nodes.size(), bricks.report().recordedCells, bricks.report().refinementRuns,
               report.seconds.build);

  phase = Stopwatch();
  auto counts = bricks.sample(*built);
  if (!counts) return counts.error();
  if (counts->unanswered > 0)
    return internalError("bake: the closest-point search over M failed for {} of {} samples whose rays missed M",
                         counts->unanswered, counts->unanswered + counts->fallbacks);
  report.rays = counts->rays;
  report.hits = counts->hits;
  report.fallbacks = counts->fallbacks;
  report.seconds.sample = bricks.report().sampleSeconds = phase.seconds();
  spdlog::info("bake: {} rays, {} samples hit M, {} by the closest point, brick by brick in {:.2f} s", counts->rays,
               counts->hits, counts->fallbacks, report.seconds.sample);

  APO_RETURN_IF_ERROR(bake_steps::encodeInto(bake, std::move(built).value(), coarse, options, bricks.frame()));
  report.bricks = bricks.report();
  report.totalSeconds = total.seconds();
  report.peakMemoryBytes = peakResidentBytes();
  reportProgress(onProgress, 1.0);
  return bake;
}

}  // namespace apo
