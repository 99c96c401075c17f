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
#include "bake/brick_journal.h"
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
            const ProgressCallback& onProgress, const BrickShare* share = nullptr)
      : source_(source), coarse_(coarse), options_(options), onProgress_(onProgress), share_(share),
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
    std::uint64_t counted = 0, index = 0;
    for (int x = 0; x < cells; ++x)
      for (int y = 0; y < cells; ++y)
        for (int z = 0; z < cells; ++z, ++index) {
          if (othersShare(index, BrickShare::Pass::Areas)) continue;
          const CellId id = (static_cast<CellId>(depth) << octree::kCellIdDepthShift) | octree::gridKey(x, y, z, depth);
          auto cell = fromJournal(brick_journal::areaName(id), brick_journal::decodeArea);
          if (!cell) return cell.error();
          if (!*cell) {
            APO_RETURN_IF_ERROR(requireEarlierPass(BrickShare::Pass::Areas, brick_journal::areaName(id)));
            auto found = cellArea(id);
            if (!found) return found.error();
            APO_RETURN_IF_ERROR(toJournal(brick_journal::areaName(id), brick_journal::encode(*found)));
            *cell = std::move(found).value();
          }
          total.add((*cell)->sum);
          counted += (*cell)->count;
        }
    if (share_ && share_->pass == BrickShare::Pass::Areas) return 0.0;  // a share: no mean yet
    if (counted != source_.count)
      return internalError("bake in bricks: the cells gave {} of M's {} points", counted, source_.count);
    return counted > 0 ? total.value() / static_cast<double>(counted) : 1.0;
  }

  // The areas of the points cell `id` of the brick depth owns.
  Result<brick_journal::AreaEntry> cellArea(CellId id) {
    const int depth = options_.brickDepth;
    auto points = load(worldBoxOf(cellOfId(id), frame_.reach, frame_.transform, true));
    if (!points) return points.error();
    std::vector<std::size_t> owned;
    for (std::size_t i = 0; i < points->size(); ++i)
      if (ownerOf(points->positions[i], depth, frame_.transform) == id) owned.push_back(i);
    brick_journal::AreaEntry entry;
    if (owned.empty()) return entry;
    auto areas = source_.areasOf(*points);
    if (!areas) return areas.error();
    for (const std::size_t i : owned) entry.sum.add((*areas)[i]);
    entry.count = owned.size();
    return entry;
  }

  // Pass 2: the errors recorded brick by brick (each brick's first build;
  // a share: its bricks' only), then the whole tree from them.
  Status recordFirstBuilds(double meanArea) {
    const octree::BuildSettings settings = bake_steps::buildSettingsOf(options_, frame_);
    caps_ = firstCaps(settings);
    complete_.assign(bricks_.size(), 0);
    for (std::size_t b = 0; b < bricks_.size(); ++b) {
      if (othersShare(b, BrickShare::Pass::Records)) continue;
      auto done = recordBrick(b, caps_[b], meanArea, settings, BrickShare::Pass::Records);
      if (!done) return done.error();
      complete_[b] = *done;
      reportProgress(onProgress_, 0.1 + 0.4 * static_cast<double>(b + 1) / static_cast<double>(bricks_.size()));
    }
    return okStatus();
  }

  // The whole tree from the records; bricks whose records fall short are
  // built again (by any task: the same bytes whoever builds them).
  Result<octree::BuiltOctree> treeFromRecords(double meanArea) {
    const octree::BuildSettings settings = bake_steps::buildSettingsOf(options_, frame_);
    std::vector<std::uint64_t>& caps = caps_;
    std::vector<char>& complete = complete_;
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
        auto done = recordBrick(b, caps[b], meanArea, settings, std::nullopt);
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
      if (leaves[b].empty() || othersShare(b, BrickShare::Pass::Samples)) continue;
      // A ray reaches the larger of `reach` and its leaf's diagonal, and
      // meets discs no wider than `reach`, whose radii (the spacing of
      // their neighbours) were found among points within `reach` of them.
      float farthest = frame_.reach;
      for (const std::uint32_t n : leaves[b])
        farthest = std::max(farthest, std::sqrt(3.0f) * cells[n].width / static_cast<float>(frame_.transform.scale));
      const float margin = farthest + 2.0f * frame_.reach;
      report_.marginWorld = std::max(report_.marginWorld, static_cast<double>(margin));
      const std::string name = brick_journal::samplesName(bricks_[b].id);
      const auto forTheseLeaves = [&](std::string_view bytes) {
        auto decoded = brick_journal::decodeSamples(bytes);
        return decoded && decoded->leaves == leaves[b] ? decoded : std::nullopt;
      };
      auto entry = fromJournal(name, forTheseLeaves);
      if (!entry) return entry.error();
      if (!*entry) {
        auto sampled = sampleBrick(built, bricks_[b].cell, leaves[b], margin, coarse, settings, moments);
        if (!sampled) return sampled.error();
        APO_RETURN_IF_ERROR(toJournal(name, brick_journal::encode(*sampled)));
        *entry = std::move(sampled).value();
      }
      const brick_journal::SampleEntry& done = **entry;
      for (std::size_t i = 0; i < done.leaves.size(); ++i) {
        OctreeNode& leaf = built.octree.nodes[done.leaves[i]];
        leaf.normal = done.values[i].normal;
        leaf.weight = done.values[i].weight;
        leaf.sides = done.values[i].sides;
        moments[done.leaves[i]] = done.moments[i];
      }
      report_.discsWiderThanReach += done.discsWiderThanReach;
      total.rays += done.counts.rays;
      total.hits += done.counts.hits;
      total.fallbacks += done.counts.fallbacks;
      total.unanswered += done.counts.unanswered;
      reportProgress(onProgress_, 0.5 + 0.45 * static_cast<double>(b + 1) / static_cast<double>(bricks_.size()));
    }
    if (!share_) sampling::averageInternalNodes(built.octree, moments, settings.internalNodesMayShowCoarse);
    return total;
  }

  // A brick's leaves sampled against the discs of its points and those
  // within `margin` of it.
  Result<brick_journal::SampleEntry> sampleBrick(octree::BuiltOctree& built, const Cell& cell,
                                                 const std::vector<std::uint32_t>& leaves, float margin,
                                                 const sampling::CoarseFrames& coarse,
                                                 const sampling::SamplingSettings& settings,
                                                 std::vector<sampling::SampleMoments>& moments) {
    auto points = load(worldBoxOf(cell, margin, frame_.transform, false));
    if (!points) return points.error();
    auto search = source_.searchOver(*points);
    if (!search) return search.error();
    brick_journal::SampleEntry entry;
    // Counted once, in the brick holding the disc's centre.
    const Aabb own = worldBoxOf(cell, 0.0f, frame_.transform, false);
    for (std::size_t i = 0; i < points->size(); ++i)
      if (std::sqrt(search->areas[i]) > frame_.reach && (points->positions[i].array() >= own.min.array()).all() &&
          (points->positions[i].array() < own.max.array()).all())
        ++entry.discsWiderThanReach;
    Scan scan;
    scan.points = std::move(points).value();
    DetailSurface surface;
    surface.detail = &scan;
    surface.caster = search->caster.get();
    surface.closest = search->closest.get();
    APO_RETURN_IF_ERROR(surface.caster->ready());
    APO_RETURN_IF_ERROR(surface.closest->ready());
    entry.counts = sampling::sampleLeaves(built, leaves, coarse, surface, settings, moments);
    entry.leaves = leaves;
    for (const std::uint32_t n : leaves) {
      const OctreeNode& leaf = built.octree.nodes[n];
      entry.values.push_back({leaf.normal, leaf.weight, leaf.sides});
      entry.moments.push_back(moments[n]);
    }
    return entry;
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
  // `pass`: the pass whose share builds it (a retry: none, any task may).
  Result<bool> recordBrick(std::size_t b, std::uint64_t cap, double meanArea, const octree::BuildSettings& settings,
                           std::optional<BrickShare::Pass> pass) {
    const std::string name = brick_journal::recordsName(bricks_[b].id, cap);
    auto entry = fromJournal(name, brick_journal::decodeRecords);
    if (!entry) return entry.error();
    if (!*entry) {
      if (pass) APO_RETURN_IF_ERROR(requireEarlierPass(*pass, name));
      auto built = buildBrick(b, cap, meanArea, settings);
      if (!built) return built.error();
      APO_RETURN_IF_ERROR(toJournal(name, brick_journal::encode(*built)));
      *entry = std::move(built).value();
    }
    records_.add((*entry)->found);
    return (*entry)->complete;
  }

  Result<brick_journal::RecordEntry> buildBrick(std::size_t b, std::uint64_t cap, double meanArea,
                                                octree::BuildSettings settings) {
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
    brick_journal::RecordEntry entry;
    octree::ErrorExchange record;
    record.within = &brick.cell;
    record.recorded = &entry.found;
    const octree::BuiltOctree built = octree::buildOctree(frame_.coarseUnit, inBrick, settings, record);
    ++report_.refinementRuns;
    entry.complete = built.refinement.stoppedBy != "budget";
    return entry;
  }

  // In a share of a bake (BrickShare), whether item `index` of `pass` is
  // another task's to do in this very pass.
  bool othersShare(std::uint64_t index, BrickShare::Pass pass) const {
    return share_ && share_->pass == pass && index % share_->tasks != share_->task;
  }

  // In a share of a later pass, an entry of `pass` must come from the
  // journal: its tasks ran before.
  Status requireEarlierPass(BrickShare::Pass pass, const std::string& name) const {
    if (!share_ || share_->pass <= pass) return okStatus();
    return badInput("the bake's journal has no entry {}: the {} pass must be done by every task before the {} pass",
                    name, passName(pass), passName(share_->pass));
  }

  // An entry of the journal, decoded; nullopt when absent or refused by `decode`
  // (damaged, by another version of this code, or for another tree: done again).
  template <class Decode>
  auto fromJournal(const std::string& name, Decode decode) -> Result<decltype(decode(std::string_view{}))> {
    using Entry = decltype(decode(std::string_view{}));
    if (!source_.journal.present()) return Entry{};
    auto bytes = source_.journal.read(name);
    if (!bytes) return bytes.error();
    if (!*bytes) return Entry{};
    Entry entry = decode(**bytes);
    if (!entry) {
      spdlog::warn("bake: the journal's entry {} is damaged or for another tree; done again", name);
      return Entry{};
    }
    ++report_.journalEntriesReused;
    return entry;
  }

  Status toJournal(const std::string& name, const std::string& bytes) {
    if (!source_.journal.present()) return okStatus();
    APO_RETURN_IF_ERROR(source_.journal.write(name, bytes));
    ++report_.journalEntriesWritten;
    return okStatus();
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
  const BrickShare* share_;
  bake_steps::Frame frame_;
  std::vector<std::uint64_t> caps_;  // each brick's texel cap, by pass 2
  std::vector<char> complete_;       // each brick's build went as far as any split helps
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
  APO_RETURN_IF_ERROR(bricks.recordFirstBuilds(*meanArea));
  auto built = bricks.treeFromRecords(*meanArea);
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

const char* passName(BrickShare::Pass pass) {
  switch (pass) {
    case BrickShare::Pass::Areas: return "areas";
    case BrickShare::Pass::Records: return "records";
    case BrickShare::Pass::Samples: return "samples";
  }
  return "?";
}

std::optional<BrickShare::Pass> passNamed(std::string_view name) {
  for (const auto pass : {BrickShare::Pass::Areas, BrickShare::Pass::Records, BrickShare::Pass::Samples})
    if (name == passName(pass)) return pass;
  return std::nullopt;
}

Result<BrickReport> bakeShareOfBricks(const BrickedPoints& detail, const CoarseSurface& coarseSurface,
                                      const Checked<BakeOptions>& checkedOptions, const BrickShare& share,
                                      const ProgressCallback& onProgress) {
  const BakeOptions& options = *checkedOptions;
  if (options.brickDepth < 1) return usageError("a bake in bricks needs --brick-depth 1 or more");
  if (!detail.journal.present()) return usageError("a share of a bake in bricks needs a journal to write to");
  if (share.tasks == 0 || share.task >= share.tasks)
    return usageError("task {} of {}: the task must be below the number of tasks", share.task, share.tasks);
  if (!coarseSurface.mesh || !coarseSurface.caster || !detail.pointsIn || !detail.areasOf || !detail.searchOver)
    return internalError("bake in bricks: a seam is missing");
  if (detail.count == 0) return badInput("the detail surface M is empty");
  APO_RETURN_IF_ERROR(bake_steps::validateCoarseMesh(*coarseSurface.mesh));
  BrickBake bricks(detail, coarseSurface, options, onProgress, &share);
  Stopwatch phase;
  auto meanArea = bricks.meanArea();
  if (!meanArea) return meanArea.error();
  bricks.report().areaSeconds = phase.seconds();
  if (share.pass == BrickShare::Pass::Areas) return bricks.report();
  phase = Stopwatch();
  APO_RETURN_IF_ERROR(bricks.recordFirstBuilds(*meanArea));
  if (share.pass == BrickShare::Pass::Records) {
    bricks.report().refineSeconds = phase.seconds();
    return bricks.report();
  }
  auto built = bricks.treeFromRecords(*meanArea);
  if (!built) return built.error();
  APO_RETURN_IF_ERROR(bake_steps::checkBudgetMet(*built, options));
  built->octree.transform = bricks.frame().transform;
  bricks.report().refineSeconds = phase.seconds();
  phase = Stopwatch();
  auto counts = bricks.sample(*built);
  if (!counts) return counts.error();
  bricks.report().sampleSeconds = phase.seconds();
  return bricks.report();
}

}  // namespace apo
