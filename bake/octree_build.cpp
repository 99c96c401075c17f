// The adaptive octree of paper section 3.1, wired from its three units. The
// levels down to the coarse depth are found by binning m's triangles into
// the coarse grid at once (cell_clip.h); the tree is then refined globally
// by the L2,1 criterion (refinement.h, docs/bake.md, "Refinement"): the
// leaves' splits are evaluated ahead by MetricEvaluator, moving m's and M's
// primitives down into the children they overlap and summing M's part in
// each (l21_metric.h), and made in order of the error they remove per
// texel, until the texel budget is spent.
#include "bake/octree_build.h"

#include "bake/cell_clip.h"
#include "bake/l21_metric.h"
#include "bake/refinement.h"

#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/task_group.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <numbers>
#include <optional>
#include <utility>

namespace apo::octree {
namespace {

// ---- m's and M's triangles, for the binning -------------------------------

Bounds coarseBounds(const CoarseMesh& m, std::uint32_t t) {
  const Triangle& tri = m.triangles[t];
  return triangleBounds(m.positions[tri[0]], m.positions[tri[1]], m.positions[tri[2]]);
}

bool coarseOverlaps(const CoarseMesh& m, std::uint32_t t, const Cell& cell) {
  const Triangle& tri = m.triangles[t];
  return triangleOverlapsBox(m.positions[tri[0]], m.positions[tri[1]], m.positions[tri[2]], cell);
}

// M's triangle i (M's points go through PointOrder).
Bounds detailBounds(const DetailPrimitives& d, std::uint32_t i) {
  const auto& c = d.triangles[i].corners;
  return triangleBounds(c[0], c[1], c[2]);
}

bool detailOverlaps(const DetailPrimitives& d, std::uint32_t i, const Cell& cell) {
  const auto& c = d.triangles[i].corners;
  return triangleOverlapsBox(c[0], c[1], c[2], cell);
}

// ---- The metric as the refinement's evaluator ------------------------------

// Lists filed child by child, then copied into lists of their exact size:
// grown one push at a time, the children's lists took several allocations
// each, and the allocators 7-9% of the 1.2M bunny's bake (perf).
// Reused from one evaluation to the next on a thread.
struct ChildFiling {
  std::array<std::vector<std::uint32_t>, 8> lists;

  void clear() {
    for (auto& list : lists) list.clear();
  }
  template <typename List = IdList>
  List take(int child) const {
    return List(lists[child].begin(), lists[child].end());
  }
};

// Splits m's triangles among the eight children of `cell`.
std::array<CoarseIdList, 8> distributeCoarse(const CoarseMesh& m, const CoarseIdList& triangles, const Cell& cell,
                                       ChildFiling& filing) {
  filing.clear();
  for (const std::uint32_t t : triangles) {
    const Triangle& tri = m.triangles[t];
    const unsigned meeting = childrenMeeting(m.positions[tri[0]], m.positions[tri[1]], m.positions[tri[2]], cell);
    for (int c = 0; c < 8; ++c)
      if (meeting & (1u << c)) filing.lists[c].push_back(t);
  }
  std::array<CoarseIdList, 8> children;
  for (int c = 0; c < 8; ++c)
    if (!filing.lists[c].empty()) children[c] = filing.take<CoarseIdList>(c);
  return children;
}

// The children `distributeCoarse` would give a non-empty list, without the
// lists: a child counts from its first triangle on, and the others are not
// tested against it again (counting m's triangles through the lists spent
// 8% of the 1.2M bunny's bake in separating-axis tests).
std::uint8_t childrenHoldingCoarse(const CoarseMesh& m, const CoarseIdList& triangles, const Cell& cell) {
  unsigned holding = 0;
  for (const std::uint32_t t : triangles) {
    const Triangle& tri = m.triangles[t];
    holding |= childrenMeeting(m.positions[tri[0]], m.positions[tri[1]], m.positions[tri[2]], cell,
                               static_cast<std::uint8_t>(~holding & 0xFF));
    if (holding == 0xFF) break;
  }
  return static_cast<std::uint8_t>(holding);
}

// M's record fetched ahead of its use: its first and last cache lines.
void prefetchRecord(const DetailTriangle& record) {
  const char* bytes = reinterpret_cast<const char*>(&record);
  __builtin_prefetch(bytes);
  __builtin_prefetch(bytes + sizeof(DetailTriangle) - 1);
}

// The L2,1 metric as the refinement's evaluator (refinement.h,
// LeafEvaluator): a leaf's split files m's triangles into its children,
// keeps those holding some of m, and sums M's part in each: from M's points
// in Morton order, from the fine cells' sums above the sum depth, or by
// clipping M's triangles into the children below it.
class MetricEvaluator {
 public:
  using Scratch = ChildFiling;

