// The L2,1 metric (bake/l21_metric.h) against ground truth: the sums of a
// triangle of M clipped to a cell against numeric integration of its
// interpolated normal field, points' variation in closed form, and the sum
// depth's rule on grids of known triangle sizes.
#include "bake/l21_metric.h"

#include "tests/bake/flat_grid.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <random>
#include <vector>

namespace apo::octree {
namespace {

TEST(NormalVariation, TwoNormalsAtAnAngle) {
  DetailPrimitives detail;
  const double angle = 0.6;
  detail.normals = {Vec3f(1, 0, 0), Vec3f(static_cast<float>(std::cos(angle)), static_cast<float>(std::sin(angle)), 0)};
  detail.weights = {1.0f, 1.0f};
  // The mean is the bisector; each normal is angle / 2 from it.
  const double each = 2.0 - 2.0 * std::cos(angle / 2.0);
  const Cell cell;
  EXPECT_NEAR(normalVariation(detail, {0, 1}, cell), 2.0 * each, 1e-6);
  EXPECT_NEAR(normalVariation(detail, {0}, cell), 0.0, 1e-12);
  detail.weights = {3.0f, 3.0f};
  EXPECT_NEAR(normalVariation(detail, {0, 1}, cell), 6.0 * each, 1e-5);
}

TEST(NormalVariation, IntegratesTheInterpolatedFieldOverTheTrianglePartInTheCell) {
  // One right triangle of legs 1 in z = 0.5, corner normals (1,0,0) at the
  // right angle and (0,0,1) at the other two: n(x, y) = (1 - u - v, 0, u + v)
  // in barycentrics. Ground truth by dense midpoint integration.
  // areaScale 2: weights in units of the triangle's own area (0.5).
  const DetailPrimitives detail = DetailPrimitives::ofMesh({{0.0f, 0.0f, 0.5f}, {1.0f, 0.0f, 0.5f}, {0.0f, 1.0f, 0.5f}},
                                                           {{0, 1, 2}}, {{1, 0, 0}, {0, 0, 1}, {0, 0, 1}}, 2.0);
  for (const Cell& cell : {Cell{Vec3f(0.5f, 0.5f, 0.5f), 1.0f, 0}, Cell{Vec3f(0.25f, 0.25f, 0.5f), 0.5f, 1}}) {
    const int n = 800;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    std::vector<std::pair<Eigen::Vector3d, double>> pieces;
    for (int i = 0; i < n; ++i)
      for (int j = 0; j < n; ++j) {
        const double x = (i + 0.5) / n, y = (j + 0.5) / n;
        if (x + y > 1.0 || (Vec3f(float(x), float(y), 0.5f) - cell.centre).cwiseAbs().maxCoeff() > 0.5f * cell.width) continue;
        const Eigen::Vector3d normal(1.0 - x - y, 0.0, x + y);
        pieces.emplace_back(normal, 1.0 / (n * n));
        sum += normal / (n * n);
      }
    const Eigen::Vector3d mean = sum.normalized();
    double expected = 0.0;
    for (const auto& [normal, area] : pieces) expected += area * (normal - mean).squaredNorm();
    // The midpoint grid misplaces area along the hypotenuse by about 1 / n.
    EXPECT_NEAR(normalVariation(detail, {0}, cell), 2.0 * expected, 1e-2 * expected) << "cell width " << cell.width;
  }
}

// Numeric integrals over the part of triangle abc inside a cell (closed
// box) of fields given in the triangle's barycentrics (u, v), with a bound
// of their error. The triangle is cut into n x n sub-triangles; one whose
// box lies inside the cell is integrated by the edge-midpoint rule, exact
// for the quadratics integrated here; one whose box misses the cell adds
// nothing; one whose box meets a face is cut into four, `levels` times,
// and then counts by its centroid. Only those last sub-triangles err, each
// by at most its area times the largest |integrand| (both the truth and the
// estimate lie in [-area max, area max]): `straddlingArea` is theirs.
struct NumericIntegral {
  std::array<Vec3f, 3> corners;
  Cell cell;
  double straddlingArea = 0.0;

  template <class Field>  // Field((u, v)) -> Eigen::VectorXd of the integrands
  Eigen::VectorXd integrate(Field field, int n, int levels) {
    Eigen::VectorXd sum = Eigen::VectorXd::Zero(field(Eigen::Vector2d(0.0, 0.0)).size());
    const double twiceArea =
        (corners[1] - corners[0]).cast<double>().cross((corners[2] - corners[0]).cast<double>()).norm();
    const double h = 1.0 / n;
    for (int i = 0; i < n; ++i)
      for (int j = 0; i + j < n; ++j) {
        add({i * h, j * h}, {(i + 1) * h, j * h}, {i * h, (j + 1) * h}, field, twiceArea, levels, sum);
        if (i + j + 1 < n) add({(i + 1) * h, (j + 1) * h}, {i * h, (j + 1) * h}, {(i + 1) * h, j * h}, field, twiceArea,
                               levels, sum);
      }
    return sum;
  }

