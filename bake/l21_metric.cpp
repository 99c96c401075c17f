// The L2,1 metric (l21_metric.h): a cell's sums from M's triangles clipped
// into it or from M's points in it, the leaf errors they give, and M's
// triangles summed once at a fine depth.
#include "bake/l21_metric.h"

#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <tuple>

namespace apo::octree {
namespace {

constexpr int kPointKeyDepth = 16;  // bake's deepest octree
constexpr std::uint64_t kOutsideTheCube = ~std::uint64_t{0};  // sorted last, in no cell's run

// The part of triangle `m` of M inside the cell, added with its
// interpolated normals (a part in a face between cells is the lower cell's,
// as GridSweep files it). The part's integrals come from its moments in the
// triangle's own coordinates, exactly for the linear fields.
void addTriangleInCell(const MetricTriangle& m, const Cell& cell, VariationSums& sums) {
  GridSweep(m.frame, gridInside(cell, 0)).run(kEveryCell, [&](const GridPart& part) { sums.addPart(m, momentsOf(part)); });
}

// A point on a face between two cells belongs to the lower one, as in the
// lookup's walk (format.h, childIndex); the first cell of an axis takes its
// lower face.
std::uint64_t pointKey(const Vec3f& p) {
  if (!insideUnitCube({p, p})) return kOutsideTheCube;
  constexpr float kCells = static_cast<float>(1u << kPointKeyDepth);
  const auto grid = [&](float x) { return static_cast<std::uint32_t>(std::max(std::ceil(x * kCells) - 1.0f, 0.0f)); };
  return mortonCode(grid(p.x()), grid(p.y()), grid(p.z()));
}

// The deepest level whose cells are at least this many times as wide as M's
// triangles (their mean longest side) is where the metric clips M once, and
// the levels above add its cells' sums (FineSums). Level by level, the 1.2M
// bunny's build clipped 7.7M pieces of M down to that depth (8), of 11.5M in
// all; once at it, 2.8M. Wider cells leave more levels to clip, narrower
// ones cut each triangle into more pieces: the rule picks the fastest of
// three depths on both the bunny (8) and the 7.2M torus (9)
// (docs/bake.md, "A faster build").
constexpr double kSumCellOverTriangle = 2.0;
// Where M's triangles differ in size (a few large ones, a floor under a
// scanned object, among many small ones), the depth the mean picks would
// cut the large ones into many pieces: the sum depth rises until the
// triangles' pieces there are at most this many per triangle, twice what
// triangles of one size give at the chosen depth ((1 + 1/2)^2; the bunny
// 2.25, the torus 2.09, estimated as sumDepthFor does; 2.3 counted).
constexpr double kMostPiecesPerTriangle = 4.5;

// A stable sort by key (`keyBits` bits), least significant digit first,
// 11 bits a pass: one or two passes over the pieces, where std::sort by
// (key, triangle) took 2% of the 1.2M bunny's bake (docs/benchmarks.md).
void sortByCell(std::vector<FineSums::Scratch::Piece>& pieces, std::vector<FineSums::Scratch::Piece>& spare, int keyBits) {
  constexpr int kDigitBits = 11;
  spare.resize(pieces.size());
  for (int shift = 0; shift < keyBits; shift += kDigitBits) {
    std::array<std::uint32_t, (1u << kDigitBits) + 1> start{};
    const auto digit = [&](const FineSums::Scratch::Piece& piece) { return (piece.key >> shift) & ((1u << kDigitBits) - 1); };
    for (const FineSums::Scratch::Piece& piece : pieces) ++start[digit(piece) + 1];
    for (std::size_t d = 1; d < start.size(); ++d) start[d] += start[d - 1];
    for (const FineSums::Scratch::Piece& piece : pieces) spare[start[digit(piece)]++] = piece;
    pieces.swap(spare);
  }
}

// The grid coordinates at `depth` of the coarse cell's lower corner.
std::array<int, 3> gridOrigin(const Cell& cell, int depth) {
  const Vec3f lower = cell.lower() * std::ldexp(1.0f, depth);  // exact: dyadic
  return {static_cast<int>(lower.x()), static_cast<int>(lower.y()), static_cast<int>(lower.z())};
}

}  // namespace

std::pair<int, double> VariationSums::bestTwoSides() const {
  constexpr double kRounding = 1e-9;
  std::pair<int, double> best{0, std::numeric_limits<double>::infinity()};
  for (int axis = 0; axis < 3; ++axis) {
    const double error = sideZero[axis].l21() + (all - sideZero[axis]).l21();
    if (error < best.second * (1.0 - kRounding)) best = {axis, error};
  }
  return best;
}

LeafError leafErrorOf(const VariationSums& sums, bool withCoarse, bool deferToCoarse, bool twoSides) {
  LeafError error{sums.l21(), sums.coarse, sums.all.area};
  error.deferToCoarse = deferToCoarse && withCoarse;
  if (twoSides && withCoarse) std::tie(error.sideAxis, error.twoSided) = sums.bestTwoSides();
  return error;
}

void addWeightedNormal(float weight, const Vec3f& normalOfM, const Vec3f* normalOfCoarse, VariationSums& sums) {
  const double w = weight;
  const Eigen::Vector3d normal = normalOfM.cast<double>();
  if (!normalOfCoarse) {
    sums.add(w, w * normal, w * normal.squaredNorm(), nullptr);
    return;
  }
  const Eigen::Vector3d coarse = normalOfCoarse->cast<double>();
  sums.add(w, w * normal, w * normal.squaredNorm(), &coarse);
  sums.coarse += w * (normal - coarse).squaredNorm();
}

LeafError errorInCell(const DetailPrimitives& detail, std::span<const std::uint32_t> primitives, const Cell& cell,
                      bool deferToCoarse, bool twoSides) {
  VariationSums sums;
  const bool withCoarse = detail.coarseKnown;
  for (const std::uint32_t i : primitives) {
    if (detail.triangles.empty()) {
      addWeightedNormal(detail.weights[i], detail.normals[i], withCoarse ? &detail.coarseNormals[i] : nullptr, sums);
    } else {
      addTriangleInCell(MetricTriangle(detail, detail.triangles[i]), cell, sums);
    }
  }
  return leafErrorOf(sums, withCoarse, deferToCoarse, twoSides);
}

double normalVariation(const DetailPrimitives& detail, const std::vector<std::uint32_t>& primitives, const Cell& cell) {
  return errorInCell(detail, primitives, cell, false, false).variation;
}

KeyRun runOfCell(const std::vector<std::uint64_t>& keys, const Cell& cell, const Cell& frame, int keyDepth,
                 KeyRun within) {
  const Vec3f corner = (cell.lower() - frame.lower()) * std::ldexp(1.0f, cell.depth);  // exact: dyadic
  const std::uint64_t code = mortonCode(static_cast<std::uint32_t>(corner.x()), static_cast<std::uint32_t>(corner.y()),
                                        static_cast<std::uint32_t>(corner.z()));
  const int shift = 3 * (keyDepth - cell.depth);
  const auto begin = keys.begin() + within.first, stop = keys.begin() + within.end;
  const auto first = std::lower_bound(begin, stop, code << shift);
  const auto end = std::lower_bound(first, stop, (code + 1) << shift);
  return {static_cast<std::uint32_t>(first - keys.begin()), static_cast<std::uint32_t>(end - keys.begin())};
}

PointOrder::PointOrder(const DetailPrimitives& d) {
    const std::size_t n = d.positions.size();
    std::vector<std::pair<std::uint64_t, std::uint32_t>> sorted(n);
    tbb::parallel_for(std::size_t{0}, n, [&](std::size_t i) {
      sorted[i] = {pointKey(d.positions[i]), static_cast<std::uint32_t>(i)};
    });
    tbb::parallel_sort(sorted.begin(), sorted.end());  // distinct pairs: one order whatever the threads
    keys_.resize(n);
    records_.resize(n);
    tbb::parallel_for(std::size_t{0}, n, [&](std::size_t k) {
      const std::uint32_t i = sorted[k].second;
      keys_[k] = sorted[k].first;
      records_[k] = {d.normals[i], d.weights[i], d.coarseKnown ? d.coarseNormals[i] : Vec3f(Vec3f::Zero())};
    });
    coarseKnown_ = d.coarseKnown;
  }

KeyRun PointOrder::runOf(const Cell& cell, KeyRun within) const {
  return runOfCell(keys_, cell, Cell{}, kPointKeyDepth, within);
}

VariationSums PointOrder::sumsOf(KeyRun run) const {
  VariationSums sums;
  for (std::uint32_t k = run.first; k < run.end; ++k) {
    const Record& r = records_[k];
    addWeightedNormal(r.weight, r.normal, coarseKnown_ ? &r.coarse : nullptr, sums);
  }
  return sums;
}

FineSums::FineSums(const DetailPrimitives& d, const IdList& triangles, const Cell& coarseCell, int sumDepth,
                   Scratch& scratch)
    : coarse_(coarseCell), levels_(sumDepth - coarseCell.depth) {
  clipIntoFineCells(d, triangles, sumDepth, scratch);
  addUpByCell(scratch);
}

KeyRun FineSums::runOf(const Cell& cell, KeyRun within) const {
  return runOfCell(keys_, cell, coarse_, coarse_.depth + levels_, within);
}

VariationSums FineSums::sumsOf(KeyRun run) const {
  VariationSums sums;
  for (std::uint32_t k = run.first; k < run.end; ++k) sums += sums_[k];
  return sums;
}

IdList FineSums::trianglesOf(KeyRun run) const {
  if (run.first == run.end) return {};
  return IdList(triangles_.begin() + begin_[run.first], triangles_.begin() + begin_[run.end]);
}

// Every triangle's pieces in the fine cells its box meets (a cell it only
// touches takes none), with their sums.
void FineSums::clipIntoFineCells(const DetailPrimitives& d, const IdList& triangles, int sumDepth, Scratch& scratch) const {
  scratch.pieces.clear();
  scratch.sums.clear();
  const int cellsPerAxis = 1 << sumDepth;
  const float width = std::ldexp(1.0f, -sumDepth);
  const std::array<int, 3> origin = gridOrigin(coarse_, sumDepth);
  const int side = 1 << levels_;
  for (const std::uint32_t t : triangles) {
    const MetricTriangle triangle(d, d.triangles[t]);
    const GridRange range = gridRange(triangle.bounds(), cellsPerAxis);
    GridAxes grid;
    bool empty = false;
    for (int axis = 0; axis < 3; ++axis) {
      const int first = std::max(range.first[axis], origin[axis]);
      const int last = std::min(range.last[axis], origin[axis] + side - 1);
      grid[axis] = {first, last - first + 1, width};
      empty = empty || last < first;
    }
    if (empty) continue;
    GridSweep(triangle.frame, grid).run(kEveryCell, [&](const GridPart& part) {
      scratch.sums.emplace_back().addPart(triangle, momentsOf(part));
      const std::uint64_t key = mortonCode(static_cast<std::uint32_t>(grid[0].first + part.cell[0] - origin[0]),
                                           static_cast<std::uint32_t>(grid[1].first + part.cell[1] - origin[1]),
                                           static_cast<std::uint32_t>(grid[2].first + part.cell[2] - origin[2]));
      scratch.pieces.push_back({key, t, static_cast<std::uint32_t>(scratch.sums.size() - 1)});
    });
  }
}

// The pieces grouped by cell and added up in (cell, triangle) order: the
// triangles come in increasing order, and the sort by cell keeps it.
void FineSums::addUpByCell(Scratch& scratch) {
  sortByCell(scratch.pieces, scratch.spare, 3 * levels_);
  const std::vector<Scratch::Piece>& pieces = scratch.pieces;
  std::size_t cells = 0;
  for (std::size_t k = 0; k < pieces.size(); ++k) cells += k == 0 || pieces[k].key != pieces[k - 1].key ? 1 : 0;
  keys_.reserve(cells);
  sums_.reserve(cells);
  begin_.reserve(cells + 1);
  triangles_.reserve(pieces.size());
  for (const Scratch::Piece& piece : pieces) {
    if (keys_.empty() || keys_.back() != piece.key) {
      keys_.push_back(piece.key);
      sums_.emplace_back();
      begin_.push_back(static_cast<std::uint32_t>(triangles_.size()));
    }
    sums_.back() += scratch.sums[piece.sums];
    triangles_.push_back(piece.triangle);
  }
  begin_.push_back(static_cast<std::uint32_t>(triangles_.size()));
}

int sumDepthFor(const DetailPrimitives& detail, const BuildSettings& settings) {
  if (detail.triangles.empty() || settings.sumDepth == 0) return 0;
  int depth = settings.sumDepth;
  if (depth < 0) {
    // Sums of each triangle's longest side along an axis, and of its square.
    double sides = 0.0, squares = 0.0;
    for (const DetailTriangle& t : detail.triangles) {
      const Bounds b = triangleBounds(t.corners[0], t.corners[1], t.corners[2]);
      const double side = (b.hi - b.lo).maxCoeff();
      sides += side;
      squares += side * side;
    }
    const double count = static_cast<double>(detail.triangles.size());
    const double mean = sides / count;
    depth = mean > 0.0 ? static_cast<int>(std::floor(std::log2(1.0 / (kSumCellOverTriangle * mean)))) : settings.maxDepth;
    depth = std::min(depth, settings.maxDepth);
    // The cells a triangle of side e meets at depth d, on a surface: about
    // (1 + e 2^d)^2.
    const auto piecesPerTriangle = [&](int d) {
      const double cellsPerUnit = std::ldexp(1.0, d);
      return 1.0 + 2.0 * cellsPerUnit * sides / count + cellsPerUnit * cellsPerUnit * squares / count;
    };
    while (depth > settings.coarseDepth && piecesPerTriangle(depth) > kMostPiecesPerTriangle) --depth;
  }
  depth = std::min(depth, settings.maxDepth);
  return depth > settings.coarseDepth ? depth : 0;
}

CellId cellIdOf(const Cell& cell) {
  // Centres and widths are exact in float down to depth 16 (dyadic).
  const Vec3f corner = cell.lower() / cell.width;
  const int x = static_cast<int>(std::lround(corner.x())), y = static_cast<int>(std::lround(corner.y())),
            z = static_cast<int>(std::lround(corner.z()));
  return (static_cast<CellId>(cell.depth) << kCellIdDepthShift) | gridKey(x, y, z, cell.depth);
}

CellId ancestorId(CellId cell, int depth) {
  const int own = static_cast<int>(cell >> kCellIdDepthShift);
  const auto xyz = gridCoordinates(cell & ((CellId{1} << kCellIdDepthShift) - 1), own);
  const int up = own - depth;
  return (static_cast<CellId>(depth) << kCellIdDepthShift) | gridKey(xyz[0] >> up, xyz[1] >> up, xyz[2] >> up, depth);
}

void RecordedErrors::add(const std::vector<std::pair<CellId, LeafError>>& found) {
  records_.insert(records_.end(), found.begin(), found.end());
}

void RecordedErrors::seal() {
  const auto byCell = [](const auto& a, const auto& b) { return a.first < b.first; };
  // The new records sorted, then merged with the sorted ones: stable, so a
  // cell keeps its first record.
  std::stable_sort(records_.begin() + static_cast<std::ptrdiff_t>(sealed_), records_.end(), byCell);
  std::inplace_merge(records_.begin(), records_.begin() + static_cast<std::ptrdiff_t>(sealed_), records_.end(), byCell);
  records_.erase(std::unique(records_.begin(), records_.end(), [](const auto& a, const auto& b) { return a.first == b.first; }),
                 records_.end());
  sealed_ = records_.size();
}

const LeafError* RecordedErrors::find(CellId cell) const {
  const auto end = records_.begin() + static_cast<std::ptrdiff_t>(sealed_);
  const auto at = std::lower_bound(records_.begin(), end, cell, [](const auto& r, CellId c) { return r.first < c; });
  return at != end && at->first == cell ? &at->second : nullptr;
}

std::optional<CellId> pointCellId(const Vec3f& p, int depth) {
  if (!insideUnitCube({p, p})) return std::nullopt;
  constexpr float kCells = static_cast<float>(1u << kPointKeyDepth);
  // As pointKey grids it, so that the cell's run of PointOrder holds the point.
  const auto grid = [&](float x) {
    return static_cast<int>(static_cast<std::uint32_t>(std::max(std::ceil(x * kCells) - 1.0f, 0.0f)) >>
                            (kPointKeyDepth - depth));
  };
  return (static_cast<CellId>(depth) << kCellIdDepthShift) | gridKey(grid(p.x()), grid(p.y()), grid(p.z()), depth);
}

}  // namespace apo::octree