  // `points`: M's points in order, when M is points. `sumDepth`: the depth
  // of FineSums' cells (leaves above it carry theirs), 0 when none.
  MetricEvaluator(const CoarseMesh& coarse, const DetailPrimitives& detail, const PointOrder* points,
                  const BuildSettings& settings, int sumDepth, const ErrorExchange& exchange)
      : coarse_(coarse), detail_(detail), points_(points), settings_(settings), sumDepth_(sumDepth),
        exchange_(exchange) {}

  // The coarse cells, their errors computed in parallel (from their fine
  // cells' sums, below which M's triangles are then clipped, when the sum
  // depth is below them).
  void prepare(std::vector<Leaf>& leaves) {
    fineSums_.resize(leaves.size());
    tbb::enumerable_thread_specific<FineSums::Scratch> scratch;
    tbb::parallel_for(std::size_t{0}, leaves.size(), [&](std::size_t i) {
      Leaf& leaf = leaves[i];
      if (sumDepth_ > leaf.cell.depth) {
        const FineSums& fine = fineSums_[i].emplace(detail_, leaf.primitives, leaf.cell, sumDepth_, scratch.local());
        leaf.fine = &fine;
        leaf.fineRun = fine.all();
        IdList().swap(leaf.primitives);
      }
      leaf.error = errorOf(leaf);
    });
  }

  // The leaf's split: m's triangles into the children (only those holding
  // some of m are kept), M's primitives into the kept ones, their errors.
  // `filing`: the thread's scratch lists.
  void split(Leaf& leaf, Candidate& candidate, ChildFiling& filing) const {
    const Cell& cell = leaf.cell;
    auto childTriangles = distributeCoarse(coarse_, leaf.triangles, leaf.cell, filing);
    for (int c = 0; c < 8; ++c)
      if (!childTriangles[c].empty()) candidate.mask |= static_cast<std::uint8_t>(1u << c);
    if (candidate.mask == 0) return;
    ChildErrors childErrors = points_      ? distributePoints(leaf, candidate.mask)
                              : leaf.fine ? distributeFineSums(leaf, candidate.mask)
                                          : distributeTriangles(leaf, candidate.mask, filing);
    candidate.children.reserve(static_cast<std::size_t>(std::popcount(candidate.mask)));
    for (int c = 0; c < 8; ++c) {
      if (!(candidate.mask & (1u << c))) continue;
      Leaf child;
      child.cell = cell.child(c);
      child.triangles = std::move(childTriangles[c]);
      child.primitives = std::move(childErrors.primitives[c]);
      child.points = childErrors.points[c];
      if (leaf.fine && child.cell.depth < sumDepth_) {
        child.fine = leaf.fine;
        child.fineRun = childErrors.fineRuns[c];
      }
      child.error = childErrors.errors[c];
      candidate.children.push_back(std::move(child));
    }
    // M's primitives are needed by the error metric only (the rays are
    // cast against all of M): a leaf that splits keeps none.
    IdList().swap(leaf.primitives);
  }

  // The children that would hold some of m, as coarseInChildren keeps them.
  int keptChildrenOf(const Leaf& leaf) const {
    return std::popcount(static_cast<unsigned>(childrenHoldingCoarse(coarse_, leaf.triangles, leaf.cell)));
  }

  // M's fine sums, which only the splitting needed.
  void release() { fineSums_ = {}; }

  // The errors recorded and the cells missed, handed to the exchange.
  void handOver() {
    if (exchange_.recorded)
      for (auto& found : found_) exchange_.recorded->insert(exchange_.recorded->end(), found.begin(), found.end());
    if (exchange_.missing) {
      for (auto& missed : missing_) exchange_.missing->insert(exchange_.missing->end(), missed.begin(), missed.end());
      std::sort(exchange_.missing->begin(), exchange_.missing->end());
      exchange_.missing->erase(std::unique(exchange_.missing->begin(), exchange_.missing->end()), exchange_.missing->end());
    }
  }