 private:
  Eigen::Vector3d at(const Eigen::Vector2d& uv) const {
    const Eigen::Vector3d a = corners[0].cast<double>();
    return a + uv.x() * (corners[1].cast<double>() - a) + uv.y() * (corners[2].cast<double>() - a);
  }

  bool inside(const Eigen::Vector3d& p) const {
    return (p.array() >= cell.lower().cast<double>().array()).all() && (p.array() <= cell.upper().cast<double>().array()).all();
  }

  template <class Field>
  void add(const Eigen::Vector2d& p, const Eigen::Vector2d& q, const Eigen::Vector2d& r, Field& field, double twiceArea,
           int levels, Eigen::VectorXd& sum) {
    const double area = 0.5 * twiceArea * std::abs((q - p).x() * (r - p).y() - (q - p).y() * (r - p).x());
    const Eigen::Vector3d lo = at(p).cwiseMin(at(q)).cwiseMin(at(r)), hi = at(p).cwiseMax(at(q)).cwiseMax(at(r));
    if ((hi.array() < cell.lower().cast<double>().array()).any() || (lo.array() > cell.upper().cast<double>().array()).any())
      return;
    if (inside(lo) && inside(hi)) {
      sum += area / 3.0 * (field(0.5 * (p + q)) + field(0.5 * (q + r)) + field(0.5 * (r + p)));
      return;
    }
    if (levels == 0) {
      const Eigen::Vector2d centroid = (p + q + r) / 3.0;
      if (inside(at(centroid))) sum += area * field(centroid);
      straddlingArea += area;
      return;
    }
    const Eigen::Vector2d pq = 0.5 * (p + q), qr = 0.5 * (q + r), rp = 0.5 * (r + p);
    add(p, pq, rp, field, twiceArea, levels - 1, sum);
    add(pq, q, qr, field, twiceArea, levels - 1, sum);
    add(rp, qr, r, field, twiceArea, levels - 1, sum);
    add(pq, qr, rp, field, twiceArea, levels - 1, sum);
  }
};

Vec3f randomUnit(std::mt19937& rng) {
  std::normal_distribution<float> g(0.0f, 1.0f);
  return Vec3f(g(rng), g(rng), g(rng)).normalized();
}

// The metric's exact sums of one triangle of M in a cell, against numeric
// integration of the fields the metric integrates: M's normal n (linear on
// the triangle, from its corners' normals), m's normal r (likewise), over
// the triangle's part inside the cell: the area, the L2,1 against the unit
// mean normal (the integral of |n - n_C|^2, n_C = the normalised integral
// of n) and the integral of |n - r|^2, in units of the triangle's area.
// Tolerance: twice the straddling sub-triangles' area times the largest
// integrand (NumericIntegral); it stays under 1% of the triangle's area,
// while an error of the clip (a face, a corner of the part) or of the
// moments moves the sums by far more on most of the 300 cases.
TEST(ErrorInCell, MatchesNumericIntegrationOfTheInterpolatedFieldInTheCell) {
  std::mt19937 rng(31);
  int cut = 0;
  for (int trial = 0; trial < 300; ++trial) {
    const int depth = std::uniform_int_distribution<int>(1, 4)(rng);
    const float width = std::ldexp(1.0f, -depth);
    std::uniform_int_distribution<int> index(0, (1 << depth) - 1);
    const Cell cell{Vec3f((index(rng) + 0.5f) * width, (index(rng) + 0.5f) * width, (index(rng) + 0.5f) * width),
                    width, depth};
    std::uniform_real_distribution<float> around(-1.0f, 1.0f);
    std::array<Vec3f, 3> corners;
    for (Vec3f& corner : corners)
      corner = cell.centre + Vec3f(around(rng), around(rng), around(rng)) * width;
    // Normals near a common direction, as on a surface, and m's near them.
    const Vec3f base = randomUnit(rng);
    std::vector<Vec3f> normals, coarse;
    for (int k = 0; k < 3; ++k) {
      normals.push_back((base + 0.6f * randomUnit(rng)).normalized());
      coarse.push_back((base + 0.3f * randomUnit(rng)).normalized());
    }
    const double area = 0.5 * (corners[1] - corners[0]).cast<double>().cross((corners[2] - corners[0]).cast<double>()).norm();
    const DetailPrimitives detail = DetailPrimitives::ofMesh({corners[0], corners[1], corners[2]}, {{0, 1, 2}}, normals,
                                                             1.0 / area, {}, coarse);
    const LeafError error = errorInCell(detail, std::vector<std::uint32_t>{0}, cell, false, false);

    const auto linear = [](const std::vector<Vec3f>& f, double u, double v) {
      return Eigen::Vector3d(f[0].cast<double>() + u * (f[1] - f[0]).cast<double>() + v * (f[2] - f[0]).cast<double>());
    };
    const auto field = [&](double u, double v) {
      const Eigen::Vector3d n = linear(normals, u, v), r = linear(coarse, u, v);
      Eigen::VectorXd values(6);
      values << 1.0, n.x(), n.y(), n.z(), n.squaredNorm(), (n - r).squaredNorm();
      return values;
    };
    NumericIntegral numeric{corners, cell};
    const Eigen::VectorXd sums =
        numeric.integrate([&](const Eigen::Vector2d& uv) { return field(uv.x(), uv.y()); }, 32, 6) / area;
    const double straddling = numeric.straddlingArea / area;
    ASSERT_LT(2.0 * straddling, 0.01) << "trial " << trial;
    // The integrands' largest values: at the corners (|n|^2 and |n - r|^2
    // are convex, n's coordinates linear).
    double largestN = 0.0, largestGap = 0.0;
    for (int k = 0; k < 3; ++k) {
      largestN = std::max(largestN, static_cast<double>(normals[k].norm()));
      largestGap = std::max(largestGap, static_cast<double>((normals[k] - coarse[k]).squaredNorm()));
    }
    const double rounding = 1e-9;
    const double areaError = 2.0 * straddling, normalError = 2.0 * straddling * largestN,
                 squareError = 2.0 * straddling * largestN * largestN;
    EXPECT_NEAR(error.area, sums[0], areaError + rounding) << "trial " << trial;
    EXPECT_NEAR(error.coarse, sums[5], 2.0 * straddling * largestGap + rounding) << "trial " << trial;
    const Eigen::Vector3d integralOfN = sums.segment<3>(1);
    const double l21 = integralOfN.norm() > 0.0 ? std::max(0.0, sums[4] - 2.0 * integralOfN.norm() + sums[0]) : 0.0;
    // |n - n_C|^2 = |n|^2 - 2 n.n_C + 1 integrated: its error is at most
    // the three parts' (|integral of n| moves by at most sqrt(3) times
    // one coordinate's error).
    EXPECT_NEAR(error.variation, l21, squareError + 2.0 * std::sqrt(3.0) * normalError + areaError + rounding)
        << "trial " << trial;
    cut += sums[0] > 0.05 && sums[0] < 0.95 ? 1 : 0;
  }
  EXPECT_GT(cut, 100);  // the cell cut most triangles, rather than holding or missing them whole
}

// Right triangles whose legs are 1/256 of the cube: their longest side
// along an axis is 1/256, and the deepest cells at least twice as wide are
// those of depth 7 (1/128).
TEST(SumDepthFor, DeepestCellsTwiceAsWideAsMsTriangles) {
  const DetailPrimitives grid = flatGrid(64, 1.0f / 256.0f, 0.5f);
  BuildSettings settings;
  settings.coarseDepth = 3;
  settings.maxDepth = 13;
  EXPECT_EQ(sumDepthFor(grid, settings), 7);
  settings.maxDepth = 6;
  EXPECT_EQ(sumDepthFor(grid, settings), 6) << "never below the maximum depth";
  settings.maxDepth = 13;
  settings.coarseDepth = 7;
  EXPECT_EQ(sumDepthFor(grid, settings), 0) << "not below the coarse depth: level by level";
  settings.coarseDepth = 3;
  settings.sumDepth = 5;
  EXPECT_EQ(sumDepthFor(grid, settings), 5) << "as asked";
  settings.sumDepth = 0;
  EXPECT_EQ(sumDepthFor(grid, settings), 0) << "as asked";
  DetailPrimitives points;
  points.positions = {Vec3f::Constant(0.5f)};
  points.normals = {Vec3f::UnitZ()};
  points.weights = {1.0f};
  settings.sumDepth = -1;
  EXPECT_EQ(sumDepthFor(points, settings), 0) << "points are never clipped";
}

// 32,768 triangles of side 1/600 (the mean alone picks depth 8, cells of
// 1/256) and 32 triangles of side 1/4: at depth 8 these would be cut into
// 64^2 pieces each, 6.2 per triangle on average, over the 4.5 allowed; at
// depth 7, 2.5.
TEST(SumDepthFor, AFewLargeTrianglesAmongSmallOnesRaiseIt) {
  BuildSettings settings;
  settings.coarseDepth = 3;
  settings.maxDepth = 13;
  const DetailPrimitives small = flatGrid(128, 1.0f / 600.0f, 0.5f);
  EXPECT_EQ(sumDepthFor(small, settings), 8);
  const DetailPrimitives mixed = flatGrid(4, 0.25f, 0.6f, small);
  ASSERT_EQ(mixed.triangles.size(), small.triangles.size() + 32);
  EXPECT_EQ(sumDepthFor(mixed, settings), 7);
}

}  // namespace
}  // namespace apo::octree
