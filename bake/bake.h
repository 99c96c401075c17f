// bake: builds the Appearance Preserving Octree-texture (APO) of a dense
// surface M's normal field around a coarse mesh m (Lacoste et al. 2007,
// sections 3 and 4) and encodes it in the format of format/format.h.
// docs/bake.md describes the algorithm.
//
// The algorithm reaches the libraries only through seams passed in:
// RayCaster (core/ray_caster.h) for M and for m, and ClosestPointFinder
// (core/closest_point.h). pipeline/bake_seams.h wires Embree and FLANN in;
// the tests pass brute-force versions.
#pragma once

#include "core/checked.h"
#include "core/closest_point.h"
#include "core/error.h"
#include "core/geometry.h"
#include "core/ray_caster.h"
#include "core/timing.h"
#include "format/format.h"

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace apo {

// ---- The unit cube --------------------------------------------------------

// m's bounding box grown by kCubeMargin of its largest side on every side
// (so no triangle touches a face of the cube), centred in the unit cube.
inline constexpr double kCubeMargin = 0.01;
UnitCubeTransform unitCubeAround(const Aabb& box);

// ---- Baking (paper section 3) ---------------------------------------------

struct BakeOptions {
  int coarseDepth = 5;   // the initial octree is complete to this depth (around m)
  int maxDepth = 13;
  // The texture's file may take this many bytes (0: no cap); the octree is
  // refined globally until they are spent or no split helps (docs/bake.md).
  // The default is a 1024 x 1024 RGB normal map's bytes.
  std::uint64_t budget = std::uint64_t{3} << 20;
  double error = 0.0;    // > 0: the paper's L2,1 threshold too, in units of M's mean primitive area
  // Rays reach max(maxDistance x m's bbox diagonal, the cell's diagonal).
  double maxDistance = 0.01;
  int samples = 1;           // ray origins per (leaf, triangle of m): 1, the paper's closest point to the centre; K > 1 stratified
  int completeDepth = -1;    // -1: coarseDepth
  NormalEncoding encoding = NormalEncoding::Oct24;
  // With a budget, leaves may show one normal per side of m (thin parts;
  // format version 4, docs/bake.md "Two-sided leaves"); false: one normal
  // per leaf, as in the paper.
  bool twoSidedLeaves = true;
  // What else stores the octree (docs/bake.md, "Layouts"): with N3Tree, GPU
  // Gems 2's N^3-tree of N = n3Size (2 or 4) of the same octree, beside the
  // APO texture (which the budget counts).
  TextureLayout layout = TextureLayout::Apo;
  int n3Size = 2;
  // > 0: M's points are baked brick by brick, the bricks being the cells of
  // this depth that hold m (docs/bake.md, "Bricks"); 0: in one piece.
  int brickDepth = 0;
};

struct BakePhaseSeconds {
  double setup = 0, build = 0, sample = 0, encode = 0;
};

// How the refinement went (docs/bake.md, "Refinement").
struct RefinementReport {
  std::uint64_t budgetBytes = 0;   // 0: none
  double errorThreshold = 0.0;     // 0: none
  std::string stoppedBy;           // "budget", "error" or "converged"
  double l21 = 0.0;                // sum over the leaves
  double rmsDegrees = 0.0;         // M's normals about their leaf's mean
  std::uint64_t leavesShowingCoarse = 0, twoSidedLeaves = 0, leavesAtMaxDepth = 0;
  std::uint64_t internalNodesShowingCoarse = 0;  // where mip-mapped walks stop, m's normal
  int sumDepth = 0;  // where the metric clipped M's triangles once (octree::sumDepthFor); 0: level by level
};

// The N^3-tree's shape and bytes (layout n3tree).
struct N3TreeReport {
  int n = 0, levels = 0;
  std::uint32_t grids = 0;
  std::array<std::uint32_t, 3> poolCells = {0, 0, 0};  // per axis
  std::uint32_t twoSidedLeaves = 0;
  std::uint64_t bytes = 0;  // indirection pool + LOD pool + sides
  double seconds = 0.0;
};

// How a bake in bricks went (bakeInBricks).
struct BrickReport {
  int depth = 0;
  std::uint64_t bricks = 0;               // cells of the brick depth holding m
  std::uint64_t refinementRuns = 0;       // bricks' builds, retries included
  std::uint64_t recordedCells = 0;        // the metric's errors the whole tree's build read back
  std::uint64_t largestBrickPoints = 0;   // the most points one brick loaded (its margin included)
  std::uint64_t pointsLoaded = 0;         // over every brick and pass
  double marginWorld = 0.0;               // the margin a brick loads around its cell (sampling)
  std::uint64_t journalEntriesReused = 0; // cells' and bricks' work read back from the journal (a resumed bake)
  std::uint64_t journalEntriesWritten = 0;
  std::uint64_t discsWiderThanReach = 0;  // discs whose radius exceeds `reach`: see docs/bake.md, "Bricks"
  double areaSeconds = 0, refineSeconds = 0, sampleSeconds = 0;
};

struct BakeReport {
  std::string detailKind;  // "mesh" or "points"
  std::uint64_t detailPrimitives = 0, coarseTriangles = 0;
  // M a mesh: how far apart its consecutive triangles lie (faceOrderSpread),
  // and whether the bake took them in Morton order (pipeline's bakeApo).
  double detailFaceOrderSpread = 0.0;
  bool detailFacesReordered = false;
  std::vector<std::uint64_t> nodesPerDepth;
  std::uint64_t leaves = 0, internalNodes = 0;
  RefinementReport refinement;
  std::uint64_t rays = 0, hits = 0, fallbacks = 0;  // fallbacks: samples taken by the closest point
  std::uint32_t textureWidth = 0, textureHeight = 0;
  std::uint64_t textureBytes = 0;
  std::optional<N3TreeReport> n3tree;
  std::optional<BrickReport> bricks;
  BakePhaseSeconds seconds;
  double totalSeconds = 0;
  std::uint64_t peakMemoryBytes = 0;
};

struct Bake {
  Octree octree;
  ApoTexture texture;
  std::optional<N3Tree> n3tree;  // layout n3tree
  BakeReport report;
};

// M as the sampler sees it: `detail` is a mesh with unit vertex normals or
// points with unit normals; `caster` hits its triangles (hit.primitive = the
// triangle) or its points' discs (hit.primitive = the point), and may build
// its structure only when asked (only the sampling casts rays on M: it calls
// caster->ready() first, once the octree is built); `closest` answers when
// both rays of a sample miss, and may still be building (closest->ready()).
struct DetailSurface {
  const Scan* detail = nullptr;
  const RayCaster* caster = nullptr;
  const ClosestPointFinder* closest = nullptr;
  // Points only: each point's share of the surface (empty: equal shares).
  // When `awaitPointAreas` is set, they are still being computed (pipeline's
  // bakeApo computes them beside the projection of M onto m): the bake calls
  // it, on its own thread, before it reads them, and fails with its error.
  std::vector<float> pointAreas;
  std::function<Status()> awaitPointAreas;
};

// m as the bake sees it: a triangle mesh and a caster that hits its
// triangles (M is projected onto m along M's normals through it).
struct CoarseSurface {
  const Scan* mesh = nullptr;
  const RayCaster* caster = nullptr;
};

// A Usage error naming the first option out of range, or the options as the
// bake takes them (core/checked.h): checked once, where they enter.
template <>
Result<Checked<BakeOptions>> check(const BakeOptions& options);
// BadInput when m has no triangles, a non-finite vertex or no extent, or M is
// empty, lacks a normal per point (vertex) or has a non-finite one.
Status validateBakeInputs(const Scan& detail, const Scan& coarse);

// The bake against the given seams. Fails as validateBakeInputs does, and
// with an Internal error when a seam fails (the closest-point search could
// not be made). Deterministic whatever the thread count. `onProgress` hears
// the fraction done.
Result<Bake> bakeWith(const DetailSurface& detail, const CoarseSurface& coarse, const Checked<BakeOptions>& options,
                      const ProgressCallback& onProgress = {});

// ---- Baking in bricks (docs/bake.md, "Bricks") ----------------------------

// What a brick of M's points needs from the libraries: its rays' caster,
// its closest-point finder, and each point's area (its share of the
// surface), as the bake in one piece takes them.
struct BrickSearch {
  std::unique_ptr<RayCaster> caster;
  std::unique_ptr<ClosestPointFinder> closest;
  std::vector<float> areas;
};

// Where a bake in bricks keeps each cell's and brick's finished work as it
// goes, so that a bake killed part way resumes from its finished bricks
// (the pipeline: files in the run's scratch folder, docs/bake.md). Entries
// are opaque bytes under a name; `read` gives nullopt for a name never
// written. The caller keeps a journal to one M, m and options.
struct BrickJournal {
  std::function<Result<std::optional<std::string>>(const std::string& name)> read;
  std::function<Status(const std::string& name, const std::string& bytes)> write;
  bool present() const { return read && write; }
};

// M's points, read a box at a time: a scan too large to hold, or a file's
// cells. `pointsIn` gives the points inside a box (world coordinates, bounds
// included), in M's order, with unit normals; `areasOf` each point's area
// among the points given; `searchOver` all three over the points given.
struct BrickedPoints {
  std::uint64_t count = 0;
  std::function<Result<PointSet>(const Aabb& box)> pointsIn;
  std::function<Result<std::vector<float>>(const PointSet& points)> areasOf;
  std::function<Result<BrickSearch>(const PointSet& points)> searchOver;
  BrickJournal journal;  // none by default
};

// The bake of M's points brick by brick (options.brickDepth > 0): only one
// brick's points and search structures are held at a time. The splits are
// those of the bake in one piece (each brick's build records the metric's
// errors, and the whole tree is built from the records), and the leaves are
// sampled brick by brick; the .apo is the one-piece bake's wherever every
// disc and neighbourhood a brick needs lies inside its margin (docs/bake.md).
Result<Bake> bakeInBricks(const BrickedPoints& detail, const CoarseSurface& coarse, const Checked<BakeOptions>& options,
                          const ProgressCallback& onProgress = {});

// One task's share of a bake in bricks split across tasks (a Slurm job
// array, docs/cluster.md "One scan across tasks"): in its pass, the task
// does the cells (pass 1) or bricks (passes 2 and 3) whose index modulo
// `tasks` is `task`, and writes them to the journal, which the tasks share;
// what earlier passes did comes from the journal. Once every task of the
// three passes is done, bakeInBricks over the same journal reads everything
// back and gives the .apo of the bake in one go.
struct BrickShare {
  enum class Pass { Areas = 1, Records = 2, Samples = 3 };
  Pass pass = Pass::Areas;
  std::uint32_t task = 0, tasks = 1;
};
const char* passName(BrickShare::Pass pass);  // "areas", "records", "samples"
std::optional<BrickShare::Pass> passNamed(std::string_view name);

// Usage error without a journal or with task >= tasks; BadInput when an
// earlier pass's entry is missing from the journal; fails as bakeInBricks.
Result<BrickReport> bakeShareOfBricks(const BrickedPoints& detail, const CoarseSurface& coarse,
                                      const Checked<BakeOptions>& options, const BrickShare& share,
                                      const ProgressCallback& onProgress = {});

std::string bakeReportJson(const BakeReport& report);  // bake.json, format_version 2

}  // namespace apo
