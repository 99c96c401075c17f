// The octree build (paper 3.1) against brute force: the leaves' triangle
// lists against testing every triangle, and refinement against where an
// analytic normal field varies. Its units' own tests: cell_clip_test.cpp,
// l21_metric_test.cpp, refinement_test.cpp.
#include "bake/octree_build.h"

#include "bake/cell_clip.h"
#include "bake/l21_metric.h"

#include "tests/bake/flat_grid.h"
#include "tests/test_support.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <numbers>
#include <random>

namespace apo::octree {
namespace {

// m: an icosphere in the unit cube; M: the same sphere's triangles, their
// normals bent by a bump of angular radius ~0.3 rad around +z.
struct SphereCase {
  CoarseMesh coarse;
  DetailPrimitives detail;
};

bool inBump(const Vec3f& directionFromCentre) { return directionFromCentre.normalized().z() > std::cos(0.3f); }

SphereCase bumpySphereCase() {
  const Scan sphere = test::makeIcosphere(3);
  const Scan dense = test::makeIcosphere(5);
  SphereCase c;
  const auto toUnit = [](const Vec3f& p) { return Vec3f(0.5f + 0.4f * p.x(), 0.5f + 0.4f * p.y(), 0.5f + 0.4f * p.z()); };
  for (const Vec3f& p : sphere.points.positions) c.coarse.positions.push_back(toUnit(p));
  c.coarse.triangles = sphere.triangles;
  std::vector<Vec3f> positions, normals;
  for (const Vec3f& p : dense.points.positions) {
    positions.push_back(toUnit(p));
    Vec3f normal = p.normalized();
    // In the bump, the normal wobbles with the longitude: high variation.
    if (inBump(p)) normal = (normal + 0.5f * Vec3f(std::sin(40.0f * p.x()), std::cos(40.0f * p.y()), 0.0f)).normalized();
    normals.push_back(normal);
  }
  const double meanArea = 4.0 * std::numbers::pi * 0.4 * 0.4 / static_cast<double>(dense.triangles.size());
  c.detail = DetailPrimitives::ofMesh(positions, dense.triangles, normals, 1.0 / meanArea);
  return c;
}

// Every node's cell, walking from the root: nodes are reached through their
// parents' broods.
std::vector<Cell> cellsOf(const Octree& octree) {
  std::vector<Cell> cells(octree.nodes.size());
  for (std::uint32_t n = 0; n < octree.nodes.size(); ++n) {
    const OctreeNode& node = octree.nodes[n];
    std::uint32_t child = node.firstChild;
    for (int c = 0; c < 8; ++c)
      if (node.childMask & (1u << c)) cells[child++] = cells[n].child(c);
  }
  return cells;
}

Cell cellOfNode(const Octree& octree, std::uint32_t target) { return cellsOf(octree)[target]; }

TEST(BuildOctree, LeavesHoldExactlyTheTrianglesOfMThatOverlapThem) {
  const SphereCase c = bumpySphereCase();
  const BuiltOctree built = buildOctree(c.coarse, c.detail, {3, 7, 0.05});
  const Octree& octree = built.octree;
  ASSERT_GT(octree.nodes.size(), 100u);
  std::vector<Cell> cells(octree.nodes.size());
  std::uint64_t leaves = 0;
  for (std::uint32_t n = 0; n < octree.nodes.size(); ++n) {
    const OctreeNode& node = octree.nodes[n];
    if (node.isLeaf()) {
      ++leaves;
      std::vector<std::uint32_t> expected;
      for (std::uint32_t t = 0; t < c.coarse.triangles.size(); ++t) {
        const Triangle& tri = c.coarse.triangles[t];
        if (triangleOverlapsBox(c.coarse.positions[tri[0]], c.coarse.positions[tri[1]], c.coarse.positions[tri[2]], cells[n]))
          expected.push_back(t);
      }
      const std::vector<std::uint32_t> listed(built.leafTriangles.begin() + static_cast<std::ptrdiff_t>(built.leafTriangleBegin[n]),
                                              built.leafTriangles.begin() + static_cast<std::ptrdiff_t>(built.leafTriangleBegin[n + 1]));
      EXPECT_EQ(listed, expected) << "leaf " << n;
      EXPECT_FALSE(expected.empty());
      continue;
    }
    EXPECT_EQ(built.leafTriangleBegin[n], built.leafTriangleBegin[n + 1]) << "internal node " << n << " has triangles";
    ASSERT_GT(node.firstChild, n) << "children come after their parent";
    std::uint32_t child = node.firstChild;
    for (int k = 0; k < 8; ++k) {
      const Cell childCell = cells[n].child(k);
      // A child exists exactly when some triangle of m meets it.
      bool met = false;
      for (const Triangle& tri : c.coarse.triangles)
        met = met || triangleOverlapsBox(c.coarse.positions[tri[0]], c.coarse.positions[tri[1]], c.coarse.positions[tri[2]], childCell);
      EXPECT_EQ(met, (node.childMask & (1u << k)) != 0) << "node " << n << " child " << k;
      if (node.childMask & (1u << k)) {
        EXPECT_EQ(octree.nodes[child].depth, node.depth + 1);
        cells[child++] = childCell;
      }
    }
  }
  EXPECT_GT(leaves, 0u);
}

TEST(BuildOctree, RefinesWhereTheNormalsVaryAndOnlyThere) {
  // Outside the bump M's normals are radial: a depth-6 cell (1/64 of the
  // cube, 0.04 rad of this sphere) holds about 5 triangles' worth of M
  // within 0.02 rad of their mean, L2,1 ~ 5 x 0.02^2 < 0.05: no leaf there
  // reaches depth 7. In the bump the normals wobble by ~0.5 over less than a
  // depth-7 cell: leaves at the maximum depth, 7.
  const SphereCase c = bumpySphereCase();
  const BuiltOctree built = buildOctree(c.coarse, c.detail, {3, 7, 0.05});
  int inBumpLeaves = 0, inBumpDeepest = 0, outsideLeaves = 0, outsideDeepest = 0;
  for (std::uint32_t n = 0; n < built.octree.nodes.size(); ++n) {
    const OctreeNode& node = built.octree.nodes[n];
    if (!node.isLeaf()) continue;
    const Vec3f direction = cellOfNode(built.octree, n).centre - Vec3f::Constant(0.5f);
    if (inBump(direction)) {
      ++inBumpLeaves;
      inBumpDeepest += node.depth == 7 ? 1 : 0;
    } else if (direction.normalized().z() < std::cos(0.4f)) {  // clear of the bump's edge
      ++outsideLeaves;
      outsideDeepest += node.depth == 7 ? 1 : 0;
    }
  }
  ASSERT_GT(inBumpLeaves, 100);
  ASSERT_GT(outsideLeaves, 100);
  // Cells the sphere only grazes hold too little of M to split.
  EXPECT_GT(inBumpDeepest, 0.8 * inBumpLeaves);
  EXPECT_EQ(outsideDeepest, 0);
}


// Texels the encoding takes (grid of the coarse depth, then 1 per leaf and 2
// per internal node below it), counted from the tree.
std::uint64_t texelsOfTree(const Octree& octree, int completeDepth) {
  std::uint64_t texels = std::uint64_t{1} << (3 * completeDepth);
  for (const OctreeNode& node : octree.nodes)
    if (node.depth >= completeDepth) texels += node.isLeaf() ? 1 : 2;
  return texels;
}

// The total L2,1 of the leaves, each recomputed from all of M's triangles
// that overlap the leaf's cell (brute force, not the build's lists).
double totalLeafError(const SphereCase& c, const Octree& octree) {
  const std::vector<Cell> cells = cellsOf(octree);
  double total = 0.0;
  for (std::uint32_t n = 0; n < octree.nodes.size(); ++n) {
    if (!octree.nodes[n].isLeaf()) continue;
    std::vector<std::uint32_t> overlapping;
    for (std::uint32_t t = 0; t < c.detail.triangles.size(); ++t) {
      const auto& corners = c.detail.triangles[t].corners;
      if (triangleOverlapsBox(corners[0], corners[1], corners[2], cells[n])) overlapping.push_back(t);
    }
    total += normalVariation(c.detail, overlapping, cells[n]);
  }
  return total;
}

BuildSettings budgetSettings(std::uint64_t texels) {
  BuildSettings settings{3, 7, 0.0, texels, 3};
  return settings;
}

TEST(BuildOctreeWithABudget, NeverSpendsMoreTexelsThanTheBudgetAndMoreBuysLessError) {
  const SphereCase c = bumpySphereCase();
  double previous = std::numeric_limits<double>::infinity();
  for (const std::uint64_t budget : {2000u, 8000u, 32000u}) {
    const BuiltOctree built = buildOctree(c.coarse, c.detail, budgetSettings(budget));
    const std::uint64_t texels = texelsOfTree(built.octree, 3);
    EXPECT_EQ(built.refinement.texels, texels) << "budget " << budget;
    EXPECT_LE(texels, budget);
    EXPECT_GT(texels, budget - 9) << "stopped with room for another split";  // a split adds at most 9
    EXPECT_EQ(built.refinement.stoppedBy, "budget");
    const double error = totalLeafError(c, built.octree);
    EXPECT_NEAR(built.refinement.error, error, 1e-6 * error) << "the reported error is the leaves' L2,1";
    EXPECT_LT(error, previous) << "budget " << budget;
    previous = error;
  }
}

TEST(BuildOctreeWithABudget, StopsWhereNoSplitHelps) {
  // M = the coarse sphere's own triangles with their own flat normals: a
  // cell inside one face has no error and never splits; only cells across
  // edges do (down to the maximum depth), and the budget is not needed.
  SphereCase c = bumpySphereCase();
  std::vector<Vec3f> normals;
  std::vector<Triangle> flat;
  for (const Triangle& t : c.coarse.triangles) {
    const Vec3f& a = c.coarse.positions[t[0]];
    const Vec3f normal = (c.coarse.positions[t[1]] - a).cross(c.coarse.positions[t[2]] - a).normalized();
    const auto base = static_cast<std::uint32_t>(normals.size());
    for (int k = 0; k < 3; ++k) normals.push_back(normal);
    flat.push_back({base, base + 1, base + 2});
  }
  std::vector<Vec3f> positions;
  for (const Triangle& t : c.coarse.triangles)
    for (int k = 0; k < 3; ++k) positions.push_back(c.coarse.positions[t[k]]);
  c.detail = DetailPrimitives::ofMesh(positions, flat, normals, c.detail.areaScale);
  const BuiltOctree built = buildOctree(c.coarse, c.detail, budgetSettings(1u << 20));
  EXPECT_EQ(built.refinement.stoppedBy, "converged");
  EXPECT_LT(built.refinement.texels, 1u << 18);
  std::uint64_t leaves = 0, deepest = 0;
  for (const OctreeNode& node : built.octree.nodes) {
    leaves += node.isLeaf() ? 1 : 0;
    deepest += node.isLeaf() && node.depth == 7 ? 1 : 0;
  }
  EXPECT_EQ(built.refinement.leavesAtMaxDepth, deepest);
  EXPECT_GT(deepest, 0u);       // along the edges
  EXPECT_LT(deepest, leaves);   // inside the faces, cells stay larger
}

// M as points: random points on the sphere (one in 20 on a cell face) with the
// bumpy normals, unequal weights, and m's normal known at each. Checked
// against every point tested against every leaf's box (brute force, not
// the build's Morton runs): each point is in exactly one leaf, and the
// reported error is the leaves' L2,1.
TEST(BuildOctreeWithABudget, PointsReportTheLeavesErrorAndEachPointOnce) {
  SphereCase c = bumpySphereCase();
  DetailPrimitives points;
  std::mt19937 rng(11);
  std::normal_distribution<float> gaussian;
  std::uniform_real_distribution<float> weight(0.5f, 1.5f);
  for (int i = 0; i < 20000; ++i) {
    const Vec3f d = Vec3f(gaussian(rng), gaussian(rng), gaussian(rng)).normalized();
    Vec3f position = Vec3f::Constant(0.5f) + 0.4f * d;
    // One point in 20 exactly on a face between depth-6 cells.
    if (i % 20 == 0) position.x() = std::round(position.x() * 64.0f) / 64.0f;
    points.positions.push_back(position);
    Vec3f normal = d;
    if (inBump(d)) normal = (normal + 0.5f * Vec3f(std::sin(40.0f * d.x()), std::cos(40.0f * d.y()), 0.0f)).normalized();
    points.normals.push_back(normal);
    points.weights.push_back(weight(rng));
    points.coarseNormals.push_back(d);
  }
  points.coarseKnown = true;
  const BuiltOctree built = buildOctree(c.coarse, points, budgetSettings(8000));
  const Octree& octree = built.octree;
  const std::vector<Cell> cells = cellsOf(octree);
  std::vector<int> leavesHolding(points.positions.size(), 0);
  double error = 0.0, weights = 0.0;
  for (std::uint32_t n = 0; n < octree.nodes.size(); ++n) {
    if (!octree.nodes[n].isLeaf()) continue;
    std::vector<std::uint32_t> inside;
    for (std::uint32_t i = 0; i < points.positions.size(); ++i) {
      // A point on a face between two cells is the lower one's (as the
      // lookup's walk decides), the first cell of an axis takes its lower face.
      const Vec3f& p = points.positions[i];
      const Vec3f lower = cells[n].lower(), upper = cells[n].upper();
      bool in = true;
      for (int axis = 0; axis < 3; ++axis)
        in = in && ((lower[axis] < p[axis] && p[axis] <= upper[axis]) || (lower[axis] == 0.0f && p[axis] == 0.0f));
      if (in) {
        inside.push_back(i);
        ++leavesHolding[i];
        weights += points.weights[i];
      }
    }
    error += normalVariation(points, inside, cells[n]);
  }
  EXPECT_EQ(built.refinement.stoppedBy, "budget");
  EXPECT_NEAR(built.refinement.error, error, 1e-6 * error) << "the reported error is the leaves' L2,1";
  EXPECT_NEAR(built.refinement.area, weights, 1e-6 * weights) << "every point of the leaves counted once";
  // No point is in two leaves; a point is in none where its cell holds none
  // of m (the sphere bulges out of m's flat faces by up to 0.5% of the
  // radius; at the leaves' size a few points lie in such cells).
  EXPECT_EQ(*std::max_element(leavesHolding.begin(), leavesHolding.end()), 1);
  EXPECT_GT(std::count(leavesHolding.begin(), leavesHolding.end(), 1), 0.995 * static_cast<double>(leavesHolding.size()));
}

// M's triangles clipped once into the cells of a fine depth, whose sums the
// shallower cells add up (FineSums), against the same tree built clipping
// them level by level: the same tree, and the leaves' error the brute-force
// L2,1 of each leaf over all of M, above, at and below the sum depth.
TEST(BuildOctreeWithABudget, SumsAddedUpFromFineCellsGiveTheLevelByLevelTree) {
  const SphereCase c = bumpySphereCase();
  BuildSettings levelByLevel = budgetSettings(20000);
  levelByLevel.sumDepth = 0;
  const BuiltOctree reference = buildOctree(c.coarse, c.detail, levelByLevel);
  EXPECT_EQ(reference.refinement.sumDepth, 0);
  for (const int sumDepth : {4, 6, 7}) {
    BuildSettings settings = levelByLevel;
    settings.sumDepth = sumDepth;
    const BuiltOctree built = buildOctree(c.coarse, c.detail, settings);
    EXPECT_EQ(built.refinement.sumDepth, sumDepth);
    ASSERT_EQ(built.octree.nodes.size(), reference.octree.nodes.size()) << "sum depth " << sumDepth;
    for (std::size_t n = 0; n < built.octree.nodes.size(); ++n)
      ASSERT_EQ(built.octree.nodes[n].childMask, reference.octree.nodes[n].childMask) << "node " << n;
    const double error = totalLeafError(c, built.octree);
    EXPECT_NEAR(built.refinement.error, error, 1e-6 * error) << "sum depth " << sumDepth;
    EXPECT_NEAR(built.refinement.area, reference.refinement.area, 1e-9 * reference.refinement.area);
  }
}

// M flat in a plane between cells (z = 1/2: the root's midplane, and a face
// of cells at every depth), m over it: each piece of M lies on the faces of
// two cells, and is counted in one (the cell above), level by level and
// summed from fine cells alike; the leaves' area is M's, 1/16 (counted in
// both cells, it was twice that).
// M a flat grid over [1/4, 1/2]^2 at height z, m the square over it
// exactly: M's area is 1/16.
struct FlatSquare {
  DetailPrimitives detail;
  CoarseMesh coarse;
};

FlatSquare flatSquare(float z) {
  FlatSquare square{flatGrid(32, 1.0f / 128.0f, z), {}};
  square.coarse.positions = {Vec3f(0.25f, 0.25f, z), Vec3f(0.5f, 0.25f, z), Vec3f(0.5f, 0.5f, z), Vec3f(0.25f, 0.5f, z)};
  square.coarse.triangles = {{0, 1, 2}, {0, 2, 3}};
  return square;
}

TEST(BuildOctreeWithABudget, MInACellFaceIsCountedOnce) {
  const FlatSquare square = flatSquare(0.5f);
  for (const int sumDepth : {0, 6}) {
    BuildSettings settings = budgetSettings(4000);
    settings.sumDepth = sumDepth;
    const BuiltOctree built = buildOctree(square.coarse, square.detail, settings);
    EXPECT_EQ(built.refinement.sumDepth, sumDepth);
    EXPECT_NEAR(built.refinement.area, 1.0 / 16.0, 1e-6) << "sum depth " << sumDepth;
  }
}

// M's triangles are binned into the occupied coarse cells through a table
// of the grid up to coarse depth 7 and by a binary search deeper: either
// way every piece of M under m is counted, once (M and m at z = 0.3, in no
// cell's face).
TEST(BuildOctreeWithABudget, MIsBinnedWholeAtEveryCoarseDepth) {
  const FlatSquare square = flatSquare(0.3f);
  for (const int coarseDepth : {2, 7, 8}) {
    BuildSettings settings{coarseDepth, 9, 0.0, 1u << 20, 2};
    settings.sumDepth = 0;
    const BuiltOctree built = buildOctree(square.coarse, square.detail, settings);
    EXPECT_NEAR(built.refinement.area, 1.0 / 16.0, 1e-6) << "coarse depth " << coarseDepth;
  }
}

TEST(BuildOctree, SameTreeWithOneOrTwoThreads) {
  const SphereCase c = bumpySphereCase();
  const auto build = [&](int threads) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
    return buildOctree(c.coarse, c.detail, budgetSettings(20000));
  };
  const BuiltOctree one = build(1), two = build(2);
  ASSERT_EQ(one.octree.nodes.size(), two.octree.nodes.size());
  for (std::size_t n = 0; n < one.octree.nodes.size(); ++n) {
    EXPECT_EQ(one.octree.nodes[n].firstChild, two.octree.nodes[n].firstChild);
    EXPECT_EQ(one.octree.nodes[n].childMask, two.octree.nodes[n].childMask);
  }
  EXPECT_EQ(one.leafTriangles, two.leafTriangles);
  EXPECT_EQ(one.leafTriangleBegin, two.leafTriangleBegin);
}

}  // namespace
}  // namespace apo::octree
