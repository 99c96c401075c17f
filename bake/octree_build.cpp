// The adaptive octree of paper section 3.1. The levels down to the coarse
// depth are found by binning m's triangles into the coarse grid at once; the
// tree is then refined globally by the L2,1 criterion (docs/bake.md,
// "Refinement"): the leaves' splits are evaluated ahead, moving m's and M's
// primitives down into the children they overlap, and made in order of the
// error they remove per texel, until the texel budget is spent.
#include "bake/octree_build.h"

#include <boost/container/small_vector.hpp>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>
#include <tbb/task_group.h>
#include <tbb/scalable_allocator.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>
#include <numeric>
#include <optional>
#include <span>
#include <tuple>
#include <utility>

namespace apo::octree {
namespace {

// A leaf's lists of m's and M's triangles. Hundreds of thousands are made on
// the evaluating threads and freed on the main one; glibc's allocator spent
// a tenth of the 1.2M-triangle build freeing them (docs/benchmarks.md, "A
// faster build"), TBB's scalable allocator keeps per-thread free lists.
using IdList = std::vector<std::uint32_t, tbb::scalable_allocator<std::uint32_t>>;

// A leaf's list of m's triangles, held in the leaf up to two: 96% of the
// 1.2M bunny's leaves hold one or two, and their lists' allocations were
// most of the evaluations' (docs/benchmarks.md).
using CoarseIdList = boost::container::small_vector<std::uint32_t, 2, tbb::scalable_allocator<std::uint32_t>>;

// ---- Geometry -------------------------------------------------------------

// Projections of the three corners on `axis` against the box's radius on it.
bool separatedOn(const Vec3f& axis, const Vec3f& v0, const Vec3f& v1, const Vec3f& v2, const Vec3f& half) {
  const float p0 = axis.dot(v0), p1 = axis.dot(v1), p2 = axis.dot(v2);
  const float radius = half.dot(axis.cwiseAbs());
  return std::min({p0, p1, p2}) > radius || std::max({p0, p1, p2}) < -radius;
}

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
void clipAgainstLine(const ParameterPolygon& polygon, double offset, double alongU, double alongV,
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
void splitAtLine(const ParameterPolygon& polygon, double offset, double alongU, double alongV, ParameterPolygon& below,
                 ParameterPolygon& above) {
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

// The part of the triangle inside the cell, in its (u, v) coordinates.
// Only the faces the triangle crosses cut: most triangles filed into a child
// cross one or two of its six faces.
ParameterPolygon clipInParameters(const TriangleFrame& frame, const Cell& cell) {
  std::array<ParameterPolygon, 2> buffers;
  ParameterPolygon* polygon = &buffers[0];
  ParameterPolygon* scratch = &buffers[1];
  polygon->corners = {Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(1.0, 0.0), Eigen::Vector2d(0.0, 1.0)};
  polygon->size = 3;
  const Vec3f lower = cell.lower(), upper = cell.upper();
  // Keeps sign * (p[axis] - bound) <= 0.
  const auto clip = [&](int axis, float bound, double sign) {
    clipAgainstLine(*polygon, sign * (frame.origin[axis] - bound), sign * frame.alongU[axis], sign * frame.alongV[axis],
                    *scratch);
    std::swap(polygon, scratch);
  };
  for (int axis = 0; axis < 3 && polygon->size > 0; ++axis) {
    if (frame.hi[axis] > upper[axis]) clip(axis, upper[axis], 1.0);
    if (frame.lo[axis] < lower[axis] && polygon->size > 0) clip(axis, lower[axis], -1.0);
  }
  return *polygon;
}

// A row of cells along one axis of a grid: cell i spans the planes
// (first + i) width and (first + i + 1) width (dyadic: exact in float, as
// Cell's bounds are).
struct GridAxis {
  int first = 0, count = 1;
  float width = 1.0f;

  double plane(int i) const { return static_cast<float>(first + i) * width; }
};
using GridAxes = std::array<GridAxis, 3>;

// A triangle's part in one cell of a grid: its (u, v) polygon, and whether
// no plane cut it (the whole triangle, whose moments are known exactly).
struct GridPart {
  std::array<int, 3> cell;
  const ParameterPolygon* polygon;
  bool whole;
};

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

// The integrals of 1, u, v, u^2, uv and v^2 over a region of the (u, v)
// plane.
struct ParameterMoments {
  double area = 0.0, u = 0.0, v = 0.0, uu = 0.0, uv = 0.0, vv = 0.0;
};

// The unit triangle's: the whole of abc.
constexpr ParameterMoments kWholeTriangle{1.0 / 2.0, 1.0 / 6.0, 1.0 / 6.0, 1.0 / 12.0, 1.0 / 24.0, 1.0 / 12.0};

// A polygon's moments by Green's theorem, edge by edge (counter-clockwise,
// as the unit triangle and every part clipped from it).
ParameterMoments momentsOf(const ParameterPolygon& polygon) {
  ParameterMoments m;
  for (int i = 0; i < polygon.size; ++i) {
    const Eigen::Vector2d& p = polygon.corners[i];
    const Eigen::Vector2d& q = polygon.corners[i + 1 == polygon.size ? 0 : i + 1];
    const double cross = p.x() * q.y() - q.x() * p.y();
    m.area += cross;
    m.u += (p.x() + q.x()) * cross;
    m.v += (p.y() + q.y()) * cross;
    m.uu += (p.x() * p.x() + p.x() * q.x() + q.x() * q.x()) * cross;
    m.vv += (p.y() * p.y() + p.y() * q.y() + q.y() * q.y()) * cross;
    m.uv += (2.0 * p.x() * p.y() + p.x() * q.y() + q.x() * p.y() + 2.0 * q.x() * q.y()) * cross;
  }
  return {m.area / 2.0, m.u / 6.0, m.v / 6.0, m.uu / 12.0, m.uv / 24.0, m.vv / 12.0};
}

// A part's moments: the whole triangle's exactly when no plane cut it.
ParameterMoments momentsOf(const GridPart& part) { return part.whole ? kWholeTriangle : momentsOf(*part.polygon); }

// GridSweep's `wanted` for every cell of its grid.
constexpr auto kEveryCell = [](int, const std::array<int, 3>&) { return true; };

// The cells `levels` deeper than `cell` inside it, as a grid.
GridAxes gridInside(const Cell& cell, int levels) {
  const int depth = cell.depth + levels;
  const Vec3f lower = cell.lower() * std::ldexp(1.0f, depth);  // exact: dyadic
  const float width = std::ldexp(1.0f, -depth);
  const int count = 1 << levels;
  return {GridAxis{static_cast<int>(lower.x()), count, width}, GridAxis{static_cast<int>(lower.y()), count, width},
          GridAxis{static_cast<int>(lower.z()), count, width}};
}

// A field linear on a triangle, from its corner values: f(u, v) = f0 + u
// (f1 - f0) + v (f2 - f0). Its integrals over a part of the triangle follow
// from the part's moments.
struct LinearField {
  Eigen::Vector3d at0, alongU, alongV;

  static LinearField through(const Vec3f& f0, const Vec3f& f1, const Vec3f& f2) {
    const Eigen::Vector3d first = f0.cast<double>();
    return {first, f1.cast<double>() - first, f2.cast<double>() - first};
  }
  LinearField operator-(const LinearField& other) const {
    return {at0 - other.at0, alongU - other.alongU, alongV - other.alongV};
  }
  Eigen::Vector3d integral(const ParameterMoments& m) const { return at0 * m.area + alongU * m.u + alongV * m.v; }
  // |f|^2, whose integrals are those of the moments weighted.
  ParameterMoments squared() const {
    return {at0.squaredNorm(),       2.0 * at0.dot(alongU),         2.0 * at0.dot(alongV),
            alongU.squaredNorm(),    2.0 * alongU.dot(alongV),      alongV.squaredNorm()};
  }
};

// The integral of a quadratic in (u, v) whose coefficients (of 1, u, v, u^2,
// uv, v^2) are `field`, over a region whose moments are `m`.
double integralOf(const ParameterMoments& field, const ParameterMoments& m) {
  return field.area * m.area + field.u * m.u + field.v * m.v + field.uu * m.uu + field.uv * m.uv + field.vv * m.vv;
}

// ---- Primitive access -----------------------------------------------------

struct Bounds {
  Vec3f lo, hi;
};

Bounds triangleBounds(const Vec3f& a, const Vec3f& b, const Vec3f& c) {
  return {a.cwiseMin(b).cwiseMin(c), a.cwiseMax(b).cwiseMax(c)};
}

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

// A triangle of M as the metric clips it: its frame, its area over the unit
// triangle's, M's interpolated normals n and (when known) m's r, both linear
// on it, and the quadratics |n|^2 and |n - r|^2 the sums integrate. Made once
// per triangle and split: a triangle crossing a cell's midplanes is clipped
// into two to four children, each piece integrated from its moments alone.
struct MetricTriangle {
  TriangleFrame frame;
  double jacobian;
  LinearField n, r;
  ParameterMoments nSquared, gapSquared;
  bool coarseKnown;

  MetricTriangle(const DetailPrimitives& d, const DetailTriangle& t)
      : frame(t.corners[0], t.corners[1], t.corners[2]),
        // Twice the triangle's area: the unit triangle's is a half.
        jacobian(d.areaScale * (t.corners[1] - t.corners[0]).cast<double>().cross((t.corners[2] - t.corners[0]).cast<double>()).norm()),
        n(LinearField::through(t.normals[0], t.normals[1], t.normals[2])),
        r(LinearField::through(t.coarseNormals[0], t.coarseNormals[1], t.coarseNormals[2])),
        nSquared(n.squared()),
        gapSquared((n - r).squared()),
        coarseKnown(d.coarseKnown) {}

  Bounds bounds() const { return {frame.lo, frame.hi}; }
};

// Running sums for the L2,1 integral of a cell: M's area, the integral of
// its normal field n and of |n|^2; with n_C the unit mean normal, the
// integral of |n - n_C|^2 expands into these.
struct Moments {
  double area = 0.0, squared = 0.0;
  Eigen::Vector3d integral = Eigen::Vector3d::Zero();

  void add(double a, const Eigen::Vector3d& integralOfN, double integralOfSquare) {
    area += a;
    integral += integralOfN;
    squared += integralOfSquare;
  }

  Moments& operator+=(const Moments& other) {
    add(other.area, other.integral, other.squared);
    return *this;
  }
  Moments operator-(const Moments& other) const {
    return {area - other.area, squared - other.squared, integral - other.integral};
  }

  double l21() const {
    const double norm = integral.norm();
    const double unitArea = norm > 0.0 ? area : 0.0;  // |n_C|^2 times the area
    return std::max(0.0, squared - 2.0 * norm + unitArea);
  }
};

// The L2,1 sums of a cell, and those a two-sided leaf needs: per axis, the
// pieces where m's normal has a non-negative coordinate on it (format.h
// leafSide; the rest is the other side). `coarse` sums the integral of
// |n(x) - r(x)|^2, r m's normal field.
struct VariationSums {
  Moments all;
  std::array<Moments, 3> sideZero;
  double coarse = 0.0;

  // A piece of M; `coarseMean` points along m's mean normal over it, null
  // when that is unknown.
  void add(double a, const Eigen::Vector3d& integralOfN, double integralOfSquare, const Eigen::Vector3d* coarseMean) {
    all.add(a, integralOfN, integralOfSquare);
    if (!coarseMean) return;
    for (int axis = 0; axis < 3; ++axis)
      if (leafSide(coarseMean->cast<float>(), axis) == 0) sideZero[axis].add(a, integralOfN, integralOfSquare);
  }

  // The part of triangle t of M whose (u, v) moments are `m`.
  void addPart(const MetricTriangle& t, const ParameterMoments& m) {
    const double a = t.jacobian * m.area;
    const Eigen::Vector3d integralOfN = t.jacobian * t.n.integral(m);
    const double integralOfSquare = t.jacobian * integralOf(t.nSquared, m);
    if (!t.coarseKnown) {
      add(a, integralOfN, integralOfSquare, nullptr);
      return;
    }
    const Eigen::Vector3d coarseMean = t.r.integral(m);
    add(a, integralOfN, integralOfSquare, &coarseMean);
    coarse += t.jacobian * integralOf(t.gapSquared, m);
  }

  VariationSums& operator+=(const VariationSums& other) {
    all += other.all;
    for (int axis = 0; axis < 3; ++axis) sideZero[axis] += other.sideZero[axis];
    coarse += other.coarse;
    return *this;
  }

  double l21() const { return all.l21(); }

  // The axis whose two sides leave the least L2,1, and that L2,1 (each side
  // against its own mean normal). A later axis wins only by more than
  // rounding: where m's normal has no zero coordinate, every axis parts the
  // same pieces, and the sums differ in their last bits alone, with the
  // order M was cut in.
  std::pair<int, double> bestTwoSides() const {
    constexpr double kRounding = 1e-9;
    std::pair<int, double> best{0, std::numeric_limits<double>::infinity()};
    for (int axis = 0; axis < 3; ++axis) {
      const double error = sideZero[axis].l21() + (all - sideZero[axis]).l21();
      if (error < best.second * (1.0 - kRounding)) best = {axis, error};
    }
    return best;
  }
};

// The part of triangle `m` of M inside the cell, added with its
// interpolated normals (a part in a face between cells is the lower cell's,
// as GridSweep files it). The part's integrals come from its moments in the
// triangle's own coordinates, exactly for the linear fields.
void addTriangleInCell(const MetricTriangle& m, const Cell& cell, VariationSums& sums) {
  GridSweep(m.frame, gridInside(cell, 0)).run(kEveryCell, [&](const GridPart& part) { sums.addPart(m, momentsOf(part)); });
}

// A leaf that stops refining shows m's normals where they leave less than
// this share of its own error. The leaf's error is that of one constant
// normal, but the renders blend neighbouring leaves (paper 5.3), which
// follows M far closer (30-60% less error on the bundled meshes): taking m
// wherever it merely beats the constant cost bunny00 6% of its filtered
// accuracy at 3 MiB (0.208 degrees mean against 0.196).
constexpr double kCoarseAdvantage = 0.01;
// m's normals within this of M's (root mean square) are M's for any
// renderer: such a leaf needs no split (m is M there, as when M had no more
// faces than the simplification's target).
constexpr double kCoarseExactDegrees = 0.02;

double squaredRadians(double degrees) {
  const double radians = degrees * std::numbers::pi / 180.0;
  return radians * radians;
}

// A leaf shows two normals, one per side of m (format version 4), where
// they leave less than this share of its one normal's error: thin parts,
// where the one normal averages opposite sides, leave far less. Measured
// (docs/benchmarks.md, "Two-sided leaves"): at 0.5, many leaves of merely
// curved cells took the second texel and the bundled meshes lost 0.3-2% at
// 3 MiB; at 0.2, none lost more than 0.3% and camel.off at 256 KiB gained 7.8% (docs/benchmarks.md).
constexpr double kTwoSidedAdvantage = 0.2;

// What a leaf costs in error: its L2,1, the same with one normal per side
// of m, and the integral against m's normals, and M's area in it. The
// refinement ranks splits by the L2,1 of what the leaf would show of M
// (ranking by the smaller of that and m's stopped refining where m was close
// but a finer APO closer still: bumpy sphere at 42 KB, 0.274 degrees
// against 0.236 for the paper's threshold); with `deferToCoarse`, a leaf
// where m is far closer shows m's normals when it stops.
struct LeafError {
  double variation = 0.0, coarse = 0.0, area = 0.0;
  double twoSided = std::numeric_limits<double>::infinity();  // infinite where a leaf may not be two-sided
  int sideAxis = 0;
  bool deferToCoarse = false;

  bool twoSidesPay() const { return twoSided < kTwoSidedAdvantage * variation; }
  // The L2,1 of what the leaf shows of M: one normal or two.
  double ranked() const { return twoSidesPay() ? twoSided : variation; }
  bool showsCoarse() const { return deferToCoarse && coarse < kCoarseAdvantage * ranked(); }
  bool showsTwoSides() const { return twoSidesPay() && !showsCoarse(); }
  double shown() const { return showsCoarse() ? coarse : ranked(); }
  std::uint64_t texels() const { return showsTwoSides() ? 2 : 1; }
  bool negligible() const {
    return ranked() <= area * squaredRadians(kNegligibleDegrees) ||
           (deferToCoarse && coarse <= area * squaredRadians(kCoarseExactDegrees));
  }
};

// `twoSides`: whether the leaf may show two normals (it needs m's normals,
// and a parent's kind bit: below the completion depth).
LeafError leafErrorOf(const VariationSums& sums, bool withCoarse, bool deferToCoarse, bool twoSides) {
  LeafError error{sums.l21(), sums.coarse, sums.all.area};
  error.deferToCoarse = deferToCoarse && withCoarse;
  if (twoSides && withCoarse) std::tie(error.sideAxis, error.twoSided) = sums.bestTwoSides();
  return error;
}

// A point of M: its weight, normal and (null when unknown) m's normal where
// it projects.
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

// Records fetched this many ahead of their use in a primitive list.
constexpr std::size_t kPrefetchAhead = 8;

void prefetchRecord(const DetailTriangle& record) {
  const char* bytes = reinterpret_cast<const char*>(&record);
  __builtin_prefetch(bytes);
  __builtin_prefetch(bytes + sizeof(DetailTriangle) - 1);
}

// ---- The coarse grid ------------------------------------------------------

// Grid coordinates at depth d of the cells whose closed boxes can meet
// [lo, hi] (a value on a cell boundary belongs to both cells).
struct GridRange {
  std::array<int, 3> first, last;
};

GridRange gridRange(const Bounds& b, int cellsPerAxis) {
  GridRange range{};
  const float n = static_cast<float>(cellsPerAxis);
  for (int axis = 0; axis < 3; ++axis) {
    range.first[axis] = std::clamp(static_cast<int>(std::ceil(b.lo[axis] * n)) - 1, 0, cellsPerAxis - 1);
    range.last[axis] = std::clamp(static_cast<int>(std::floor(b.hi[axis] * n)), 0, cellsPerAxis - 1);
  }
  return range;
}

using GridKey = std::uint64_t;

GridKey gridKey(int x, int y, int z, int depth) {
  return (static_cast<GridKey>(x) << (2 * depth)) | (static_cast<GridKey>(y) << depth) | static_cast<GridKey>(z);
}

std::array<int, 3> gridCoordinates(GridKey key, int depth) {
  const GridKey mask = (GridKey{1} << depth) - 1;
  return {static_cast<int>(key >> (2 * depth)), static_cast<int>((key >> depth) & mask), static_cast<int>(key & mask)};
}

Cell gridCell(GridKey key, int depth) {
  const auto xyz = gridCoordinates(key, depth);
  const float width = std::ldexp(1.0f, -depth);
  return {Vec3f((xyz[0] + 0.5f) * width, (xyz[1] + 0.5f) * width, (xyz[2] + 0.5f) * width), width, depth};
}

bool insideUnitCube(const Bounds& b) {
  return (b.lo.array() >= 0.0f).all() && (b.hi.array() <= 1.0f).all();
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

// ---- Points in Morton order ---------------------------------------------------

// M's points sorted by the Morton code of the finest cell holding each: the
// points in any cell are then one run of the order, found by two binary
// searches, and summed in one pass over contiguous records. Filing each
// point into the children of every cell it went down through, as triangles
// are, cost the 2M-point bake a third of its build (docs/benchmarks.md,
// "A faster build").
constexpr int kPointKeyDepth = 16;  // bake's deepest octree
constexpr std::uint64_t kOutsideTheCube = ~std::uint64_t{0};  // sorted last, in no cell's run

// Positions [first, end) of a sorted key array: the points in a cell (in
// PointOrder), M's fine cells in a cell (in FineSums).
struct KeyRun {
  std::uint32_t first = 0, end = 0;
};

// The run of `keys` (Morton codes of the cells of depth `keyDepth`, counted
// from the lower corner of `frame`, a cell holding `cell`) inside `cell`,
// within `within` (a run holding it).
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

// A point on a face between two cells belongs to the lower one, as in the
// lookup's walk (format.h, childIndex); the first cell of an axis takes its
// lower face.
std::uint64_t pointKey(const Vec3f& p) {
  if (!insideUnitCube({p, p})) return kOutsideTheCube;
  constexpr float kCells = static_cast<float>(1u << kPointKeyDepth);
  const auto grid = [&](float x) { return static_cast<std::uint32_t>(std::max(std::ceil(x * kCells) - 1.0f, 0.0f)); };
  return mortonCode(grid(p.x()), grid(p.y()), grid(p.z()));
}

class PointOrder {
 public:
  explicit PointOrder(const DetailPrimitives& d) {
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

  // The run of the points in `cell`, within `within` (a run holding it).
  KeyRun runOf(const Cell& cell, KeyRun within) const { return runOfCell(keys_, cell, Cell{}, kPointKeyDepth, within); }
  KeyRun all() const { return {0, static_cast<std::uint32_t>(keys_.size())}; }

  VariationSums sumsOf(KeyRun run) const {
    VariationSums sums;
    for (std::uint32_t k = run.first; k < run.end; ++k) {
      const Record& r = records_[k];
      addWeightedNormal(r.weight, r.normal, coarseKnown_ ? &r.coarse : nullptr, sums);
    }
    return sums;
  }

 private:
  struct Record {
    Vec3f normal;
    float weight;
    Vec3f coarse;
  };
  std::vector<std::uint64_t> keys_;
  std::vector<Record> records_;
  bool coarseKnown_ = false;
};

// ---- M's triangles summed once at a fine depth ----------------------------

// The deepest level whose cells are at least this many times as wide as M's
// triangles (their mean longest side) is where the metric clips M once, and
// the levels above add its cells' sums (FineSums). Level by level, the 1.2M
// bunny's build clipped 7.7M pieces of M down to that depth (8), of 11.5M in
// all; once at it, 2.8M. Wider cells leave more levels to clip, narrower
// ones cut each triangle into more pieces: the rule picks the fastest of
// three depths on both the bunny (8) and the 7.2M torus (9)
// (docs/benchmarks.md, "M's triangles clipped once at a fine depth").
constexpr double kSumCellOverTriangle = 2.0;
// Where M's triangles differ in size (a few large ones, a floor under a
// scanned object, among many small ones), the depth the mean picks would
// cut the large ones into many pieces: the sum depth rises until the
// triangles' pieces there are at most this many per triangle, twice what
// triangles of one size give at the chosen depth ((1 + 1/2)^2; the bunny
// 2.25, the torus 2.09, estimated as sumDepthFor does; 2.3 counted).
constexpr double kMostPiecesPerTriangle = 4.5;

// The cells of depth `sumDepth` inside one coarse cell that M's triangles
// meet, in Morton order within the coarse cell: for each, the L2,1 sums of
// the triangles' parts in it and the triangles themselves. The cells of any
// depth between the two are then runs of that order, and their sums the
// sums of their runs, as M's points' are (PointOrder).
class FineSums {
 public:
  // Each piece of a triangle in a fine cell, summed alone; reused from one
  // coarse cell to the next on a thread (the bunny's coarse cells hold about
  // 870 pieces each, 160 KB, which fresh memory would fault in anew each time).
  struct Scratch {
    struct Piece {
      std::uint64_t key;
      std::uint32_t triangle, sums;  // sums: index into `sums`
    };
    std::vector<Piece> pieces, spare;  // spare: the radix sort's other buffer
    std::vector<VariationSums> sums;
  };

  FineSums(const DetailPrimitives& d, const IdList& triangles, const Cell& coarseCell, int sumDepth, Scratch& scratch)
      : coarse_(coarseCell), levels_(sumDepth - coarseCell.depth) {
    clipIntoFineCells(d, triangles, sumDepth, scratch);
    addUpByCell(scratch);
  }

  KeyRun all() const { return {0, static_cast<std::uint32_t>(keys_.size())}; }

  // The run of the fine cells inside `cell` (inside the coarse cell, at most
  // as deep as the fine cells), within `within` (a run holding it).
  KeyRun runOf(const Cell& cell, KeyRun within) const {
    return runOfCell(keys_, cell, coarse_, coarse_.depth + levels_, within);
  }

  VariationSums sumsOf(KeyRun run) const {
    VariationSums sums;
    for (std::uint32_t k = run.first; k < run.end; ++k) sums += sums_[k];
    return sums;
  }

  // M's triangles in the run's cells (one fine cell, or none).
  IdList trianglesOf(KeyRun run) const {
    if (run.first == run.end) return {};
    return IdList(triangles_.begin() + begin_[run.first], triangles_.begin() + begin_[run.end]);
  }

 private:
  // Every triangle's pieces in the fine cells its box meets (a cell it only
  // touches takes none), with their sums.
  void clipIntoFineCells(const DetailPrimitives& d, const IdList& triangles, int sumDepth, Scratch& scratch) const {
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
  void addUpByCell(Scratch& scratch) {
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

  // A stable sort by key (`keyBits` bits), least significant digit first,
  // 11 bits a pass: one or two passes over the pieces, where std::sort by
  // (key, triangle) took 2% of the 1.2M bunny's bake (docs/benchmarks.md).
  static void sortByCell(std::vector<Scratch::Piece>& pieces, std::vector<Scratch::Piece>& spare, int keyBits) {
    constexpr int kDigitBits = 11;
    spare.resize(pieces.size());
    for (int shift = 0; shift < keyBits; shift += kDigitBits) {
      std::array<std::uint32_t, (1u << kDigitBits) + 1> start{};
      const auto digit = [&](const Scratch::Piece& piece) { return (piece.key >> shift) & ((1u << kDigitBits) - 1); };
      for (const Scratch::Piece& piece : pieces) ++start[digit(piece) + 1];
      for (std::size_t d = 1; d < start.size(); ++d) start[d] += start[d - 1];
      for (const Scratch::Piece& piece : pieces) spare[start[digit(piece)]++] = piece;
      pieces.swap(spare);
    }
  }

  // The grid coordinates at `depth` of the coarse cell's lower corner.
  static std::array<int, 3> gridOrigin(const Cell& cell, int depth) {
    const Vec3f lower = cell.lower() * std::ldexp(1.0f, depth);  // exact: dyadic
    return {static_cast<int>(lower.x()), static_cast<int>(lower.y()), static_cast<int>(lower.z())};
  }

  Cell coarse_;
  int levels_;
  std::vector<std::uint64_t> keys_;
  std::vector<VariationSums> sums_;
  std::vector<std::uint32_t> begin_;  // per cell, into triangles_; one more at the end
  std::vector<std::uint32_t> triangles_;
};

// ---- Global refinement below the coarse depth ------------------------------

// A leaf of the growing tree with m's and M's primitives in its cell.
struct Leaf {
  std::uint32_t node = 0;
  Cell cell;
  CoarseIdList triangles;  // m's
  IdList primitives;       // M's triangles (M a mesh), at or below the sum depth
  const FineSums* fine = nullptr;  // M's triangles' sums (M a mesh), above the sum depth
  KeyRun fineRun;
  KeyRun points;  // M's points (M points)
  LeafError error;
  // Children its split would keep (those holding some of m): counted when
  // the leaf is made, as it is cheap (m's few triangles), to bound the
  // split's value per texel before M is clipped into them.
  int keptChildren = 1;
};

// A leaf and what splitting it would give: its kept children, evaluated.
struct Candidate {
  Leaf leaf;
  std::uint8_t mask = 0;
  // In increasing child index; made on the evaluating threads and freed on
  // the main one, as the leaves' lists are (IdList).
  std::vector<Leaf, tbb::scalable_allocator<Leaf>> children;
  double gain = 0.0;           // L2,1 removed by the split
  double largestChildError = 0.0;

  // The leaf's 1 or 2 texels become an internal node's 2, plus the children's.
  std::uint64_t texels() const {
    std::uint64_t texels = 2 - leaf.error.texels();
    for (const Leaf& child : children) texels += child.error.texels();
    return texels;
  }
  // What the split is worth: the error it removes, or, when it removes
  // little because M's part stays in one child (m crosses a corner of the
  // cell, M lies along one side), the error it opens to the next split.
  // Ranked by the gain alone, such cells would never split, though the
  // threshold rule of the paper splits them (measured on bunny00 at 3 MiB:
  // by the gain, 0.252 degrees mean filtered, 0.722 p95; by the gain but
  // opening single children, 0.213 / 0.657; by this value, 0.196 / 0.598,
  // though its total L2,1 is a few percent above the paper's rule's at
  // equal texels: the filtered lookup gains most where M's normal turns
  // sharply in a part of the cell, which this value finds first).
  double value() const { return std::max(gain, largestChildError); }
  double valuePerTexel() const { return value() / static_cast<double>(texels()); }
};

// A candidate's record (its leaf, its children's list), fetched ahead of
// its use.
void prefetchCandidate(const Candidate& candidate) {
  const char* bytes = reinterpret_cast<const char*>(&candidate);
  for (std::size_t offset = 0; offset < sizeof(Candidate); offset += 64) __builtin_prefetch(bytes + offset);
}

// A queued candidate's place in the splitting order, kept beside its index so
// that ordering the queue reads no candidate: the most value per texel
// first, then the node index (deterministic ties).
// 16 bytes: four to a cache line.
struct QueueEntry {
  double valuePerTexel = 0.0;  // unevaluated: an upper bound
  std::uint32_t node = 0;
  std::uint32_t slot = 0;  // the candidate's slot, and kEvaluated

  static constexpr std::uint32_t kEvaluated = 1u << 31;
  bool evaluated() const { return (slot & kEvaluated) != 0; }
  std::uint32_t candidate() const { return slot & ~kEvaluated; }

  // The queue's order: true when `a` comes after `b`.
  static bool after(const QueueEntry& a, const QueueEntry& b) {
    if (a.valuePerTexel != b.valuePerTexel) return a.valuePerTexel < b.valuePerTexel;
    return a.node > b.node;
  }
};

// The candidates in splitting order: a heap with four children to a node.
// A round pops and pushes hundreds of thousands of entries on one thread
// while the other core waits; a binary heap of them (std::push_heap) spent
// twice the levels, each a cache miss (docs/benchmarks.md).
class SplitQueue {
 public:
  bool empty() const { return heap_.empty(); }
  std::size_t size() const { return heap_.size(); }
  const QueueEntry& top() const { return heap_.front(); }
  // In no particular order.
  const std::vector<QueueEntry>& entries() const { return heap_; }
  void clear() { heap_.clear(); }

  void push(const QueueEntry& entry) {
    std::size_t at = heap_.size();
    heap_.push_back(entry);
    while (at > 0) {
      const std::size_t parent = (at - 1) / kArity;
      if (!QueueEntry::after(heap_[parent], entry)) break;
      heap_[at] = heap_[parent];
      at = parent;
    }
    heap_[at] = entry;
  }

  QueueEntry pop() {
    const QueueEntry top = heap_.front();
    const QueueEntry last = heap_.back();
    heap_.pop_back();
    const std::size_t n = heap_.size();
    if (n == 0) return top;
    std::size_t at = 0;
    for (;;) {
      const std::size_t first = kArity * at + 1;
      if (first >= n) break;
      std::size_t best = first;
      for (std::size_t c = first + 1; c < std::min(first + kArity, n); ++c)
        if (QueueEntry::after(heap_[best], heap_[c])) best = c;
      if (!QueueEntry::after(last, heap_[best])) break;
      heap_[at] = heap_[best];
      at = best;
    }
    heap_[at] = last;
    return top;
  }

 private:
  static constexpr std::size_t kArity = 4;
  std::vector<QueueEntry> heap_;
};

class Refinement {
 public:
  // `points`: M's points in order, when M is points. `sumDepth`: the depth
  // of FineSums' cells (leaves above it carry theirs), 0 when none.
  Refinement(const CoarseMesh& coarse, const DetailPrimitives& detail, const PointOrder* points,
             const BuildSettings& settings, int sumDepth)
      : coarse_(coarse), detail_(detail), points_(points), settings_(settings), sumDepth_(sumDepth) {}

  // Whether the leaf may split at all (before its split is evaluated).
  bool mayRefine(const Leaf& leaf) const {
    if (leaf.cell.depth >= settings_.maxDepth || leaf.error.negligible()) return false;
    return !(settings_.error > 0.0) || leaf.error.variation > settings_.error;
  }

  // The leaf's split: m's triangles into the children (only those holding
  // some of m are kept), M's primitives into the kept ones, their errors.
  // `filing`: the thread's scratch lists.
  Candidate evaluate(Leaf leaf, ChildFiling& filing) const {
    Candidate candidate;
    const Cell& cell = leaf.cell;
    auto childTriangles = distributeCoarse(coarse_, leaf.triangles, leaf.cell, filing);
    for (int c = 0; c < 8; ++c)
      if (!childTriangles[c].empty()) candidate.mask |= static_cast<std::uint8_t>(1u << c);
    if (candidate.mask != 0) {
      ChildErrors childErrors = points_      ? distributePoints(leaf, candidate.mask)
                                : leaf.fine ? distributeFineSums(leaf, candidate.mask)
                                            : distributeTriangles(leaf, candidate.mask, filing);
      double childError = 0.0;
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
        if (mayRefine(child)) child.keptChildren = keptChildrenOf(child);  // only a leaf that may split is queued
        childError += child.error.ranked();
        candidate.largestChildError = std::max(candidate.largestChildError, child.error.ranked());
        candidate.children.push_back(std::move(child));
      }
      candidate.gain = leaf.error.ranked() - childError;
      // M's primitives are needed by the error metric only (the rays are
      // cast against all of M): a leaf that splits keeps none.
      IdList().swap(leaf.primitives);
    }
    candidate.leaf = std::move(leaf);
    return candidate;
  }

  // The children that would hold some of m, as coarseInChildren keeps them.
  int keptChildrenOf(const Leaf& leaf) const {
    return std::popcount(static_cast<unsigned>(childrenHoldingCoarse(coarse_, leaf.triangles, leaf.cell)));
  }

  LeafError errorOf(const Leaf& leaf) const {
    if (points_)
      return leafErrorOf(points_->sumsOf(leaf.points), detail_.coarseKnown, settings_.deferToCoarse, mayBeTwoSided(leaf.cell));
    if (leaf.fine)
      return leafErrorOf(leaf.fine->sumsOf(leaf.fineRun), detail_.coarseKnown, settings_.deferToCoarse,
                         mayBeTwoSided(leaf.cell));
    return errorInCell(detail_, leaf.primitives, leaf.cell, settings_.deferToCoarse, mayBeTwoSided(leaf.cell));
  }

  // A split worth making: some of m below, and worth something.
  static bool worthSplitting(const Candidate& c) {
    return c.mask != 0 && c.value() > 0.0;
  }

 private:
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
        out.errors[c] = leafErrorOf(points_->sumsOf(out.points[c]), detail_.coarseKnown, settings_.deferToCoarse,
                                    mayBeTwoSided(child));
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
  // more of the build: docs/benchmarks.md, "A faster build"). A triangle
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
};

// Texels the encoding of the octree as it stands takes: the completion grid,
// then 1 per leaf and 2 per internal node at or below the completion depth.
std::uint64_t texelsOf(const std::vector<OctreeNode>& nodes, int completeDepth) {
  std::uint64_t texels = std::uint64_t{1} << (3 * completeDepth);
  for (const OctreeNode& node : nodes)
    if (node.depth >= completeDepth) texels += node.isLeaf() ? 1 : 2;
  return texels;
}

constexpr std::uint32_t kNotALeaf = ~0u;

// Moves nodes[order[i]] to nodes[i] for every i, along the permutation's
// cycles: a second array of the nodes would be fresh memory, whose zeroing
// by the kernel took most of the renumbering's 0.1 s on the 1.2M bunny.
void permuteInPlace(std::vector<OctreeNode>& nodes, const std::vector<std::uint32_t>& order) {
  std::vector<bool> placed(nodes.size(), false);
  for (std::size_t start = 0; start < nodes.size(); ++start) {
    if (placed[start]) continue;
    const OctreeNode first = nodes[start];
    std::size_t at = start;
    for (;;) {
      placed[at] = true;
      const std::size_t from = order[at];
      if (from == start) break;
      nodes[at] = nodes[from];
      at = from;
    }
    nodes[at] = first;
  }
}

// Renumbers the nodes breadth first from the root (each brood contiguous, in
// child order, as before); returns the new number of each old node.
std::vector<std::uint32_t> renumberBreadthFirst(std::vector<OctreeNode>& nodes) {
  std::vector<std::uint32_t> order = {0};  // old numbers, in the new order
  order.reserve(nodes.size());
  for (std::size_t i = 0; i < order.size(); ++i) {
    const OctreeNode& node = nodes[order[i]];
    for (int k = 0; k < std::popcount(static_cast<unsigned>(node.childMask)); ++k)
      order.push_back(node.firstChild + static_cast<std::uint32_t>(k));
  }
  std::vector<std::uint32_t> newNumber(nodes.size());
  for (std::size_t i = 0; i < order.size(); ++i) newNumber[order[i]] = static_cast<std::uint32_t>(i);
  permuteInPlace(nodes, order);
  tbb::parallel_for(std::size_t{0}, nodes.size(), [&](std::size_t i) {
    if (!nodes[i].isLeaf()) nodes[i].firstChild = newNumber[nodes[i].firstChild];
  });
  return newNumber;
}

// Leaves evaluated per task while a round goes on (GlobalRefinement::round).
constexpr std::size_t kEvaluationBatch = 16;

// Candidates expanded per round: enough to keep both cores busy, few enough
// that the order stays close to one split at a time.
std::size_t roundSize(std::size_t queued, bool budgeted) {
  if (!budgeted) return queued;
  return std::max<std::size_t>(256, queued / 16);
}

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

bool triangleOverlapsBox(const Vec3f& a, const Vec3f& b, const Vec3f& c, const Cell& cell) {
  const Vec3f half = Vec3f::Constant(0.5f * cell.width);
  const Vec3f v0 = a - cell.centre, v1 = b - cell.centre, v2 = c - cell.centre;
  for (int axis = 0; axis < 3; ++axis)
    if (std::min({v0[axis], v1[axis], v2[axis]}) > half[axis] || std::max({v0[axis], v1[axis], v2[axis]}) < -half[axis])
      return false;
  const std::array<Vec3f, 3> edges = {v1 - v0, v2 - v1, v0 - v2};
  if (separatedOn(edges[0].cross(edges[1]), v0, v1, v2, half)) return false;
  for (const Vec3f& edge : edges)
    for (int axis = 0; axis < 3; ++axis)
      if (separatedOn(Vec3f::Unit(axis).cross(edge), v0, v1, v2, half)) return false;
  return true;
}

// One projection of the corners per axis for the eight children: a child's
// centre shifts it by its offset along the axis (a child's half width and
// its centre's offset on each axis are both a quarter of the cell's width).
// Where a child's gap on an axis is within rounding of zero (m touching the
// child's box: CAD models whose faces pass through cells' corners), the
// child is tested apart, so that every answer is triangleOverlapsBox's.
std::uint8_t childrenMeeting(const Vec3f& a, const Vec3f& b, const Vec3f& c, const Cell& cell, std::uint8_t wanted) {
  // Far above either computation's rounding (float's epsilon is 1.2e-7),
  // relative to the magnitudes the projections are made of.
  constexpr float kRounding = 1e-5f;
  const float quarter = 0.25f * cell.width;
  const Vec3f v0 = a - cell.centre, v1 = b - cell.centre, v2 = c - cell.centre;
  const float reach = v0.cwiseAbs().cwiseMax(v1.cwiseAbs()).cwiseMax(v2.cwiseAbs()).maxCoeff() + 2.0f * quarter;
  unsigned meeting = wanted, unsure = 0;
  // `gap` > 0: the children and the triangle are apart along the axis.
  const auto judge = [&](unsigned children, float gap, float tolerance) {
    if (gap > tolerance)
      meeting &= ~children;
    else if (gap >= -tolerance)
      unsure |= children;
  };
  // Box axes: the lower children on an axis (bit 1, childCentre) span
  // [-2 quarter, 0] from the centre, the upper ones [0, 2 quarter].
  constexpr std::array<unsigned, 3> kLowerOn{0xF0, 0xCC, 0xAA};
  for (int axis = 0; axis < 3; ++axis) {
    const float lo = std::min({v0[axis], v1[axis], v2[axis]}), hi = std::max({v0[axis], v1[axis], v2[axis]});
    judge(kLowerOn[axis], std::max(lo, -2.0f * quarter - hi), kRounding * reach);
    judge(~kLowerOn[axis] & 0xFFu, std::max(lo - 2.0f * quarter, -hi), kRounding * reach);
  }
  const auto separate = [&](const Vec3f& axis) {
    const float p0 = axis.dot(v0), p1 = axis.dot(v1), p2 = axis.dot(v2);
    const float lo = std::min({p0, p1, p2}), hi = std::max({p0, p1, p2});
    const Vec3f shift = quarter * axis;
    const float radius = quarter * axis.cwiseAbs().sum();
    const float tolerance = kRounding * axis.cwiseAbs().sum() * reach;
    // All eight children judged at once, without a branch per child (with
    // the sampling's clip in place, 4% of the bunny's CPU time less than a
    // loop skipping those already apart: docs/benchmarks.md, tenth stop); a
    // child already apart is judged again to no effect.
    std::array<float, 8> gap;
    for (unsigned child = 0; child < 8; ++child) {
      const float offset = ((child & 4) ? -shift.x() : shift.x()) + ((child & 2) ? -shift.y() : shift.y()) +
                           ((child & 1) ? -shift.z() : shift.z());
      gap[child] = std::max(lo - offset - radius, -radius - (hi - offset));
    }
    unsigned apart = 0, near = 0;
    for (unsigned child = 0; child < 8; ++child) {
      apart |= static_cast<unsigned>(gap[child] > tolerance) << child;
      near |= static_cast<unsigned>(gap[child] >= -tolerance) << child;
    }
    meeting &= ~apart;
    unsure |= near & ~apart;
  };
  const std::array<Vec3f, 3> edges = {v1 - v0, v2 - v1, v0 - v2};
  if (meeting != 0) separate(edges[0].cross(edges[1]));
  for (const Vec3f& edge : edges)
    for (int axis = 0; axis < 3 && meeting != 0; ++axis) separate(Vec3f::Unit(axis).cross(edge));
  for (unsigned child = 0; child < 8; ++child)
    if ((meeting & unsure & (1u << child)) && !triangleOverlapsBox(a, b, c, cell.child(static_cast<int>(child))))
      meeting &= ~(1u << child);
  return static_cast<std::uint8_t>(meeting);
}

CellPolygon clipTriangleToCell(const Vec3f& a, const Vec3f& b, const Vec3f& c, const Cell& cell) {
  const TriangleFrame frame(a, b, c);
  const ParameterPolygon part = clipInParameters(frame, cell);
  CellPolygon polygon;
  for (int k = 0; k < part.size; ++k)
    polygon.corners[polygon.size++] =
        (frame.origin + part.corners[k].x() * frame.alongU + part.corners[k].y() * frame.alongV).cast<float>();
  return polygon;
}

double polygonArea(std::span<const Vec3f> polygon) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (std::size_t i = 1; i + 1 < polygon.size(); ++i)
    sum += (polygon[i] - polygon[0]).cast<double>().cross((polygon[i + 1] - polygon[0]).cast<double>());
  return 0.5 * sum.norm();
}

Eigen::Vector3f barycentricsOf(const Vec3f& p, const Vec3f& a, const Vec3f& b, const Vec3f& c) {
  const Vec3f v0 = b - a, v1 = c - a, v2 = p - a;
  const double d00 = v0.dot(v0), d01 = v0.dot(v1), d11 = v1.dot(v1), d20 = v2.dot(v0), d21 = v2.dot(v1);
  const double denominator = d00 * d11 - d01 * d01;
  if (!(denominator > 0.0)) return {1.0f, 0.0f, 0.0f};
  const double v = (d11 * d20 - d01 * d21) / denominator, w = (d00 * d21 - d01 * d20) / denominator;
  Eigen::Vector3f weights(static_cast<float>(1.0 - v - w), static_cast<float>(v), static_cast<float>(w));
  weights = weights.cwiseMax(0.0f);  // the point is on the triangle up to rounding
  return weights / weights.sum();
}

double normalVariation(const DetailPrimitives& detail, const std::vector<std::uint32_t>& primitives, const Cell& cell) {
  return errorInCell(detail, primitives, cell, false, false).variation;
}

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

namespace {

// Leaves that will not split: m's triangles of each (for the sampling) kept
// in the leaf's own list until the layout, and their errors summed as they
// come. (Copying every list into one array as leaves finished, then again
// into the layout, left the second core idle for 0.1 s at the end of the
// 1.2M bunny's build.)
class FinishedLeaves {
 public:
  // `leavesAtMost`: a bound of the leaves to come (0: none known), so that
  // the records are never copied into larger fresh memory as they come.
  FinishedLeaves(int maxDepth, std::size_t leavesAtMost) : maxDepth_(maxDepth) { records_.reserve(leavesAtMost); }

  void add(Leaf&& leaf, RefinementOutcome& outcome) {
    count(summaryOf(leaf), outcome);
    records_.push_back({leaf.node, std::move(leaf.triangles), leaf.error.showsCoarse(), leaf.error.showsTwoSides(),
                        static_cast<std::uint8_t>(leaf.error.sideAxis)});
  }

  // The leaves still queued when the refinement stops (a third of the
  // bunny's), left where they are until the layout: moved into records one
  // by one, on one core, they took 70 ms of the 1.2M bunny's build, mostly
  // cache misses on the candidates' slots. Read on every core, and summed in
  // their order, as `add` would have.
  void addInPlace(std::vector<Leaf*> leaves, RefinementOutcome& outcome) {
    const auto summaries = std::make_unique_for_overwrite<Summary[]>(leaves.size());  // its pages touched in parallel
    tbb::parallel_for(std::size_t{0}, leaves.size(), [&](std::size_t i) { summaries[i] = summaryOf(*leaves[i]); });
    for (std::size_t i = 0; i < leaves.size(); ++i) count(summaries[i], outcome);
    inPlace_ = std::move(leaves);
  }

  // The CSR of m's triangles per node, nodes renumbered by `newNumber`, and
  // the leaves that show m's normals marked; each leaf's list copied and
  // freed in parallel.
  void layOut(const std::vector<std::uint32_t>& newNumber, BuiltOctree& built) {
    std::vector<std::uint32_t> leafOf(newNumber.size(), kNotALeaf);
    std::vector<std::uint64_t>& begin = built.leafTriangleBegin;
    begin.assign(newNumber.size() + 1, 0);
    tbb::parallel_for(std::size_t{0}, leaves(), [&](std::size_t i) {
      const std::uint32_t n = newNumber[nodeOf(i)];
      leafOf[n] = static_cast<std::uint32_t>(i);
      begin[n + 1] = trianglesOf(i).size();
    });
    std::partial_sum(begin.begin(), begin.end(), begin.begin());
    built.leafTriangles.resize(begin.back());
    tbb::parallel_for(std::size_t{0}, newNumber.size(), [&](std::size_t n) {
      if (leafOf[n] == kNotALeaf) return;
      const std::size_t i = leafOf[n];
      OctreeNode& node = built.octree.nodes[n];
      if (i < records_.size()) {
        node.coarseNormal = records_[i].showsCoarse;
        node.twoSided = records_[i].twoSided;
        node.sideAxis = records_[i].sideAxis;
      } else {
        const LeafError& error = inPlace_[i - records_.size()]->error;
        node.coarseNormal = error.showsCoarse();
        node.twoSided = error.showsTwoSides();
        node.sideAxis = static_cast<std::uint8_t>(error.sideAxis);
      }
      CoarseIdList& triangles = trianglesOf(i);
      std::copy(triangles.begin(), triangles.end(), built.leafTriangles.begin() + static_cast<std::ptrdiff_t>(begin[n]));
      CoarseIdList().swap(triangles);
    });
  }

 private:
  struct Record {
    std::uint32_t node;
    CoarseIdList triangles;
    bool showsCoarse, twoSided;
    std::uint8_t sideAxis;
  };
  // What a leaf adds to the outcome. No initializers: made for overwrite.
  struct Summary {
    double shown, area;
    bool showsCoarse, twoSided, atMaxDepth;
  };

  Summary summaryOf(const Leaf& leaf) const {
    return {leaf.error.shown(), leaf.error.area, leaf.error.showsCoarse(), leaf.error.showsTwoSides(),
            leaf.cell.depth >= maxDepth_};
  }
  static void count(const Summary& summary, RefinementOutcome& outcome) {
    outcome.error += summary.shown;
    outcome.area += summary.area;
    outcome.leavesShowingCoarse += summary.showsCoarse ? 1 : 0;
    outcome.twoSidedLeaves += summary.twoSided ? 1 : 0;
    outcome.leavesAtMaxDepth += summary.atMaxDepth ? 1 : 0;
  }

  // Leaf i: the records, then the leaves left in place.
  std::size_t leaves() const { return records_.size() + inPlace_.size(); }
  std::uint32_t nodeOf(std::size_t i) const {
    return i < records_.size() ? records_[i].node : inPlace_[i - records_.size()]->node;
  }
  CoarseIdList& trianglesOf(std::size_t i) {
    return i < records_.size() ? records_[i].triangles : inPlace_[i - records_.size()]->triangles;
  }

  int maxDepth_;
  std::vector<Record> records_;
  std::vector<Leaf*> inPlace_;
};

// The candidates' slots, in blocks of 4,096: growing the store moves no
// candidate (the leaves left queued are read through their addresses at the
// end), and finding a slot reads a table of a few hundred blocks, where
// std::deque's blocks of 512 bytes held two candidates each, and its table
// of blocks missed the cache on its own.
class CandidateSlots {
 public:
  std::size_t size() const { return size_; }
  Candidate& operator[](std::size_t i) { return blocks_[i >> kShift][i & kMask]; }
  Candidate& emplace_back() {
    if ((size_ & kMask) == 0) blocks_.push_back(std::make_unique<Candidate[]>(kBlock));
    return (*this)[size_++];
  }

 private:
  static constexpr std::size_t kShift = 12, kBlock = std::size_t{1} << kShift, kMask = kBlock - 1;
  std::vector<std::unique_ptr<Candidate[]>> blocks_;
  std::size_t size_ = 0;
};

// The global refinement (docs/bake.md, "Refinement"). Leaves that may split
// are queued unevaluated (by an upper bound of their split's value per
// texel) or evaluated (by the value itself). A leaf reaching the top
// unevaluated is evaluated and queued again, so only leaves near the top are
// ever clipped into children (a lazy greedy).
class GlobalRefinement {
 public:
  GlobalRefinement(const CoarseMesh& coarse, const DetailPrimitives& detail, const PointOrder* points,
                   const BuildSettings& settings, int sumDepth, std::vector<OctreeNode>& nodes, RefinementOutcome& outcome)
      : detail_(detail), settings_(settings), sumDepth_(sumDepth), refinement_(coarse, detail, points, settings, sumDepth),
        nodes_(nodes), outcome_(outcome), finished_(settings.maxDepth, settings.budgetTexels) {}

  // The coarse cells, their errors computed in parallel (from their fine
  // cells' sums, below which M's triangles are then clipped, when the sum
  // depth is below them).
  void start(std::vector<Leaf> leaves) {
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
      leaves[i].error = refinement_.errorOf(leaves[i]);
      if (refinement_.mayRefine(leaves[i])) leaves[i].keptChildren = refinement_.keptChildrenOf(leaves[i]);
    });
    for (const Leaf& leaf : leaves) outcome_.texels += leaf.error.texels() - 1;
    for (Leaf& leaf : leaves) file(std::move(leaf));
  }

  // Splits until the budget is spent or no leaf may split; returns whether
  // the budget stopped it.
  bool run() {
    const bool budgeted = settings_.budgetTexels > 0;
    // The coarse levels alone may exceed the budget: then nothing splits.
    bool budgetReached = budgeted && outcome_.texels > settings_.budgetTexels;
    while (!queue_.empty() && !budgetReached) budgetReached = round(budgeted);
    std::vector<Leaf*> left;
    left.reserve(queue_.size());
    for (const QueueEntry& entry : queue_.entries()) left.push_back(&slots_[entry.candidate()].leaf);
    finished_.addInPlace(std::move(left), outcome_);
    queue_.clear();
    return budgetReached;
  }

  // What only the splitting needed (M's fine sums and primitives, the splits
  // evaluated but not made), freed while the nodes are renumbered: a tenth of the 1.2M
  // bunny's build, freed after the layout on one core.
  void releaseSplitState() {
    fineSums_ = {};
    toEvaluate_ = {};
    evaluating_ = {};
    tbb::parallel_for(std::size_t{0}, slots_.size(), [&](std::size_t i) {
      decltype(Candidate::children)().swap(slots_[i].children);
      IdList().swap(slots_[i].leaf.primitives);
    });
  }

  // The leaves' lists of m's triangles laid out (FinishedLeaves::layOut).
  void layOut(const std::vector<std::uint32_t>& newNumber, BuiltOctree& built) { finished_.layOut(newNumber, built); }

 private:
  // A round: the top entries; evaluated ones split (while the budget lasts),
  // unevaluated ones are evaluated together, in parallel. Returns whether
  // the budget ran out.
  bool round(bool budgeted) {
    const std::size_t count = roundSize(queue_.size(), budgeted);
    // The leaves to evaluate are evaluated on the other cores as they come,
    // in batches, while this thread goes on popping and splitting (done
    // after the pops, the evaluation left the second core idle for a fifth
    // of the 1.2M bunny's build). Each is evaluated in its slot, through an
    // address taken here (the slots' store may grow meanwhile), and read
    // only after the wait: the round is the same on any number of threads.
    // In place, this thread moves no candidate in and out of the slots for
    // them (bunny build -3%).
    std::vector<std::uint32_t>& toEvaluate = toEvaluate_;
    std::vector<Candidate*>& evaluating = evaluating_;
    toEvaluate.clear();
    evaluating.clear();
    tbb::task_group evaluations;
    // Set once the budget is spent: the round is the last, and the leaves
    // popped for evaluation stay leaves whatever their split would give, so
    // the batches not yet begun are skipped (the 1.2M bunny's last round
    // sent 4,520 leaves to be evaluated in vain).
    std::atomic<bool> lastRound{false};
    std::size_t batched = 0;
    const auto evaluateFrom = [&](std::size_t end) {
      evaluations.run([this, candidates = evaluating.data(), first = batched, end, &lastRound] {
        ChildFiling& filing = filings_.local();
        for (std::size_t i = first; i < end && !lastRound.load(std::memory_order_relaxed); ++i) {
          Candidate& candidate = *candidates[i];
          candidate = refinement_.evaluate(std::move(candidate.leaf), filing);
        }
      });
      batched = end;
    };
    // Reserved: no batch may see the addresses move.
    evaluating.reserve(count);
    bool budgetReached = false;
    for (std::size_t k = 0; k < count && !queue_.empty(); ++k) {
      const QueueEntry entry = queue_.pop();
      // The next entry's candidate fetched while this one is handled: the
      // slots are read in the queue's order, a cache miss each (this
      // thread's pops, takes and splits took 0.3 s of the 1.2M bunny's
      // build, while one core evaluated; build 1.252 -> 1.219 s).
      if (!queue_.empty()) prefetchCandidate(slots_[queue_.top().candidate()]);
      if (!entry.evaluated()) {
        toEvaluate.push_back(entry.candidate());
        evaluating.push_back(&slots_[entry.candidate()]);
        if (evaluating.size() - batched == kEvaluationBatch) evaluateFrom(evaluating.size());
        continue;
      }
      const std::uint32_t slot = entry.candidate();
      Candidate& candidate = slots_[slot];
      if (budgeted && outcome_.texels + candidate.texels() > settings_.budgetTexels) {
        // Less than one split's texels (at most 9) are left: stop here.
        finished_.add(std::move(candidate.leaf), outcome_);
        freeSlots_.push_back(slot);
        budgetReached = true;
        lastRound.store(true, std::memory_order_relaxed);
        break;
      }
      split(slot);
    }
    if (!budgetReached && batched < evaluating.size()) evaluateFrom(evaluating.size());
    evaluations.wait();
    if (budgetReached) {
      // Evaluated or not (which depends on the threads' timing), each goes
      // back as it came: the leaves left, and their order, do not depend on
      // which were.
      for (const std::uint32_t slot : toEvaluate) queueSlot(slot, false);
      return true;
    }
    for (std::size_t i = 0; i < toEvaluate.size(); ++i) {
      // Written by the evaluating threads: fetched ahead into this one's cache.
      if (i + kPrefetchAhead < toEvaluate.size()) prefetchCandidate(*evaluating[i + kPrefetchAhead]);
      const std::uint32_t slot = toEvaluate[i];
      if (Refinement::worthSplitting(slots_[slot])) {
        queueSlot(slot, true);
      } else {
        finished_.add(std::move(slots_[slot].leaf), outcome_);
        freeSlots_.push_back(slot);
      }
    }
    return budgetReached;
  }

  // The candidate in `slot` split: its children into the tree and the
  // queue, the first of them into its slot, still in cache.
  void split(std::uint32_t slot) {
    Candidate& candidate = slots_[slot];
    outcome_.texels += candidate.texels();
    OctreeNode& parent = nodes_[candidate.leaf.node];
    parent.firstChild = static_cast<std::uint32_t>(nodes_.size());
    parent.childMask = candidate.mask;
    auto children = std::move(candidate.children);
    freeSlots_.push_back(slot);
    // The slots the other children will take (last freed, first taken),
    // fetched ahead.
    for (std::size_t k = 1; k < children.size() && k < freeSlots_.size(); ++k)
      prefetchCandidate(slots_[freeSlots_[freeSlots_.size() - 1 - k]]);
    for (Leaf& child : children) {
      child.node = static_cast<std::uint32_t>(nodes_.size());
      OctreeNode node;
      node.depth = static_cast<std::uint8_t>(child.cell.depth);
      nodes_.push_back(node);
      file(std::move(child));
    }
  }

  void file(Leaf leaf) {
    if (!refinement_.mayRefine(leaf)) {
      finished_.add(std::move(leaf), outcome_);
      return;
    }
    queueSlot(put(std::move(leaf)), false);
  }

  void queueSlot(std::uint32_t slot, bool evaluated) {
    const Candidate& candidate = slots_[slot];
    const LeafError& error = candidate.leaf.error;
    // Unevaluated: a split is worth at most the leaf's one-normal L2,1 (its
    // gain, or a child's error) and adds at least 1 texel per kept child and
    // 1 for the node (none to a two-sided leaf), so that ratio bounds its
    // key, and the first evaluated entry on top is the best split of all
    // (the greedy order; rounds of many entries stay close to it). Guesses
    // tighter than a bound (the parent's ratio) evaluated half as many
    // leaves but lost 2-4% of the accuracy on bunny00.
    const int texelsAtLeast = 2 - static_cast<int>(error.texels()) + std::max(1, candidate.leaf.keptChildren);
    const double key = evaluated ? candidate.valuePerTexel() : error.variation / static_cast<double>(texelsAtLeast);
    const std::uint32_t node = candidate.leaf.node;
    queue_.push({key, node, slot | (evaluated ? QueueEntry::kEvaluated : 0u)});
  }

  // Candidates live in reused slots: the queue holds only their keys.
  std::uint32_t put(Leaf leaf) {
    if (freeSlots_.empty()) {
      slots_.emplace_back().leaf = std::move(leaf);
      return static_cast<std::uint32_t>(slots_.size() - 1);
    }
    const std::uint32_t slot = freeSlots_.back();
    freeSlots_.pop_back();
    // Written in place: the slot holds what its last candidate left.
    Candidate& candidate = slots_[slot];
    candidate.leaf = std::move(leaf);
    candidate.mask = 0;
    decltype(Candidate::children)().swap(candidate.children);
    candidate.gain = candidate.largestChildError = 0.0;
    return slot;
  }

  const DetailPrimitives& detail_;
  const BuildSettings& settings_;
  int sumDepth_;
  const Refinement refinement_;
  std::vector<std::optional<FineSums>> fineSums_;  // per coarse cell, with a sum depth
  std::vector<OctreeNode>& nodes_;
  RefinementOutcome& outcome_;
  FinishedLeaves finished_;
  CandidateSlots slots_;
  std::vector<std::uint32_t> freeSlots_;
  SplitQueue queue_;
  // A round's leaves to evaluate: their slots and addresses; kept from round
  // to round, as fresh memory for each cost the kernel's zeroing of its pages.
  std::vector<std::uint32_t> toEvaluate_;
  std::vector<Candidate*> evaluating_;
  tbb::enumerable_thread_specific<ChildFiling> filings_;  // the evaluations' scratch lists, per thread
};

}  // namespace

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

BuiltOctree buildOctree(const CoarseMesh& coarse, const DetailPrimitives& detail, const BuildSettings& settings) {
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
  GlobalRefinement refinement(coarse, detail, pointOrder ? &*pointOrder : nullptr, settings, outcome.sumDepth, nodes,
                              outcome);
  refinement.start(std::move(first));
  const bool budgetReached = refinement.run();
  outcome.stoppedBy = budgetReached ? "budget" : settings.error > 0.0 ? "error" : "converged";
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