 private:
  LeafError errorOf(const Leaf& leaf) const {
    if (points_) return pointsError(leaf.cell, leaf.points);
    if (leaf.fine)
      return leafErrorOf(leaf.fine->sumsOf(leaf.fineRun), detail_.coarseKnown, settings_.deferToCoarse,
                         mayBeTwoSided(leaf.cell));
    return errorInCell(detail_, leaf.primitives, leaf.cell, settings_.deferToCoarse, mayBeTwoSided(leaf.cell));
  }

  // The error of M's points in a cell (recorded when the exchange asks), or
  // the one recorded for it by an earlier build (zero when none was).
  LeafError pointsError(const Cell& cell, KeyRun run) const {
    if (exchange_.replay) {
      const CellId id = cellIdOf(cell);
      if (const LeafError* recorded = exchange_.replay->find(id)) return *recorded;
      missing_.local().push_back(id);
      return {};
    }
    const LeafError error =
        leafErrorOf(points_->sumsOf(run), detail_.coarseKnown, settings_.deferToCoarse, mayBeTwoSided(cell));
    if (exchange_.recorded && ancestorId(cellIdOf(cell), exchange_.within->depth) == cellIdOf(*exchange_.within))
      found_.local().emplace_back(cellIdOf(cell), error);
    return error;
  }

  bool mayBeTwoSided(const Cell& cell) const {
    return settings_.twoSidedLeaves && cell.depth > settings_.completeDepth;
  }

  // M's primitives in each kept child and the child's error.
  struct ChildErrors {
    std::array<IdList, 8> primitives;
    std::array<KeyRun, 8> fineRuns;
    std::array<KeyRun, 8> points;
    std::array<LeafError, 8> errors;
  };

  ChildErrors distributePoints(const Leaf& leaf, std::uint8_t mask) const {
    ChildErrors out;
    for (int c = 0; c < 8; ++c)
      if (mask & (1u << c)) {
        const Cell child = leaf.cell.child(c);
        out.points[c] = points_->runOf(child, leaf.points);
        out.errors[c] = pointsError(child, out.points[c]);
      }
    return out;
  }

  // Above the sum depth, the children's sums are their fine cells'; a child
  // at that depth takes its fine cell's triangles, to be clipped below it.
  ChildErrors distributeFineSums(const Leaf& leaf, std::uint8_t mask) const {
    ChildErrors out;
    for (int c = 0; c < 8; ++c)
      if (mask & (1u << c)) {
        const Cell child = leaf.cell.child(c);
        out.fineRuns[c] = leaf.fine->runOf(child, leaf.fineRun);
        out.errors[c] = leafErrorOf(leaf.fine->sumsOf(out.fineRuns[c]), detail_.coarseKnown, settings_.deferToCoarse,
                                    mayBeTwoSided(child));
        if (child.depth == sumDepth_) out.primitives[c] = leaf.fine->trianglesOf(out.fineRuns[c]);
      }
    return out;
  }

  // Each triangle is cut at the midplanes it crosses (GridSweep), and its
  // parts are both the overlap test and the pieces the children's sums take
  // (filing by a separating-axis test, then clipping again to sum, cost 3-5%
  // more of the build: docs/bake.md, "A faster build"). A triangle
  // whose part in a child has no area is not filed there: it adds nothing
  // below.
  ChildErrors distributeTriangles(const Leaf& leaf, std::uint8_t mask, ChildFiling& filing) const {
    ChildErrors out;
    filing.clear();
    std::array<VariationSums, 8> sums;
    const Cell& cell = leaf.cell;
    const GridAxes children = gridInside(cell, 1);
    // The children on each half of each axis (child bit 1: the lower half,
    // grid cell 0): x's bit is 4, y's 2, z's 1.
    constexpr std::array<std::array<unsigned, 2>, 3> kHalf{{{0xF0, 0x0F}, {0xCC, 0x33}, {0xAA, 0x55}}};
    // Whether a kept child lies on the halves given up to `axis`.
    const auto wanted = [&](int axis, const std::array<int, 3>& at) {
      unsigned children = mask;
      for (int a = 0; a <= axis; ++a) children &= kHalf[a][at[a]];
      return children != 0;
    };
    const IdList& primitives = leaf.primitives;
    for (std::size_t k = 0; k < primitives.size(); ++k) {
      // The records are read through the leaf's list: fetched ahead, their
      // cache misses overlap the clipping of the triangles before them.
      if (k + kPrefetchAhead < primitives.size()) prefetchRecord(detail_.triangles[primitives[k + kPrefetchAhead]]);
      const std::uint32_t t = primitives[k];
      const MetricTriangle triangle(detail_, detail_.triangles[t]);
      GridSweep(triangle.frame, children).run(wanted, [&](const GridPart& part) {
        const int c = (part.cell[0] == 0 ? 4 : 0) | (part.cell[1] == 0 ? 2 : 0) | (part.cell[2] == 0 ? 1 : 0);
        sums[c].addPart(triangle, momentsOf(part));
        filing.lists[c].push_back(t);
      });
    }
    const bool withCoarse = detail_.coarseKnown;
    for (int c = 0; c < 8; ++c)
      if (mask & (1u << c)) {
        out.primitives[c] = filing.take(c);
        out.errors[c] = leafErrorOf(sums[c], withCoarse, settings_.deferToCoarse, mayBeTwoSided(cell.child(c)));
      }
    return out;
  }

