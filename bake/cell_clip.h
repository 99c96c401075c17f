// Inside bake: triangles against the octree's cells (paper 3.1). The exact
// overlap of a triangle and a closed box, the part of a triangle inside a
// cell, the sweep that cuts a triangle into the cells of a grid in its own
// (u, v) coordinates (the pieces the L2,1 metric integrates), and the
// binning of m's and M's triangles into the coarse grid. Unit-cube
// coordinates throughout.
//
// The clipping helpers, GridSweep and the grid's small helpers are defined
// here, inline: the metric and the refinement's evaluation call them for
// every piece of M, the binning for every (triangle, cell) pair, and a call
// into another unit for each would cost the build what one unit's inlining
// spared it.
#pragma once

#include "bake/octree_build.h"

#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>
#include <tbb/scalable_allocator.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <span>
#include <utility>
#include <vector>

namespace apo::octree {

// A list of primitives (m's or M's triangles, by index). Hundreds of
// thousands are made on the evaluating threads and freed on the main one;
// glibc's allocator spent a tenth of the 1.2M-triangle build freeing them
// (docs/bake.md, "A faster build"), TBB's scalable allocator keeps
// per-thread free lists.
using IdList = std::vector<std::uint32_t, tbb::scalable_allocator<std::uint32_t>>;

// Exact triangle / closed box overlap by the separating axis theorem
// (Akenine-Moller 2001): 3 box axes, the triangle normal, 9 edge crossings.
bool triangleOverlapsBox(const Vec3f& a, const Vec3f& b, const Vec3f& c, const Cell& cell);

// The children of `cell` among `wanted` (bit c: child c) whose closed boxes
// meet triangle abc, as triangleOverlapsBox answers for each: its test made
// once for the eight, each child whose answer is within rounding tested
// apart. Testing each child apart projected the corners again for each: m's
// triangles, tested against the children and grandchildren of every leaf
// evaluated, took 7% of the 1.2M bunny's bake so (docs/benchmarks.md).
std::uint8_t childrenMeeting(const Vec3f& a, const Vec3f& b, const Vec3f& c, const Cell& cell,
                             std::uint8_t wanted = 0xFF);

// The part of triangle abc inside the cell (Sutherland-Hodgman against the
// six faces): a convex polygon of up to 9 corners, none when they miss. In
// place: the sampling clips each of m's triangles to each leaf it is in.
struct CellPolygon {
  std::array<Vec3f, 9> corners;
  int size = 0;
  std::span<const Vec3f> view() const { return {corners.data(), static_cast<std::size_t>(size)}; }
};
CellPolygon clipTriangleToCell(const Vec3f& a, const Vec3f& b, const Vec3f& c, const Cell& cell);
double polygonArea(std::span<const Vec3f> polygon);

// Barycentric weights of p (on or near triangle abc) in abc, clamped to the
// triangle.
Eigen::Vector3f barycentricsOf(const Vec3f& p, const Vec3f& a, const Vec3f& b, const Vec3f& c);

// ---- Clipping in a triangle's own coordinates -----------------------------

// A triangle abc in its own coordinates: p(u, v) = a + u (b - a) + v (c - a).
// The part of it inside a box is a convex polygon of that (u, v) plane, cut
// from the unit triangle by the box's faces: each face adds at most one
// corner, so 9 at most. Fixed storage: the error metric clips millions of
// triangles and would otherwise spend its time allocating.
struct ParameterPolygon {
  std::array<Eigen::Vector2d, 9> corners;
  int size = 0;
};

// Keeps the part of `polygon` where offset + u alongU + v alongV <= 0.
inline void clipAgainstLine(const ParameterPolygon& polygon, double offset, double alongU, double alongV,
                            ParameterPolygon& clipped) {
  std::array<double, 9> side;
  const int n = polygon.size;
  for (int i = 0; i < n; ++i) side[i] = offset + polygon.corners[i].x() * alongU + polygon.corners[i].y() * alongV;
  clipped.size = 0;
  for (int i = 0; i < n; ++i) {
    const int next = i + 1 == n ? 0 : i + 1;
    const double dp = side[i], dq = side[next];
    if (dp <= 0.0) clipped.corners[clipped.size++] = polygon.corners[i];
    if ((dp < 0.0 && dq > 0.0) || (dp > 0.0 && dq < 0.0))
      clipped.corners[clipped.size++] = polygon.corners[i] + (polygon.corners[next] - polygon.corners[i]) * (dp / (dp - dq));
  }
}

// Splits `polygon` at the line offset + u alongU + v alongV = 0: `below`
// keeps where that is <= 0, `above` where it is >= 0; as clipAgainstLine
// on each side, in one pass.
inline void splitAtLine(const ParameterPolygon& polygon, double offset, double alongU, double alongV,
                        ParameterPolygon& below, ParameterPolygon& above) {
  std::array<double, 9> side;
  const int n = polygon.size;
  for (int i = 0; i < n; ++i) side[i] = offset + polygon.corners[i].x() * alongU + polygon.corners[i].y() * alongV;
  below.size = 0;
  above.size = 0;
  for (int i = 0; i < n; ++i) {
    const int next = i + 1 == n ? 0 : i + 1;
    const double dp = side[i], dq = side[next];
    if (dp <= 0.0) below.corners[below.size++] = polygon.corners[i];
    if (dp >= 0.0) above.corners[above.size++] = polygon.corners[i];
    if ((dp < 0.0 && dq > 0.0) || (dp > 0.0 && dq < 0.0)) {
      const Eigen::Vector2d crossing = polygon.corners[i] + (polygon.corners[next] - polygon.corners[i]) * (dp / (dp - dq));
      below.corners[below.size++] = crossing;
      above.corners[above.size++] = crossing;
    }
  }
}

// Triangle abc's corners' bounds and its own (u, v) frame, p(u, v) = origin
// + u alongU + v alongV, in double: what every clip of it needs.
struct TriangleFrame {
  Vec3f lo, hi;
  Eigen::Vector3d origin, alongU, alongV;

