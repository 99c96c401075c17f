// The clipping of triangles into cells (bake/cell_clip.h) against brute
// force: overlap tests against dense sampling and each child tested apart,
// clipped polygons against a plain Sutherland-Hodgman clip in 3D, clipped
// areas against Monte Carlo, and the grid sweep's parts against the plain
// clip of the triangle to each cell of the grid.
#include "bake/cell_clip.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <random>
#include <vector>

namespace apo::octree {
namespace {

Vec3f randomPoint(std::mt19937& rng, float lo, float hi) {
  std::uniform_real_distribution<float> u(lo, hi);
  return {u(rng), u(rng), u(rng)};
}

// Points spread over triangle abc on a barycentric grid of `n` steps.
std::vector<Vec3f> trianglePoints(const Vec3f& a, const Vec3f& b, const Vec3f& c, int n) {
  std::vector<Vec3f> points;
  for (int i = 0; i <= n; ++i)
    for (int j = 0; i + j <= n; ++j) {
      const float u = static_cast<float>(i) / n, v = static_cast<float>(j) / n;
      points.push_back(a + u * (b - a) + v * (c - a));
    }
  return points;
}

float distanceToCell(const Vec3f& p, const Cell& cell) {
  return (p - p.cwiseMax(cell.lower()).cwiseMin(cell.upper())).norm();
}

using Polygon3 = std::vector<Eigen::Vector3d>;

// The textbook clip: the polygon against each of the box's six half-spaces
// in turn, in double, every face whether the polygon crosses it or not.
Polygon3 plainClip(Polygon3 polygon, const Eigen::Vector3d& lower, const Eigen::Vector3d& upper) {
  for (int axis = 0; axis < 3; ++axis)
    for (const double sign : {1.0, -1.0}) {
      const double bound = sign > 0.0 ? upper[axis] : lower[axis];
      Polygon3 kept;
      for (std::size_t i = 0; i < polygon.size(); ++i) {
        const Eigen::Vector3d& p = polygon[i];
        const Eigen::Vector3d& q = polygon[(i + 1) % polygon.size()];
        const double dp = sign * (p[axis] - bound), dq = sign * (q[axis] - bound);
        if (dp <= 0.0) kept.push_back(p);
        if ((dp < 0.0 && dq > 0.0) || (dp > 0.0 && dq < 0.0)) kept.push_back(p + (q - p) * (dp / (dp - dq)));
      }
      polygon = kept;
    }
  return polygon;
}

Polygon3 plainClip(const Vec3f& a, const Vec3f& b, const Vec3f& c, const Cell& cell) {
  return plainClip({a.cast<double>(), b.cast<double>(), c.cast<double>()}, cell.lower().cast<double>(),
                   cell.upper().cast<double>());
}

double areaOf(const Polygon3& polygon) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (std::size_t i = 1; i + 1 < polygon.size(); ++i) sum += (polygon[i] - polygon[0]).cross(polygon[i + 1] - polygon[0]);
  return 0.5 * sum.norm();
}

// The farthest any corner of `from` is from the nearest corner of `to`.
double farthestCorner(const Polygon3& from, const Polygon3& to) {
  double farthest = 0.0;
  for (const Eigen::Vector3d& p : from) {
    double nearest = std::numeric_limits<double>::infinity();
    for (const Eigen::Vector3d& q : to) nearest = std::min(nearest, (p - q).norm());
    farthest = std::max(farthest, nearest);
  }
  return farthest;
}

// A dyadic cell of depth 1 to 6 anywhere in the cube.
Cell randomCell(std::mt19937& rng) {
  const int depth = std::uniform_int_distribution<int>(1, 6)(rng);
  const int cells = 1 << depth;
  std::uniform_int_distribution<int> index(0, cells - 1);
  const float width = 1.0f / static_cast<float>(cells);
  const Vec3f centre((index(rng) + 0.5f) * width, (index(rng) + 0.5f) * width, (index(rng) + 0.5f) * width);
  return {centre, width, depth};
}

// A corner near the cell: each coordinate on the cell's lower face, its
// upper face, its midplane or anywhere within a width of it, so that
// corners fall on the cell's faces, edges and corners, and edges and whole
// triangles lie in its faces.
Vec3f cornerNear(std::mt19937& rng, const Cell& cell) {
  std::uniform_int_distribution<int> kind(0, 5);
  std::uniform_real_distribution<float> spread(-1.0f, 1.0f);
  Vec3f p;
  for (int axis = 0; axis < 3; ++axis) {
    switch (kind(rng)) {
      case 0: p[axis] = cell.lower()[axis]; break;
      case 1: p[axis] = cell.upper()[axis]; break;
      case 2: p[axis] = cell.centre[axis]; break;
      default: p[axis] = cell.centre[axis] + spread(rng) * cell.width;
    }
  }
  return p;
}

TEST(TriangleOverlapsBox, AgreesWithDenseSampling) {
  std::mt19937 rng(7);
  int overlapping = 0, apart = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    const Cell cell{randomPoint(rng, 0.3f, 0.7f), 0.2f, 3};
    const Vec3f a = randomPoint(rng, 0.0f, 1.0f), b = randomPoint(rng, 0.0f, 1.0f), c = randomPoint(rng, 0.0f, 1.0f);
    const int n = 300;
    float nearest = 1e9f;
    for (const Vec3f& p : trianglePoints(a, b, c, n)) nearest = std::min(nearest, distanceToCell(p, cell));
    // Grid points are at most an edge / n apart: a triangle that meets the
    // box has a grid point within that of it.
    const float resolution = std::max({(b - a).norm(), (c - a).norm(), (c - b).norm()}) / n;
    const bool overlaps = triangleOverlapsBox(a, b, c, cell);
    if (nearest == 0.0f) {
      EXPECT_TRUE(overlaps) << "trial " << trial;
    }
    if (nearest > resolution) {
      EXPECT_FALSE(overlaps) << "trial " << trial << " nearest " << nearest;
    }
    (overlaps ? overlapping : apart) += 1;
  }
  EXPECT_GT(overlapping, 300);  // both outcomes were exercised
  EXPECT_GT(apart, 300);
}