  const CoarseMesh& coarse_;
  const DetailPrimitives& detail_;
  const PointOrder* points_;
  const BuildSettings& settings_;
  int sumDepth_;
  std::vector<std::optional<FineSums>> fineSums_;  // per coarse cell, with a sum depth
  const ErrorExchange& exchange_;
  mutable tbb::enumerable_thread_specific<std::vector<std::pair<CellId, LeafError>>> found_;
  mutable tbb::enumerable_thread_specific<std::vector<CellId>> missing_;
};

// ---- Assembly -------------------------------------------------------------

// The complete levels down to the coarse depth, breadth first, over the
// occupied coarse cells (sorted keys). Returns the node index of each.
std::vector<std::uint32_t> buildUpperLevels(const std::vector<GridKey>& occupied, int coarseDepth,
                                            std::vector<OctreeNode>& nodes) {
  // levels[d]: sorted keys of the occupied cells at depth d.
  std::vector<std::vector<GridKey>> levels(coarseDepth + 1);
  levels[coarseDepth] = occupied;
  for (int d = coarseDepth - 1; d >= 0; --d) {
    for (const GridKey key : levels[d + 1]) {
      const auto xyz = gridCoordinates(key, d + 1);
      levels[d].push_back(gridKey(xyz[0] >> 1, xyz[1] >> 1, xyz[2] >> 1, d));
    }
    std::sort(levels[d].begin(), levels[d].end());
    levels[d].erase(std::unique(levels[d].begin(), levels[d].end()), levels[d].end());
  }
  std::vector<std::uint32_t> coarseNodes(occupied.size());
  std::vector<std::pair<GridKey, int>> queue = {{0, 0}};  // (key, depth), breadth first
  nodes.assign(1, OctreeNode{});
  for (std::size_t q = 0; q < queue.size(); ++q) {
    const auto [key, depth] = queue[q];
    const auto node = static_cast<std::uint32_t>(q);
    if (depth == coarseDepth) {
      coarseNodes[static_cast<std::size_t>(std::lower_bound(occupied.begin(), occupied.end(), key) - occupied.begin())] = node;
      continue;
    }
    const auto xyz = gridCoordinates(key, depth);
    nodes[node].firstChild = static_cast<std::uint32_t>(nodes.size());
    for (int c = 0; c < 8; ++c) {
      // Child bit 1 is the lower half: grid coordinate 2x; bit 0: 2x + 1.
      const GridKey child = gridKey(2 * xyz[0] + ((c & 4) ? 0 : 1), 2 * xyz[1] + ((c & 2) ? 0 : 1),
                                    2 * xyz[2] + ((c & 1) ? 0 : 1), depth + 1);
      if (!std::binary_search(levels[depth + 1].begin(), levels[depth + 1].end(), child)) continue;
      nodes[node].childMask |= static_cast<std::uint8_t>(1u << c);
      OctreeNode childNode;
      childNode.depth = static_cast<std::uint8_t>(depth + 1);
      nodes.push_back(childNode);
      queue.emplace_back(child, depth + 1);
    }
  }
  return coarseNodes;
}

// Groups sorted (key, primitive) pairs by key.
struct Groups {
  std::vector<GridKey> keys;
  std::vector<IdList> members;
};

Groups groupByKey(const std::vector<std::pair<GridKey, std::uint32_t>>& pairs) {
  Groups groups;
  for (const auto& [key, member] : pairs) {
    if (groups.keys.empty() || groups.keys.back() != key) {
      groups.keys.push_back(key);
      groups.members.emplace_back();
    }
    groups.members.back().push_back(member);
  }
  return groups;
}

}  // namespace

DetailPrimitives DetailPrimitives::ofMesh(const std::vector<Vec3f>& positions, const std::vector<Triangle>& triangles,
                                          const std::vector<Vec3f>& cornerNormals, double areaScale,
                                          const std::vector<Vec3f>& shifts, const std::vector<Vec3f>& coarseNormals) {
  DetailPrimitives detail;
  detail.areaScale = areaScale;
  detail.coarseKnown = !coarseNormals.empty();
  detail.triangles.resize(triangles.size());
  tbb::parallel_for(std::size_t{0}, triangles.size(), [&](std::size_t i) {
    DetailTriangle& t = detail.triangles[i];
    const Vec3f shift = shifts.empty() ? Vec3f(Vec3f::Zero()) : shifts[i];
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t v = triangles[i][k];
      t.corners[k] = positions[v] + shift;
      t.normals[k] = cornerNormals[v];
      t.coarseNormals[k] = detail.coarseKnown ? coarseNormals[v] : Vec3f(Vec3f::Zero());
    }
  });
  return detail;
}

