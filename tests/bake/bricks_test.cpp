// The bake in bricks against the bake in one piece, on the same points: the
// octree, its normals and the encoded texture must be the same.
#include "bake/bake.h"

#include "bake/brick_journal.h"

#include "adapters/embree/embree_ray_caster.h"
#include "pipeline/bake_seams.h"
#include "tests/bake/bumpy_sphere.h"
#include "tests/test_support.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstring>
#include <limits>
#include <map>
#include <random>
#include <string>

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

// M's points held in memory, served a box at a time, with a journal kept
// in `entries` that refuses every write after `writesLeft` of them (as a
// killed bake stops writing).
struct JournalInMemory {
  std::map<std::string, std::string> entries;
  std::uint64_t writesLeft = std::numeric_limits<std::uint64_t>::max();

  BrickJournal journal() {
    BrickJournal journal;
    journal.read = [this](const std::string& name) -> Result<std::optional<std::string>> {
      const auto found = entries.find(name);
      if (found == entries.end()) return std::optional<std::string>{};
      return std::optional<std::string>{found->second};
    };
    journal.write = [this](const std::string& name, const std::string& bytes) -> Status {
      if (writesLeft == 0) return internalError("killed");
      --writesLeft;
      entries[name] = bytes;
      return okStatus();
    };
    return journal;
  }
};

BrickedPoints bricked(const Scan& scan, const BrickJournal& journal) {
  BrickedPoints source = pointsInMemory(scan);
  source.journal = journal;
  return source;
}

TEST_F(BrickBake, AKilledBakeResumesFromItsFinishedBricks) {
  const std::uint64_t budget = 96 << 10;
  const Checked<BakeOptions> options = test::checked(bakeOptions(budget, 2));
  auto whole = bake(budget, 0);
  ASSERT_TRUE(whole.ok()) << whole.error().message;

  JournalInMemory all;
  auto fresh = bakeApoInBricks(bricked(*points_, all.journal()), *coarse_, options);
  ASSERT_TRUE(fresh.ok()) << fresh.error().message;
  const BrickReport& freshReport = *fresh->report.bricks;
  const std::uint64_t entries = all.entries.size();
  EXPECT_EQ(freshReport.journalEntriesWritten, entries);
  EXPECT_EQ(freshReport.journalEntriesReused, 0u);
  // Every cell of pass 1, every brick build of pass 2, every brick of pass 3.
  EXPECT_EQ(entries, 64u + freshReport.refinementRuns + freshReport.bricks);

  // Killed after half its entries were written: run again, it does only the rest.
  JournalInMemory half;
  half.writesLeft = entries / 2;
  auto killed = bakeApoInBricks(bricked(*points_, half.journal()), *coarse_, options);
  ASSERT_FALSE(killed.ok());
  EXPECT_EQ(half.entries.size(), entries / 2);
  half.writesLeft = std::numeric_limits<std::uint64_t>::max();
  auto resumed = bakeApoInBricks(bricked(*points_, half.journal()), *coarse_, options);
  ASSERT_TRUE(resumed.ok()) << resumed.error().message;
  EXPECT_EQ(resumed->report.bricks->journalEntriesReused, entries / 2);
  EXPECT_EQ(resumed->report.bricks->journalEntriesWritten, entries - entries / 2);
  EXPECT_LT(resumed->report.bricks->pointsLoaded, freshReport.pointsLoaded);
  expectSameBake(*resumed, *whole);

  // Everything in the journal: no point is loaded again. One entry damaged
  // (cut short) is done again.
  all.entries.begin()->second.resize(all.entries.begin()->second.size() / 2);
  auto again = bakeApoInBricks(bricked(*points_, all.journal()), *coarse_, options);
  ASSERT_TRUE(again.ok()) << again.error().message;
  EXPECT_EQ(again->report.bricks->journalEntriesReused, entries - 1);
  EXPECT_EQ(again->report.bricks->journalEntriesWritten, 1u);
  EXPECT_LT(again->report.bricks->pointsLoaded, freshReport.pointsLoaded / 10);
  expectSameBake(*again, *whole);
}