// The eight children's mask is each child's own test, made in one pass;
// triangles of every size against the cell (inside one child, across it,
// far larger), and triangles lying in the cell's midplanes, which meet the
// closed children on both sides.
TEST(ChildrenMeeting, AgreesWithEachChildTestedApart) {
  std::mt19937 rng(19);
  std::uniform_real_distribution<float> scale(0.01f, 2.0f);
  std::uniform_int_distribution<int> anyMask(0, 255);
  int meetings = 0, misses = 0, partly = 0;
  const auto check = [&](const Vec3f& a, const Vec3f& b, const Vec3f& c, const Cell& cell, int trial) {
    unsigned apart = 0;
    for (int child = 0; child < 8; ++child)
      if (triangleOverlapsBox(a, b, c, cell.child(child))) apart |= 1u << child;
    ASSERT_EQ(childrenMeeting(a, b, c, cell), apart) << "trial " << trial;
    const auto wanted = static_cast<std::uint8_t>(anyMask(rng));
    ASSERT_EQ(childrenMeeting(a, b, c, cell, wanted), apart & wanted) << "trial " << trial;
    for (int child = 0; child < 8; ++child) ((apart >> child) & 1u ? meetings : misses) += 1;
    partly += apart != 0 && apart != 0xFF ? 1 : 0;
  };
  for (int trial = 0; trial < 20000; ++trial) {
    const Cell cell{randomPoint(rng, 0.3f, 0.7f), 0.25f, 2};
    const Vec3f centre = cell.centre + (randomPoint(rng, 0.0f, 1.0f) - Vec3f::Constant(0.5f)) * 0.5f;
    const float size = scale(rng) * cell.width;
    const auto corner = [&]() -> Vec3f { return centre + (randomPoint(rng, 0.0f, 1.0f) - Vec3f::Constant(0.5f)) * size; };
    check(corner(), corner(), corner(), cell, trial);
  }
  const Cell cell{Vec3f::Constant(0.5f), 0.5f, 1};
  for (int axis = 0; axis < 3; ++axis) {
    // In the midplane, around the centre: all eight closed children.
    Vec3f a = Vec3f::Constant(0.3f), b = Vec3f::Constant(0.3f), c = Vec3f::Constant(0.3f);
    a[axis] = b[axis] = c[axis] = 0.5f;
    b[(axis + 1) % 3] = 0.9f;
    c[(axis + 2) % 3] = 0.9f;
    check(a, b, c, cell, -1 - axis);
    EXPECT_EQ(std::popcount(static_cast<unsigned>(childrenMeeting(a, b, c, cell))), 8);
  }
  // Touching at a corner within rounding (colored_tetra.ply's m: the face
  // x + y + z = 1.0098 through the corner (0.421875, 0.578125) of a cell's
  // lower face, at its edge z = 0.0098): tested there as each child alone.
  const Vec3f tetra(0.00980392192f, 0.00980392192f, 0.990196049f);
  check(tetra, Vec3f(0.990196049f, 0.00980392192f, 0.00980392192f), Vec3f(0.00980392192f, 0.990196049f, 0.00980392192f),
        Cell{Vec3f(0.421875f, 0.578125f, 0.015625f), 0.03125f, 5}, -4);
  EXPECT_GT(meetings, 5000);  // every outcome was exercised
  EXPECT_GT(misses, 50000);
  EXPECT_GT(partly, 2000) << meetings << " " << misses;
}