  TriangleFrame(const Vec3f& a, const Vec3f& b, const Vec3f& c)
      : lo(a.cwiseMin(b).cwiseMin(c)),
        hi(a.cwiseMax(b).cwiseMax(c)),
        origin(a.cast<double>()),
        alongU((b - a).cast<double>()),
        alongV((c - a).cast<double>()) {}
};

// A row of cells along one axis of a grid: cell i spans the planes
// (first + i) width and (first + i + 1) width (dyadic: exact in float, as
// Cell's bounds are).
struct GridAxis {
  int first = 0, count = 1;
  float width = 1.0f;

  double plane(int i) const { return static_cast<float>(first + i) * width; }
};
using GridAxes = std::array<GridAxis, 3>;

// The cells `levels` deeper than `cell` inside it, as a grid.
inline GridAxes gridInside(const Cell& cell, int levels) {
  const int depth = cell.depth + levels;
  const Vec3f lower = cell.lower() * std::ldexp(1.0f, depth);  // exact: dyadic
  const float width = std::ldexp(1.0f, -depth);
  const int count = 1 << levels;
  return {GridAxis{static_cast<int>(lower.x()), count, width}, GridAxis{static_cast<int>(lower.y()), count, width},
          GridAxis{static_cast<int>(lower.z()), count, width}};
}

// A triangle's part in one cell of a grid: its (u, v) polygon, and whether
// no plane cut it (the whole triangle, whose moments are known exactly).
struct GridPart {
  std::array<int, 3> cell;
  const ParameterPolygon* polygon;
  bool whole;
};

// GridSweep's `wanted` for every cell of its grid.
inline constexpr auto kEveryCell = [](int, const std::array<int, 3>&) { return true; };

// Cuts a triangle into the cells of a grid, axis by axis: each piece is cut
// once at each plane it crosses, where clipping the triangle to each cell
// apart cut it again for every cell (each clip of a cell starting from the
// whole triangle). A piece lying in a plane between two cells is the lower
// one's, as a point there is the lookup's (format.h, childIndex), and the
// cube's lower face the first cell's: it is counted once, where clipping
// to each cell counted it in both. A piece without area (fewer than three
// corners) goes to none. `wanted(axis, cell)` says whether any cell with
// these coordinates up to `axis` is wanted; `visit(part)` takes every part
// with an area in a wanted cell.
class GridSweep {
 public:
  GridSweep(const TriangleFrame& frame, const GridAxes& grid) : frame_(frame), grid_(grid) {}

  template <class Wanted, class Visit>
  void run(Wanted wanted, Visit visit) {
    ParameterPolygon whole;
    whole.corners[0] = Eigen::Vector2d(0.0, 0.0);
    whole.corners[1] = Eigen::Vector2d(1.0, 0.0);
    whole.corners[2] = Eigen::Vector2d(0.0, 1.0);
    whole.size = 3;
    sweep(0, whole, true, {0, 0, 0}, wanted, visit);
  }

 private:
  // Keeps the part of `polygon` below (sign 1) or above (sign -1) the plane
  // where the coordinate `axis` is `bound`.
  void keepSide(const ParameterPolygon& polygon, int axis, double bound, double sign, ParameterPolygon& kept) const {
    clipAgainstLine(polygon, sign * (frame_.origin[axis] - bound), sign * frame_.alongU[axis],
                    sign * frame_.alongV[axis], kept);
  }

