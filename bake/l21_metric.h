// Inside bake: the L2,1 metric of paper 3.1 (Cohen-Steiner's integral of
// |n(x) - n_C|^2 over M inside a cell, n_C the unit mean normal), in units
// of M's mean triangle area. A triangle of M is clipped into a cell in its
// own (u, v) coordinates (cell_clip.h); the integrals of M's normal field,
// linear on the triangle, and of its square follow exactly from the part's
// moments. A cell's sums (VariationSums) give its L2,1 and what a leaf
// shows (LeafError): one normal, one per side of m, or m's own normals.
// M's points are summed in Morton order (PointOrder); M's triangles are
// clipped once into the cells of a fine depth, whose sums the cells above
// add up (FineSums, sumDepthFor).
//
// The moments, the linear fields and the sums' additions are defined here,
// inline: the refinement's evaluation adds every piece of M it clips, and
// a call into another unit per piece would cost the build what one unit's
// inlining spared it.
#pragma once

#include "bake/cell_clip.h"
#include "bake/octree_build.h"

#include <array>
#include <cstdint>
#include <limits>
#include <numbers>
#include <optional>
#include <span>
#include <utility>
#include <vector>

namespace apo::octree {

// The integrals of 1, u, v, u^2, uv and v^2 over a region of the (u, v)
// plane.
struct ParameterMoments {
  double area = 0.0, u = 0.0, v = 0.0, uu = 0.0, uv = 0.0, vv = 0.0;
};

// The unit triangle's: the whole of abc.
inline constexpr ParameterMoments kWholeTriangle{1.0 / 2.0, 1.0 / 6.0, 1.0 / 6.0, 1.0 / 12.0, 1.0 / 24.0, 1.0 / 12.0};

// A polygon's moments by Green's theorem, edge by edge (counter-clockwise,
// as the unit triangle and every part clipped from it).
inline ParameterMoments momentsOf(const ParameterPolygon& polygon) {
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
inline ParameterMoments momentsOf(const GridPart& part) { return part.whole ? kWholeTriangle : momentsOf(*part.polygon); }

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
inline double integralOf(const ParameterMoments& field, const ParameterMoments& m) {
  return field.area * m.area + field.u * m.u + field.v * m.v + field.uu * m.uu + field.uv * m.uv + field.vv * m.vv;
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
  std::pair<int, double> bestTwoSides() const;
};

// A leaf that stops refining shows m's normals where they leave less than
// this share of its own error. The leaf's error is that of one constant
// normal, but the renders blend neighbouring leaves (paper 5.3), which
// follows M far closer (30-60% less error on the bundled meshes): taking m
// wherever it merely beats the constant cost bunny00 6% of its filtered
// accuracy at 3 MiB (0.208 degrees mean against 0.196).
inline constexpr double kCoarseAdvantage = 0.01;
// m's normals within this of M's (root mean square) are M's for any
// renderer: such a leaf needs no split (m is M there, as when M had no more
// faces than the simplification's target).
inline constexpr double kCoarseExactDegrees = 0.02;

inline double squaredRadians(double degrees) {
  const double radians = degrees * std::numbers::pi / 180.0;
  return radians * radians;
}

// A leaf shows two normals, one per side of m (format version 4), where
// they leave less than this share of its one normal's error: thin parts,
// where the one normal averages opposite sides, leave far less. Measured
// (docs/benchmarks.md, "Two-sided leaves"): at 0.5, many leaves of merely
// curved cells took the second texel and the bundled meshes lost 0.3-2% at
// 3 MiB; at 0.2, none lost more than 0.3% and camel.off at 256 KiB gained 7.8% (docs/benchmarks.md).
inline constexpr double kTwoSidedAdvantage = 0.2;

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

// A cell of any depth by its depth and grid coordinates.
using CellId = std::uint64_t;
inline constexpr int kCellIdDepthShift = 58;  // above a depth-16 grid key's 48 bits
CellId cellIdOf(const Cell& cell);
// The cell of depth `depth` (at most the cell's) holding it.
CellId ancestorId(CellId cell, int depth);
// The cell of depth `depth` whose run of PointOrder holds a point (unit-cube
// coordinates; a point on a face goes to the lower cell); none outside the cube.
std::optional<CellId> pointCellId(const Vec3f& p, int depth);

// The L2,1 metric's errors of cells, as one build found them and another
// reads them back (the bake in bricks, docs/bake.md "Bricks"): each brick's
// build over its own points records the errors of the cells inside the
// brick, and the build of the whole tree takes them from the records, never
// from M, and so makes the splits the build over all of M would.
class RecordedErrors {
 public:
  void add(const std::vector<std::pair<CellId, LeafError>>& found);
  // Sorts what was added by cell, each cell once (a cell's error is the
  // same however often it was found); before `find`.
  void seal();
  const LeafError* find(CellId cell) const;
  std::size_t size() const { return records_.size(); }

 private:
  std::vector<std::pair<CellId, LeafError>> records_;
  std::size_t sealed_ = 0;  // records_[0, sealed_) are sorted and unique
};

// What a build records or reads back beside the metric (none by default).
struct ErrorExchange {
  // Recording: the errors the metric gives cells inside `within` go to `recorded`.
  const Cell* within = nullptr;
  std::vector<std::pair<CellId, LeafError>>* recorded = nullptr;
  // Reading back: errors come from `replay` (the DetailPrimitives given are
  // then empty); the cells it lacks go to `missing`, with a zero error.
  const RecordedErrors* replay = nullptr;
  std::vector<CellId>* missing = nullptr;
};

// A leaf's error from its sums. `withCoarse`: m's normals are known;
// `twoSides`: whether the leaf may show two normals (it needs m's normals,
// and a parent's kind bit: below the completion depth).
LeafError leafErrorOf(const VariationSums& sums, bool withCoarse, bool deferToCoarse, bool twoSides);

// A point of M: its weight, normal and (null when unknown) m's normal where
// it projects.
void addWeightedNormal(float weight, const Vec3f& normalOfM, const Vec3f* normalOfCoarse, VariationSums& sums);

// The error of the primitives of M in the cell, each clipped to it (M's
// triangles) or whole (M's points).
LeafError errorInCell(const DetailPrimitives& detail, std::span<const std::uint32_t> primitives, const Cell& cell,
                      bool deferToCoarse, bool twoSides);

// L2,1 of the primitives in a cell (paper 3.1, Cohen-Steiner's integral):
// the integral over M inside the cell of |n(x) - n_C|^2, n(x) M's
// interpolated normal and n_C the unit mean normal, over M's mean triangle
// area; for points, the sum of w_i |n_i - n_C|^2.
double normalVariation(const DetailPrimitives& detail, const std::vector<std::uint32_t>& primitives, const Cell& cell);

// ---- Points in Morton order ---------------------------------------------------

// Positions [first, end) of a sorted key array: the points in a cell (in
// PointOrder), M's fine cells in a cell (in FineSums).
struct KeyRun {
  std::uint32_t first = 0, end = 0;
};

// The run of `keys` (Morton codes of the cells of depth `keyDepth`, counted
// from the lower corner of `frame`, a cell holding `cell`) inside `cell`,
// within `within` (a run holding it).
KeyRun runOfCell(const std::vector<std::uint64_t>& keys, const Cell& cell, const Cell& frame, int keyDepth,
                 KeyRun within);

// M's points sorted by the Morton code of the finest cell holding each: the
// points in any cell are then one run of the order, found by two binary
// searches, and summed in one pass over contiguous records. Filing each
// point into the children of every cell it went down through, as triangles
// are, cost the 2M-point bake a third of its build (docs/bake.md,
// "A faster build").
class PointOrder {
 public:
  explicit PointOrder(const DetailPrimitives& d);

  // The run of the points in `cell`, within `within` (a run holding it).
  KeyRun runOf(const Cell& cell, KeyRun within) const;
  KeyRun all() const { return {0, static_cast<std::uint32_t>(keys_.size())}; }
  VariationSums sumsOf(KeyRun run) const;

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

// The depth at which buildOctree clips M's triangles once (BuildSettings::
// sumDepth resolved): the deepest whose cells are twice as wide as M's
// triangles, raised where a few large triangles would be cut into many
// pieces; 0 when it clips them level by level (M points, or triangles as
// large as the coarse cells).
int sumDepthFor(const DetailPrimitives& detail, const BuildSettings& settings);

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

  FineSums(const DetailPrimitives& d, const IdList& triangles, const Cell& coarseCell, int sumDepth, Scratch& scratch);

  KeyRun all() const { return {0, static_cast<std::uint32_t>(keys_.size())}; }

  // The run of the fine cells inside `cell` (inside the coarse cell, at most
  // as deep as the fine cells), within `within` (a run holding it).
  KeyRun runOf(const Cell& cell, KeyRun within) const;

  VariationSums sumsOf(KeyRun run) const;

  // M's triangles in the run's cells (one fine cell, or none).
  IdList trianglesOf(KeyRun run) const;

 private:
  void clipIntoFineCells(const DetailPrimitives& d, const IdList& triangles, int sumDepth, Scratch& scratch) const;
  void addUpByCell(Scratch& scratch);

  Cell coarse_;
  int levels_;
  std::vector<std::uint64_t> keys_;
  std::vector<VariationSums> sums_;
  std::vector<std::uint32_t> begin_;  // per cell, into triangles_; one more at the end
  std::vector<std::uint32_t> triangles_;
};

}  // namespace apo::octree
