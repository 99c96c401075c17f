// The bake in bricks against the bake in one piece, on the same points: the
// octree, its normals and the encoded texture must be the same.
#include "bake/bake.h"

#include "pipeline/bake_seams.h"
#include "tests/bake/bumpy_sphere.h"
#include "tests/test_support.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <random>

namespace apo {
namespace {
using ::testing::HasSubstr;

// The bumpy sphere as a scan: points on its dense mesh with their exact
// normals, shuffled (as a scanner's order follows no brick), and turned
// against m (an icosphere too): along m's axes of symmetry, a ray would
// meet two or three discs at exactly the same distance, and which one
// Embree reports depends on its BVH, so on the brick (docs/bake.md, "Bricks").
Scan bumpyPoints(const test::BumpySphere& shape, int subdivisions) {
  Scan mesh = shape.mesh(subdivisions);
  std::vector<std::size_t> order(mesh.points.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::shuffle(order.begin(), order.end(), std::mt19937(7));
  const Eigen::Matrix3f turn = Eigen::AngleAxisf(0.3f, Vec3f(1, 2, 3).normalized()).toRotationMatrix();
  Scan points;
  for (const std::size_t i : order) {
    points.points.positions.push_back(turn * mesh.points.positions[i]);
    points.points.normals.push_back(turn * mesh.points.normals[i]);
  }
  return points;
}

BakeOptions bakeOptions(std::uint64_t budget, int brickDepth) {
  BakeOptions options;
  options.coarseDepth = 4;
  options.maxDepth = 10;
  options.maxDistance = 0.03;
  options.budget = budget;
  options.brickDepth = brickDepth;
  return options;
}

void expectSameBake(const Bake& bricks, const Bake& whole) {
  ASSERT_EQ(bricks.octree.nodes.size(), whole.octree.nodes.size());
  std::size_t differentNodes = 0;
  for (std::size_t n = 0; n < whole.octree.nodes.size(); ++n) {
    const OctreeNode &a = bricks.octree.nodes[n], &b = whole.octree.nodes[n];
    differentNodes += a.childMask != b.childMask || a.firstChild != b.firstChild || a.normal != b.normal ||
                              a.weight != b.weight || a.coarseNormal != b.coarseNormal || a.twoSided != b.twoSided
                          ? 1
                          : 0;
  }
  EXPECT_EQ(differentNodes, 0u);
  EXPECT_EQ(bricks.texture.texels, whole.texture.texels);
  EXPECT_EQ(bricks.report.refinement.l21, whole.report.refinement.l21);
  EXPECT_EQ(bricks.report.rays, whole.report.rays);
  EXPECT_EQ(bricks.report.hits, whole.report.hits);
}

class BrickBake : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    points_ = new Scan(bumpyPoints(test::BumpySphere::allOver(), 6));
    coarse_ = new Scan(test::makeIcosphere(3));
  }
  static void TearDownTestSuite() {
    delete points_;
    delete coarse_;
  }
  static Result<Bake> bake(std::uint64_t budget, int brickDepth) {
    return bakeApo(*points_, *coarse_, test::checked(bakeOptions(budget, brickDepth)));
  }
  static Scan* points_;
  static Scan* coarse_;
};
Scan* BrickBake::points_ = nullptr;
Scan* BrickBake::coarse_ = nullptr;

TEST_F(BrickBake, BricksGiveTheOnePieceBakeUnderABudget) {
  // A budget the bricks' first caps do not reach everywhere: some are built again.
  const std::uint64_t budget = 96 << 10;
  auto whole = bake(budget, 0);
  ASSERT_TRUE(whole.ok()) << whole.error().message;
  ASSERT_EQ(whole->report.refinement.stoppedBy, "budget");
  for (const int depth : {1, 2}) {
    auto bricks = bake(budget, depth);
    ASSERT_TRUE(bricks.ok()) << bricks.error().message;
    ASSERT_TRUE(bricks->report.bricks.has_value());
    EXPECT_EQ(bricks->report.bricks->depth, depth);
    EXPECT_GT(bricks->report.bricks->bricks, depth == 1 ? 4u : 20u);
    EXPECT_EQ(bricks->report.bricks->discsWiderThanReach, 0u);
    // Each brick held far fewer points than the scan.
    EXPECT_LT(bricks->report.bricks->largestBrickPoints, points_->points.size() * (depth == 1 ? 2 : 1) / 3);
    expectSameBake(*bricks, *whole);
  }
}

TEST(BrickBakeOfAPlane, BricksWhoseFirstShareFallsShortAreBuiltAgain) {
  // A flat square with one bump: the flat parts never split (their normals
  // agree), so the budget goes to the bricks holding the bump, far beyond
  // their share by m's cells. The points sit a hair off the plane, each at
  // its own height: discs all in one plane would meet a ray at exactly the
  // same distance, and Embree reports one of them by its BVH's order.
  std::mt19937 random(11);
  std::uniform_real_distribution<float> along(-1.0f, 1.0f), hair(-1e-4f, 1e-4f);
  const auto height = [](float x, float y) {
    return 0.08f * std::exp(-((x - 0.5f) * (x - 0.5f) + (y - 0.45f) * (y - 0.45f)) / 0.04f);
  };
  Scan points;
  for (int i = 0; i < 120000; ++i) {
    const float x = along(random), y = along(random), h = height(x, y);
    const float hx = h * -2.0f * (x - 0.5f) / 0.04f, hy = h * -2.0f * (y - 0.45f) / 0.04f;
    points.points.positions.emplace_back(x, y, h + hair(random));
    points.points.normals.push_back(Vec3f(-hx, -hy, 1.0f).normalized());
  }
  Scan plane;
  plane.points.positions = {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0}};
  plane.triangles = {{0, 1, 2}, {0, 2, 3}};
  BakeOptions options = bakeOptions(48 << 10, 0);
  auto whole = bakeApo(points, plane, test::checked(options));
  ASSERT_TRUE(whole.ok()) << whole.error().message;
  EXPECT_EQ(whole->report.refinement.stoppedBy, "budget");
  options.brickDepth = 1;
  auto bricks = bakeApo(points, plane, test::checked(options));
  ASSERT_TRUE(bricks.ok()) << bricks.error().message;
  EXPECT_GT(bricks->report.bricks->refinementRuns, bricks->report.bricks->bricks);
  expectSameBake(*bricks, *whole);
}