  std::pair<double, double> extentOf(const ParameterPolygon& polygon, int axis) const {
    double lo = std::numeric_limits<double>::infinity(), hi = -lo;
    for (int i = 0; i < polygon.size; ++i) {
      const double x = frame_.origin[axis] + polygon.corners[i].x() * frame_.alongU[axis] +
                       polygon.corners[i].y() * frame_.alongV[axis];
      lo = std::min(lo, x);
      hi = std::max(hi, x);
    }
    return {lo, hi};
  }

  template <class Wanted, class Visit>
  void sweep(int axis, const ParameterPolygon& polygon, bool whole, std::array<int, 3> cell, Wanted& wanted,
             Visit& visit) {
    const GridAxis& row = grid_[axis];
    const auto [lo, hi] = extentOf(polygon, axis);
    std::array<ParameterPolygon, 3> buffers;
    const ParameterPolygon* rest = &polygon;  // the piece not yet filed, from cell i on
    int free = 0;
    const auto cut = [&](double bound, double sign) -> ParameterPolygon* {
      ParameterPolygon* kept = &buffers[free];
      free = (free + 1) % 3;
      keepSide(*rest, axis, bound, sign, *kept);
      whole = false;
      return kept;
    };
    // In the grid's lower face: the cell below's, but at the cube's.
    if (hi <= row.plane(0) && row.plane(0) > 0.0) return;
    if (lo < row.plane(0)) rest = cut(row.plane(0), -1.0);
    if (hi > row.plane(row.count) && rest->size >= 3) rest = cut(row.plane(row.count), 1.0);
    for (int i = 0; i < row.count && rest->size >= 3; ++i) {
      const double upper = row.plane(i + 1);
      const bool last = hi <= upper || i + 1 == row.count;
      if (!last && lo >= upper) continue;  // nothing of it below this cell's upper plane
      cell[axis] = i;
      const ParameterPolygon* part = rest;
      if (!last) {
        ParameterPolygon* below = &buffers[free];
        ParameterPolygon* above = &buffers[(free + 1) % 3];
        free = (free + 2) % 3;
        splitAtLine(*rest, frame_.origin[axis] - upper, frame_.alongU[axis], frame_.alongV[axis], *below, *above);
        whole = false;
        rest = above;
        part = below;
      }
      if (part->size >= 3 && wanted(axis, cell)) {
        if (axis == 2)
          visit(GridPart{cell, part, whole});
        else
          sweep(axis + 1, *part, whole, cell, wanted, visit);
      }
      if (last) break;
    }
  }