TEST(ClipTriangleToCell, AreaMatchesMonteCarlo) {
  std::mt19937 rng(11);
  for (int trial = 0; trial < 40; ++trial) {
    const Cell cell{Vec3f(0.5f, 0.5f, 0.5f), 0.3f, 2};
    const Vec3f a = randomPoint(rng, 0.2f, 0.8f), b = randomPoint(rng, 0.2f, 0.8f), c = randomPoint(rng, 0.2f, 0.8f);
    const double area = 0.5 * (b - a).cast<double>().cross((c - a).cast<double>()).norm();
    std::uniform_real_distribution<float> u(0.0f, 1.0f);
    const int samples = 200000;
    int inside = 0;
    for (int s = 0; s < samples; ++s) {
      float r1 = u(rng), r2 = u(rng);
      if (r1 + r2 > 1.0f) r1 = 1.0f - r1, r2 = 1.0f - r2;
      const Vec3f p = a + r1 * (b - a) + r2 * (c - a);
      inside += distanceToCell(p, cell) == 0.0f ? 1 : 0;
    }
    const double expected = area * inside / samples;
    // Binomial standard error of the fraction, times the area, times 5.
    const double tolerance = 5.0 * area * std::sqrt(0.25 / samples) + 1e-7;
    EXPECT_NEAR(polygonArea(clipTriangleToCell(a, b, c, cell).view()), expected, tolerance) << "trial " << trial;
  }
}

// The clip in the triangle's own coordinates, of only the faces it crosses,
// gives the textbook clip's polygon: the same area and the same corners (up
// to the float rounding of the clip's corners), on random
// triangles and cells, many with corners, edges or the whole triangle on
// the cell's faces, edges and corners.
TEST(ClipTriangleToCell, MatchesAPlainSutherlandHodgmanClip) {
  std::mt19937 rng(23);
  int empty = 0, whole = 0, cut = 0, inAFace = 0;
  for (int trial = 0; trial < 20000; ++trial) {
    const Cell cell = randomCell(rng);
    Vec3f a = cornerNear(rng, cell), b = cornerNear(rng, cell), c = cornerNear(rng, cell);
    if (trial % 10 == 0) {  // the whole triangle in a face of the cell
      const int axis = trial % 3;
      a[axis] = b[axis] = c[axis] = (trial / 10) % 2 ? cell.lower()[axis] : cell.upper()[axis];
      ++inAFace;
    }
    const Polygon3 expected = plainClip(a, b, c, cell);
    const CellPolygon clipped = clipTriangleToCell(a, b, c, cell);
    Polygon3 corners;
    for (const Vec3f& p : clipped.view()) corners.push_back(p.cast<double>());
    const double triangleArea = 0.5 * ((b - a).cast<double>().cross((c - a).cast<double>())).norm();
    // The clip's corners are rounded to float: by at most sqrt(3) 6e-8 in
    // the unit cube, which moves the area by at most that times the
    // polygon's perimeter (under 9 cell widths).
    const double cornerRounding = 1.1e-7;
    ASSERT_NEAR(polygonArea(clipped.view()), areaOf(expected), 9.0 * cell.width * cornerRounding + 1e-15)
        << "trial " << trial;
    // A part without area (the triangle touching the cell along a segment
    // of a face or at a point) is a matter of rounding for either clip, and
    // nothing to the metric or the sampling, which take its area: only its
    // area is compared.
    const bool flat = areaOf(expected) <= 1e-9 * cell.width * cell.width;
    // Corners: the float rounding, and where an edge grazes a face, the
    // crossing moves by the rounding of its ends' distances to the face over
    // their difference: 1e-4 of the cell, far under any wrong corner.
    const double cornerTolerance = cornerRounding + 1e-4 * cell.width;
    if (!flat) {
      ASSERT_LE(farthestCorner(corners, expected), cornerTolerance) << "trial " << trial;
      ASSERT_LE(farthestCorner(expected, corners), cornerTolerance) << "trial " << trial;
    }
    if (flat)
      ++empty;
    else if (std::abs(areaOf(expected) - triangleArea) <= 1e-9 * triangleArea)
      ++whole;
    else
      ++cut;
  }
  EXPECT_GT(empty, 1000);  // every outcome was exercised
  EXPECT_GT(whole, 1000);
  EXPECT_GT(cut, 5000) << empty << " " << whole;
  EXPECT_EQ(inAFace, 2000);
}