TEST_F(BrickBake, ThreeTasksSharingTheBricksGiveTheBakeInOnePiece) {
  const std::uint64_t budget = 96 << 10;
  const Checked<BakeOptions> options = test::checked(bakeOptions(budget, 2));
  auto whole = bake(budget, 0);
  ASSERT_TRUE(whole.ok()) << whole.error().message;
  JournalInMemory shared;
  const BrickedPoints source = bricked(*points_, shared.journal());

  auto coarseCaster = makeEmbreeMeshCaster(*coarse_);
  ASSERT_TRUE(coarseCaster.ok());
  const CoarseSurface coarse{coarse_, coarseCaster->get()};

  // A pass before the one it needs is refused, naming what is missing.
  auto early = bakeShareOfBricks(source, coarse, options, {BrickShare::Pass::Records, 0, 3});
  ASSERT_FALSE(early.ok());
  EXPECT_THAT(early.error().message, HasSubstr("the areas pass must be done by every task"));

  std::uint64_t samplesWritten = 0;
  for (const auto pass : {BrickShare::Pass::Areas, BrickShare::Pass::Records, BrickShare::Pass::Samples})
    for (std::uint32_t task = 0; task < 3; ++task) {
      const std::size_t before = shared.entries.size();
      auto share = bakeShareOfBricks(source, coarse, options, {pass, task, 3});
      ASSERT_TRUE(share.ok()) << passName(pass) << " " << task << ": " << share.error().message;
      EXPECT_GT(shared.entries.size(), before) << passName(pass) << " " << task << " wrote nothing";
      if (pass == BrickShare::Pass::Samples) samplesWritten += share->journalEntriesWritten;
    }
  EXPECT_GE(samplesWritten, 3u);
  // The merge: every entry read back, no point loaded, the same bake.
  auto merged = bakeInBricks(source, coarse, options);
  ASSERT_TRUE(merged.ok()) << merged.error().message;
  EXPECT_EQ(merged->report.bricks->journalEntriesWritten, 0u);
  EXPECT_EQ(merged->report.bricks->journalEntriesReused, shared.entries.size());
  EXPECT_EQ(merged->report.bricks->pointsLoaded, 0u);
  expectSameBake(*merged, *whole);
  EXPECT_FALSE(bakeShareOfBricks(source, coarse, options, {BrickShare::Pass::Areas, 3, 3}).ok());
}

TEST(BrickJournal, EntriesReadBackAsWrittenAndDamagedOnesAreRefused) {
  brick_journal::RecordEntry records;
  records.complete = true;
  octree::LeafError error;
  error.variation = 0.25;
  error.twoSided = 0.125;
  error.sideAxis = 2;
  error.deferToCoarse = true;
  records.found = {{7, error}, {(octree::CellId{3} << octree::kCellIdDepthShift) | 5, octree::LeafError{}}};
  const std::string bytes = brick_journal::encode(records);
  const auto back = brick_journal::decodeRecords(bytes);
  ASSERT_TRUE(back.has_value());
  EXPECT_TRUE(back->complete);
  ASSERT_EQ(back->found.size(), 2u);
  EXPECT_EQ(back->found[0].first, 7u);
  EXPECT_EQ(back->found[0].second.variation, 0.25);
  EXPECT_EQ(back->found[0].second.twoSided, 0.125);
  EXPECT_EQ(back->found[0].second.sideAxis, 2);
  EXPECT_TRUE(back->found[0].second.deferToCoarse);
  EXPECT_EQ(back->found[1].first, records.found[1].first);

  brick_journal::SampleEntry samples;
  samples.leaves = {4, 9};
  samples.values.resize(2);
  samples.values[0].normal = Vec3f(0, 0.6f, 0.8f);
  samples.values[0].weight = 0.03;
  samples.values[1].sides[1] = Vec3f(1, 0, 0);
  samples.moments.resize(2);
  samples.moments[1].weight = 2.5;
  samples.moments[1].sum = Eigen::Vector3d(1, -2, 3);
  samples.counts.rays = 11;
  samples.discsWiderThanReach = 1;
  const auto sampled = brick_journal::decodeSamples(brick_journal::encode(samples));
  ASSERT_TRUE(sampled.has_value());
  EXPECT_EQ(sampled->leaves, samples.leaves);
  EXPECT_EQ(sampled->values[0].normal, samples.values[0].normal);
  EXPECT_EQ(sampled->values[0].weight, 0.03);
  EXPECT_EQ(sampled->values[1].sides[1], samples.values[1].sides[1]);
  EXPECT_EQ(sampled->moments[1].weight, 2.5);
  EXPECT_EQ(sampled->moments[1].sum, samples.moments[1].sum);
  EXPECT_EQ(sampled->counts.rays, 11u);
  EXPECT_EQ(sampled->discsWiderThanReach, 1u);

  brick_journal::AreaEntry area;
  area.sum.add(0.5f);
  area.sum.add(0.25f);
  area.count = 2;
  const auto areaBack = brick_journal::decodeArea(brick_journal::encode(area));
  ASSERT_TRUE(areaBack.has_value());
  EXPECT_EQ(areaBack->sum.value(), 0.75);
  EXPECT_EQ(areaBack->count, 2u);

  // Cut short, one byte too many, another kind, a count beyond the bytes.
  EXPECT_FALSE(brick_journal::decodeRecords(bytes.substr(0, bytes.size() - 1)));
  EXPECT_FALSE(brick_journal::decodeRecords(bytes + "x"));
  EXPECT_FALSE(brick_journal::decodeSamples(bytes));
  std::string huge = bytes;
  const std::uint64_t claimed = std::uint64_t{1} << 60;
  std::memcpy(huge.data() + 7, &claimed, sizeof claimed);  // after magic, kind, version and the flag
  EXPECT_FALSE(brick_journal::decodeRecords(huge));
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