TEST_F(BrickBake, BricksGiveTheOnePieceBakeWithTheErrorThresholdAlone) {
  // No budget: the paper's threshold alone stops the refinement.
  BakeOptions options = bakeOptions(0, 0);
  options.error = 0.5;
  auto whole = bakeApo(*points_, *coarse_, test::checked(options));
  ASSERT_TRUE(whole.ok()) << whole.error().message;
  options.brickDepth = 2;
  auto bricks = bakeApo(*points_, *coarse_, test::checked(options));
  ASSERT_TRUE(bricks.ok()) << bricks.error().message;
  EXPECT_EQ(bricks->report.bricks->refinementRuns, bricks->report.bricks->bricks);  // none built again
  expectSameBake(*bricks, *whole);
}

TEST(BrickOptions, BrickDepthIsCheckedAgainstTheCoarseDepth) {
  BakeOptions options;
  options.coarseDepth = 3;
  options.brickDepth = 4;
  auto checked = check(options);
  ASSERT_FALSE(checked.ok());
  EXPECT_THAT(checked.error().message, HasSubstr("--brick-depth"));
  options.brickDepth = -1;
  EXPECT_FALSE(check(options).ok());
  options.brickDepth = 3;
  EXPECT_TRUE(check(options).ok());
}

}  // namespace
}  // namespace apo