  const TriangleFrame& frame_;
  const GridAxes& grid_;
};

// ---- The coarse grid ------------------------------------------------------

struct Bounds {
  Vec3f lo, hi;
};

inline Bounds triangleBounds(const Vec3f& a, const Vec3f& b, const Vec3f& c) {
  return {a.cwiseMin(b).cwiseMin(c), a.cwiseMax(b).cwiseMax(c)};
}

inline bool insideUnitCube(const Bounds& b) {
  return (b.lo.array() >= 0.0f).all() && (b.hi.array() <= 1.0f).all();
}

// Grid coordinates at depth d of the cells whose closed boxes can meet
// [lo, hi] (a value on a cell boundary belongs to both cells).
struct GridRange {
  std::array<int, 3> first, last;
};

inline GridRange gridRange(const Bounds& b, int cellsPerAxis) {
  GridRange range{};
  const float n = static_cast<float>(cellsPerAxis);
  for (int axis = 0; axis < 3; ++axis) {
    range.first[axis] = std::clamp(static_cast<int>(std::ceil(b.lo[axis] * n)) - 1, 0, cellsPerAxis - 1);
    range.last[axis] = std::clamp(static_cast<int>(std::floor(b.hi[axis] * n)), 0, cellsPerAxis - 1);
  }
  return range;
}

// A cell of the grid of some depth by its coordinates, x's bits highest.
using GridKey = std::uint64_t;

inline GridKey gridKey(int x, int y, int z, int depth) {
  return (static_cast<GridKey>(x) << (2 * depth)) | (static_cast<GridKey>(y) << depth) | static_cast<GridKey>(z);
}

inline std::array<int, 3> gridCoordinates(GridKey key, int depth) {
  const GridKey mask = (GridKey{1} << depth) - 1;
  return {static_cast<int>(key >> (2 * depth)), static_cast<int>((key >> depth) & mask), static_cast<int>(key & mask)};
}

inline Cell gridCell(GridKey key, int depth) {
  const auto xyz = gridCoordinates(key, depth);
  const float width = std::ldexp(1.0f, -depth);
  return {Vec3f((xyz[0] + 0.5f) * width, (xyz[1] + 0.5f) * width, (xyz[2] + 0.5f) * width), width, depth};
}

// (tag, primitive) for every coarse cell a primitive overlaps, where
// `tagOf(key)` gives the cell a tag (none: the cell is not wanted); one list
// per 4096 primitives, in the primitives' order.
template <class BoundsOf, class Overlaps, class TagOf>
std::vector<std::vector<std::pair<std::uint64_t, std::uint32_t>>> overlapsByChunk(std::size_t count, int depth,
                                                                                  BoundsOf boundsOf, Overlaps overlaps,
                                                                                  TagOf tagOf) {
  const int n = 1 << depth;
  std::vector<std::vector<std::pair<std::uint64_t, std::uint32_t>>> perChunk((count + 4095) / 4096);
  tbb::parallel_for(std::size_t{0}, perChunk.size(), [&](std::size_t chunk) {
    auto& pairs = perChunk[chunk];
    for (std::size_t i = chunk * 4096; i < std::min(count, (chunk + 1) * 4096); ++i) {
      const auto p = static_cast<std::uint32_t>(i);
      const Bounds bounds = boundsOf(p);
      const GridRange r = gridRange(bounds, n);
      // Bounds inside one closed cell: the primitive surely overlaps it.
      const bool single = r.first == r.last && insideUnitCube(bounds);
      for (int x = r.first[0]; x <= r.last[0]; ++x)
        for (int y = r.first[1]; y <= r.last[1]; ++y)
          for (int z = r.first[2]; z <= r.last[2]; ++z) {
            const GridKey key = gridKey(x, y, z, depth);
            const std::optional<std::uint64_t> tag = tagOf(key);
            if (tag && (single || overlaps(p, gridCell(key, depth)))) pairs.emplace_back(*tag, p);
          }
    }
  });
  return perChunk;
}

// (cell key, primitive) for every coarse cell a primitive overlaps, sorted:
// grouped by cell, primitives in increasing order within a cell.
template <class BoundsOf, class Overlaps>
std::vector<std::pair<GridKey, std::uint32_t>> binIntoGrid(std::size_t count, int depth, BoundsOf boundsOf,
                                                           Overlaps overlaps) {
  const auto perChunk =
      overlapsByChunk(count, depth, boundsOf, overlaps, [](GridKey key) { return std::optional<std::uint64_t>(key); });
  std::vector<std::pair<GridKey, std::uint32_t>> all;
  for (const auto& pairs : perChunk) all.insert(all.end(), pairs.begin(), pairs.end());
  tbb::parallel_sort(all.begin(), all.end());
  return all;
}

// The primitives overlapping each of `cells` (sorted keys), in increasing
// order: counted per cell, then filed chunk by chunk. Sorting the 1.2M
// bunny's 1.4M (cell, triangle) pairs and grouping them took 0.07 s, the
// grouping on one core (docs/benchmarks.md).
template <class BoundsOf, class Overlaps>
std::vector<IdList> binIntoCells(const std::vector<GridKey>& cells, std::size_t count, int depth, BoundsOf boundsOf,
                                 Overlaps overlaps) {
  // Each cell's index looked up in a table of the whole grid when it is
  // small (8 MiB at most), by a binary search otherwise.
  constexpr int kDeepestTable = 7;
  std::vector<std::int32_t> indexOf(depth <= kDeepestTable ? std::size_t{1} << (3 * depth) : 0, -1);
  for (std::size_t i = 0; i < cells.size() && !indexOf.empty(); ++i) indexOf[cells[i]] = static_cast<std::int32_t>(i);
  const auto perChunk = overlapsByChunk(count, depth, boundsOf, overlaps, [&](GridKey key) {
    if (!indexOf.empty())
      return indexOf[key] >= 0 ? std::optional<std::uint64_t>(indexOf[key]) : std::nullopt;
    const auto found = std::lower_bound(cells.begin(), cells.end(), key);
    return found != cells.end() && *found == key ? std::optional<std::uint64_t>(found - cells.begin()) : std::nullopt;
  });
  std::vector<std::size_t> sizes(cells.size(), 0);
  for (const auto& pairs : perChunk)
    for (const auto& [cell, primitive] : pairs) ++sizes[cell];
  std::vector<IdList> members(cells.size());
  for (std::size_t cell = 0; cell < cells.size(); ++cell) members[cell].reserve(sizes[cell]);
  for (const auto& pairs : perChunk)
    for (const auto& [cell, primitive] : pairs) members[cell].push_back(primitive);
  return members;
}

}  // namespace apo::octree