double RefinementOutcome::rmsDegrees() const {
  return area > 0.0 ? std::sqrt(error / area) * 180.0 / std::numbers::pi : 0.0;
}

BuiltOctree buildOctree(const CoarseMesh& coarse, const DetailPrimitives& detail, const BuildSettings& settings) {
  return buildOctree(coarse, detail, settings, ErrorExchange{});
}

BuiltOctree buildOctree(const CoarseMesh& coarse, const DetailPrimitives& detail, const BuildSettings& settings,
                        const ErrorExchange& exchange) {
  const int depth = settings.coarseDepth;
  const Groups coarseCells = groupByKey(binIntoGrid(
      coarse.triangles.size(), depth, [&](std::uint32_t t) { return coarseBounds(coarse, t); },
      [&](std::uint32_t t, const Cell& cell) { return coarseOverlaps(coarse, t, cell); }));
  // M's triangles in the occupied coarse cells only; M's points in order.
  const bool points = detail.triangles.empty();
  std::vector<IdList> detailCells;
  if (!points)
    detailCells = binIntoCells(
        coarseCells.keys, detail.size(), depth, [&](std::uint32_t i) { return detailBounds(detail, i); },
        [&](std::uint32_t i, const Cell& cell) { return detailOverlaps(detail, i, cell); });
  const std::optional<PointOrder> pointOrder = points ? std::optional<PointOrder>(detail) : std::nullopt;

  BuiltOctree built;
  std::vector<OctreeNode>& nodes = built.octree.nodes;
  const std::vector<std::uint32_t> coarseNodes = buildUpperLevels(coarseCells.keys, depth, nodes);
  RefinementOutcome& outcome = built.refinement;
  outcome.texels = texelsOf(nodes, settings.completeDepth);

  std::vector<Leaf> first(coarseCells.keys.size());
  for (std::size_t i = 0; i < first.size(); ++i) {
    const GridKey key = coarseCells.keys[i];
    first[i].node = coarseNodes[i];
    first[i].cell = gridCell(key, depth);
    first[i].triangles.assign(coarseCells.members[i].begin(), coarseCells.members[i].end());
    if (pointOrder) first[i].points = pointOrder->runOf(first[i].cell, pointOrder->all());
    if (!points) first[i].primitives = std::move(detailCells[i]);
  }
  detailCells = {};
  // Every node below the completion depth takes a texel at least: a budget
  // bounds the nodes, and reserving them spares the build (serial there)
  // copying the nodes into ever larger fresh memory (40 MB for the 1.2M
  // bunny); pages reserved but never used are never touched.
  if (settings.budgetTexels > 0) nodes.reserve(std::max<std::size_t>(nodes.size(), settings.budgetTexels));
  outcome.sumDepth = sumDepthFor(detail, settings);
  MetricEvaluator metric(coarse, detail, pointOrder ? &*pointOrder : nullptr, settings, outcome.sumDepth, exchange);
  GlobalRefinement refinement(metric, settings, nodes, outcome);
  refinement.start(std::move(first));
  refinement.run();
  metric.handOver();
  // Breadth-first numbering: the octree does not depend on the order the
  // splits were made in (which follows the last bits of the error metric).
  std::vector<std::uint32_t> newNumber;
  {
    tbb::task_group release;
    release.run([&] { refinement.releaseSplitState(); });
    newNumber = renumberBreadthFirst(nodes);
    release.wait();
  }
  refinement.layOut(newNumber, built);
  return built;
}

}  // namespace apo::octree