// The area of a part in the (u, v) plane, times twice the triangle's area,
// is its area in space.
double parameterArea(const ParameterPolygon& polygon) {
  double twice = 0.0;
  for (int i = 0; i < polygon.size; ++i) {
    const Eigen::Vector2d& p = polygon.corners[i];
    const Eigen::Vector2d& q = polygon.corners[(i + 1) % polygon.size];
    twice += p.x() * q.y() - q.x() * p.y();
  }
  return 0.5 * twice;
}

// The sweep cuts a triangle into a grid's cells: each cell's parts have the
// area the textbook clip leaves in that cell, and each part is flagged whole
// exactly when it is the whole triangle. Triangles in general position
// (none lies in a plane between cells, where the sweep counts a piece once
// and the plain clip twice: the next test).
TEST(GridSweep, EachCellsPartIsThePlainClipToThatCell) {
  std::mt19937 rng(29);
  int cellsMet = 0, wholes = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    const Cell cell = randomCell(rng);
    const int levels = std::uniform_int_distribution<int>(0, 2)(rng);
    const float size = std::uniform_real_distribution<float>(0.05f, 1.5f)(rng) * cell.width;
    const Vec3f centre = cell.centre + (randomPoint(rng, 0.0f, 1.0f) - Vec3f::Constant(0.5f)) * cell.width;
    const auto corner = [&] { return Vec3f(centre + (randomPoint(rng, 0.0f, 1.0f) - Vec3f::Constant(0.5f)) * size); };
    const Vec3f a = corner(), b = corner(), c = corner();
    const double twiceArea = ((b - a).cast<double>().cross((c - a).cast<double>())).norm();
    const GridAxes grid = gridInside(cell, levels);
    const int side = 1 << levels;
    std::vector<double> swept(side * side * side, 0.0);
    const TriangleFrame frame(a, b, c);
    GridSweep(frame, grid).run(kEveryCell, [&](const GridPart& part) {
      swept[(part.cell[0] * side + part.cell[1]) * side + part.cell[2]] += twiceArea * parameterArea(*part.polygon);
      if (part.whole) {
        ++wholes;
        EXPECT_NEAR(parameterArea(*part.polygon), 0.5, 1e-15) << "trial " << trial;
      }
    });
    for (int x = 0; x < side; ++x)
      for (int y = 0; y < side; ++y)
        for (int z = 0; z < side; ++z) {
          const float width = grid[0].width;
          const Cell gridCell{Vec3f((grid[0].first + x + 0.5f) * width, (grid[1].first + y + 0.5f) * width,
                                    (grid[2].first + z + 0.5f) * width),
                              width, cell.depth + levels};
          const double expected = areaOf(plainClip(a, b, c, gridCell));
          ASSERT_NEAR(swept[(x * side + y) * side + z], expected, 1e-7 * twiceArea) << "trial " << trial;
          cellsMet += expected > 0.0 ? 1 : 0;
        }
  }
  EXPECT_GT(cellsMet, 3000);
  EXPECT_GT(wholes, 100);
}

// A triangle lying in the plane between two cells is filed in the lower
// one, once: the parts add up to the triangle's area, where clipping to
// each cell apart counts it in both.
TEST(GridSweep, APieceInAPlaneBetweenCellsIsTheLowerCells) {
  const Cell cell{Vec3f::Constant(0.5f), 1.0f, 0};
  const Vec3f a(0.1f, 0.2f, 0.5f), b(0.9f, 0.3f, 0.5f), c(0.4f, 0.8f, 0.5f);
  const double area = 0.5 * ((b - a).cast<double>().cross((c - a).cast<double>())).norm();
  double total = 0.0;
  const TriangleFrame frame(a, b, c);
  GridSweep(frame, gridInside(cell, 1)).run(kEveryCell, [&](const GridPart& part) {
    EXPECT_EQ(part.cell[2], 0) << "the lower cell along z";
    total += 2.0 * area * parameterArea(*part.polygon);
  });
  EXPECT_NEAR(total, area, 1e-12);
  double eachChildApart = 0.0;
  for (int child = 0; child < 8; ++child) eachChildApart += areaOf(plainClip(a, b, c, cell.child(child)));
  EXPECT_NEAR(eachChildApart, 2.0 * area, 1e-7) << "the closed children on both sides of z = 1/2 hold it";
}

}  // namespace
}  // namespace apo::octree
