// The N^3-tree against the octree it is built from (its ground truth: the
// octree's own walk), a tiny tree laid out by hand, the filtered lookup
// against the APO's, and the .n3t file's round trip and refusals.
#include "format/format.h"
#include "tests/format/apo_test_trees.h"
#include "tests/test_support.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <random>

namespace apo {
namespace {

using ::testing::HasSubstr;
using test::ChildPath;
using test::lookupPoints;

N3Tree buildOrDie(const Octree& octree, int n, NormalEncoding encoding = NormalEncoding::Oct24) {
  Result<N3Tree> tree = buildN3Tree(octree, n, encoding);
  EXPECT_TRUE(tree.ok()) << tree.error().message;
  return tree.ok() ? *tree : N3Tree{};
}

Vec3f quantised(const Vec3f& normal, NormalEncoding encoding) { return decodeNormal(encodeNormal(normal, encoding), encoding); }

std::array<std::uint8_t, 4> poolCell(const N3Tree& tree, std::uint32_t x, std::uint32_t y, std::uint32_t z) {
  const std::array<std::uint32_t, 3> size = tree.poolSize();
  const std::size_t at = 4 * (x + std::size_t{size[0]} * (y + std::size_t{size[1]} * z));
  return {tree.pool[at], tree.pool[at + 1], tree.pool[at + 2], tree.pool[at + 3]};
}

// The root has children 0, 3 and 7; child 3 has children 1 and 6; axis
// normals, so xyz8 bytes are literal (+x = FF 80 80, -y = 80 00 80, ...).
// Child c's bit is 1 on the lower side: child 0 is the upper cell (1, 1, 1)
// of the root's grid, child 3 = 011 is (1, 0, 0), child 7 is (0, 0, 0).
TEST(N3Tree, TinyTreeLaidOutByHand) {
  const Octree octree = test::octreeFromPaths({{0}, {3, 1}, {3, 6}, {7}}, [](const ChildPath& path) -> Vec3f {
    if (path.empty()) return Vec3f::UnitZ();
    if (path == ChildPath{0}) return Vec3f::UnitX();
    if (path == ChildPath{3}) return -Vec3f::UnitX();
    if (path == ChildPath{7}) return Vec3f::UnitY();
    if (path == ChildPath{3, 1}) return -Vec3f::UnitY();
    return -Vec3f::UnitZ();
  });
  const N3Tree tree = buildOrDie(octree, 2, NormalEncoding::Xyz8);
  EXPECT_EQ(tree.usedGrids, 2u);
  EXPECT_EQ(tree.levels, 2);
  EXPECT_EQ(tree.grids, (std::array<std::uint32_t, 3>{2, 1, 1}));
  EXPECT_EQ(tree.poolSize(), (std::array<std::uint32_t, 3>{4, 2, 2}));
  using Cell = std::array<std::uint8_t, 4>;
  EXPECT_EQ(poolCell(tree, 1, 1, 1), (Cell{0xFF, 0x80, 0x80, N3Tree::kData}));
  EXPECT_EQ(poolCell(tree, 0, 0, 0), (Cell{0x80, 0xFF, 0x80, N3Tree::kData}));
  EXPECT_EQ(poolCell(tree, 1, 0, 0), (Cell{1, 0, 0, N3Tree::kPointer}));  // grid 1 at (u, v, w) = (1, 0, 0)
  EXPECT_EQ(poolCell(tree, 0, 1, 0), (Cell{0, 0, 0, N3Tree::kEmpty}));
  // Grid 1 (node 3) in cells x 2..3: child 1 = 001 is (1, 1, 0), child 6 = 110 is (0, 0, 1).
  EXPECT_EQ(poolCell(tree, 2 + 1, 1, 0), (Cell{0x80, 0x00, 0x80, N3Tree::kData}));
  EXPECT_EQ(poolCell(tree, 2 + 0, 0, 1), (Cell{0x80, 0x80, 0x00, N3Tree::kData}));
  EXPECT_EQ(poolCell(tree, 2 + 1, 1, 1), (Cell{0, 0, 0, N3Tree::kEmpty}));
  // The LOD pool: each grid's node.
  EXPECT_EQ(std::vector<std::uint8_t>(tree.lod.begin(), tree.lod.begin() + 8),
            (std::vector<std::uint8_t>{0x80, 0x80, 0xFF, 0xFF, 0x00, 0x80, 0x80, 0xFF}));
  EXPECT_EQ(tree.textureBytes(), 4u * 16 + 4 * 2);
  EXPECT_TRUE(validateN3Tree(tree).ok());

  // Walks: into child 3's child 1 (reads 2 cells), into child 3's empty part (its average), the root's empty part.
  const N3Lookup deep = lookupN3Tree(tree, Vec3f(0.875f, 0.375f, 0.125f));
  EXPECT_TRUE(deep.found && !deep.average);
  const auto xyz = [](const Vec3f& v) { return quantised(v, NormalEncoding::Xyz8); };
  EXPECT_EQ(deep.normal, xyz(-Vec3f::UnitY()));
  EXPECT_EQ(deep.depth, 2);
  EXPECT_EQ(deep.reads, 2u);
  EXPECT_EQ(deep.place, 3u + 4 * (1 + 2 * 0));
  const N3Lookup missing = lookupN3Tree(tree, Vec3f(0.875f, 0.375f, 0.375f));
  EXPECT_TRUE(missing.found && missing.average);
  EXPECT_EQ(missing.normal, xyz(-Vec3f::UnitX()));
  EXPECT_EQ(missing.place, tree.poolCells() + 1);
  EXPECT_EQ(missing.reads, 3u);
  EXPECT_EQ(lookupN3Tree(tree, Vec3f(0.25f, 0.75f, 0.25f)).normal, xyz(Vec3f::UnitZ()));
  // A point on the centre plane goes to the lower side: (0.5, 0.5, 0.5) is in child 7.
  EXPECT_EQ(lookupN3Tree(tree, Vec3f(0.5f, 0.5f, 0.5f)).normal, xyz(Vec3f::UnitY()));
  EXPECT_FALSE(lookupN3Tree(tree, Vec3f(1.01f, 0.5f, 0.5f)).found);
  // maxDepth 0: the root's average, one read.
  const N3Lookup root = lookupN3Tree(tree, Vec3f(0.875f, 0.375f, 0.125f), 0);
  EXPECT_TRUE(root.average);
  EXPECT_EQ(root.normal, xyz(Vec3f::UnitZ()));
  EXPECT_EQ(root.reads, 1u);
}

// The ground truth is the octree's own walk: an N^3-tree of N = 2 is the
// same walk (same node, same depth, same normal) everywhere; of N = 4, the
// same normal wherever the octree's walk ends at a leaf.
TEST(N3Tree, WalksAgreeWithTheOctreeOnRandomTrees) {
  const Octree octree = test::randomOctree(42, 3, 9, 0.45);
  for (const int n : {2, 4}) {
    for (const NormalEncoding encoding : {NormalEncoding::Oct24, NormalEncoding::Xyz8}) {
      const N3Tree tree = buildOrDie(octree, n, encoding);
      ASSERT_TRUE(validateN3Tree(tree).ok());
      std::size_t leaves = 0;
      for (const Vec3f& p : lookupPoints(60000, 9)) {
        const Lookup expected = lookupOctree(octree, p);
        const N3Lookup actual = lookupN3Tree(tree, p);
        ASSERT_EQ(actual.found, expected.found) << p.transpose();
        if (!actual.found) continue;
        const bool atLeaf = octree.nodes[expected.texel].isLeaf();
        // A missing child below a grid's node: that node's average, as the
        // octree's walk stops there; below a node inside a grid of N = 4,
        // the grid's (space m does not reach: docs/n3tree-format.md).
        if (n == 2 || atLeaf || expected.depth % tree.log2n() == 0) {
          ASSERT_EQ(actual.normal, quantised(expected.normal, encoding)) << "N " << n << " at " << p.transpose();
          ASSERT_EQ(actual.average, !atLeaf);
        }
        if (n == 2) {
          ASSERT_EQ(actual.depth, expected.depth);
        }
        if (atLeaf) {
          // A leaf between two levels of N = 4 fills the cells below it.
          ASSERT_GE(actual.depth, expected.depth);
          ASSERT_LT(actual.depth, expected.depth + tree.log2n());
          ++leaves;
        }
        // One cell per level; stopped at an empty cell, that cell and the LOD pool's.
        ASSERT_EQ(actual.reads, static_cast<std::uint32_t>(actual.depth / tree.log2n()) + (actual.average ? 2u : 0u));
      }
      EXPECT_GT(leaves, 1500u);
    }
  }
}

TEST(N3Tree, MaxDepthStopsAtTheNodesAverage) {
  const Octree octree = test::randomOctree(43, 2, 8, 0.5);
  const N3Tree two = buildOrDie(octree, 2);
  const N3Tree four = buildOrDie(octree, 4);
  for (const Vec3f& p : lookupPoints(10000, 10)) {
    for (int maxDepth = 0; maxDepth <= 8; ++maxDepth) {
      const Lookup expected = lookupOctree(octree, p, maxDepth);
      const N3Lookup actual = lookupN3Tree(two, p, maxDepth);
      ASSERT_EQ(actual.found, expected.found);
      if (!actual.found) continue;
      ASSERT_EQ(actual.depth, expected.depth);
      ASSERT_EQ(actual.normal, quantised(expected.normal, NormalEncoding::Oct24));
      // N = 4 walks two octree levels per grid: it stops at the even depth at or above.
      const N3Lookup coarser = lookupN3Tree(four, p, maxDepth);
      ASSERT_LE(coarser.depth, maxDepth);
      if (coarser.average) {
        ASSERT_EQ(coarser.depth % 2, 0);
      }
      const Lookup there = lookupOctree(octree, p, coarser.depth);
      if (coarser.average && there.depth == coarser.depth) {
        ASSERT_EQ(coarser.normal, quantised(there.normal, NormalEncoding::Oct24));
      }
    }
  }
}

// Of N = 2, the filter blends what the APO's filter blends, operation for operation.
TEST(N3Tree, FilteredLookupOfNTwoIsTheAposFilteredLookup) {
  const Octree octree = test::randomOctree(44, 3, 8, 0.5);
  Result<ApoTexture> apo = encodeApo(octree, 0, NormalEncoding::Oct24, 3, 12);
  ASSERT_TRUE(apo.ok()) << apo.error().message;
  const N3Tree tree = buildOrDie(octree, 2);
  std::mt19937_64 random(5);
  std::size_t compared = 0;
  for (const Vec3f& p : lookupPoints(20000, 11)) {
    const Vec3f m = test::randomUnitVector(random);
    const Lookup expected = lookupTextureFiltered(*apo, p, m);
    const N3Lookup actual = lookupN3TreeFiltered(tree, p, m);
    ASSERT_EQ(actual.found, expected.found);
    if (!actual.found) continue;
    ASSERT_EQ(actual.normal, expected.normal) << p.transpose();
    ++compared;
  }
  EXPECT_GT(compared, 10000u);
}

// Leaves showing m and two-sided leaves answer as the octree does, for both N.
TEST(N3Tree, LeavesShowingMAndTwoSidedLeavesAgreeWithTheOctree) {
  Octree octree = test::randomOctree(45, 2, 7, 0.6);
  std::mt19937_64 random(46);
  std::uniform_int_distribution<int> kind(0, 3), axis(0, 2);
  for (OctreeNode& node : octree.nodes) {
    const int k = kind(random);
    if (node.isLeaf() && node.depth > 0 && k == 0) {
      node.twoSided = true;
      node.sideAxis = static_cast<std::uint8_t>(axis(random));
      node.sides = {test::randomUnitVector(random), test::randomUnitVector(random)};
    } else if (k == 1) {
      node.coarseNormal = true;
    }
  }
  for (const int n : {2, 4}) {
    const N3Tree tree = buildOrDie(octree, n);
    EXPECT_TRUE(tree.defersToCoarse && tree.coarseAtInternalNodes);
    EXPECT_GT(tree.twoSidedLeaves, 100u);
    std::size_t twoSided = 0, coarse = 0;
    for (const Vec3f& p : lookupPoints(40000, 12)) {
      const Vec3f m = test::randomUnitVector(random);
      const Lookup expected = lookupOctree(octree, p, 255, m);
      const N3Lookup actual = lookupN3Tree(tree, p, 255, m);
      if (!actual.found || !octree.nodes[expected.texel].isLeaf()) continue;
      ASSERT_EQ(actual.twoSided, expected.twoSided);
      ASSERT_EQ(actual.coarse, expected.coarse);
      ASSERT_EQ(actual.normal, expected.coarse ? m : quantised(expected.normal, NormalEncoding::Oct24));
      twoSided += actual.twoSided;
      coarse += actual.coarse;
    }
    EXPECT_GT(twoSided, 300u);
    EXPECT_GT(coarse, 100u);
  }
}

TEST(N3Tree, RefusesAnotherNAndAPoolTooLarge) {
  const Octree octree = test::randomOctree(47, 3, 6, 0.5);
  EXPECT_EQ(buildN3Tree(octree, 3, NormalEncoding::Oct24).error().kind, ErrorKind::Usage);
  EXPECT_EQ(buildN3Tree(octree, 8, NormalEncoding::Oct24).error().kind, ErrorKind::Usage);
  const Result<N3Tree> cramped = buildN3Tree(octree, 2, NormalEncoding::Oct24, 4);
  ASSERT_FALSE(cramped.ok());
  EXPECT_THAT(cramped.error().message, HasSubstr("at most 4 per side"));
}

// ---- Validation and the file ------------------------------------------------------

void expectInvalid(const N3Tree& tree, const std::string& what) {
  const Status valid = validateN3Tree(tree);
  ASSERT_FALSE(valid.ok()) << "accepted; expected: " << what;
  EXPECT_THAT(valid.error().message, HasSubstr(what));
}

TEST(N3Tree, ValidationRefusesWhatTheBuilderNeverWrites) {
  const N3Tree good = buildOrDie(test::randomOctree(48, 2, 5, 0.5), 2);
  ASSERT_GT(good.usedGrids, 10u);
  // Find the root grid's first pointer cell.
  std::size_t pointer = 0;
  while (good.pool[4 * pointer + 3] != N3Tree::kPointer) ++pointer;
  N3Tree backwards = good;
  backwards.pool[4 * pointer] = 0;  // to grid 0, the root itself: a cycle
  backwards.pool[4 * pointer + 1] = 0;
  backwards.pool[4 * pointer + 2] = 0;
  expectInvalid(backwards, "expected a later grid");
  N3Tree outside = good;
  outside.pool[4 * pointer + 2] = 9;
  expectInvalid(outside, "outside the pool");
  N3Tree oddKind = good;
  oddKind.pool[4 * pointer + 3] = 100;
  expectInvalid(oddKind, "kind 100");
  N3Tree shallow = good;
  shallow.levels = 1;
  expectInvalid(shallow, "the header says 1 levels");
  N3Tree badSide = good;
  badSide.pool[4 * pointer + 3] = N3Tree::kTwoSided;
  expectInvalid(badSide, "two-sided leaf");
}

TEST(N3TreeFile, RoundTripsAndRefusesCorruptBytes) {
  const std::filesystem::path dir = test::freshTempDir();
  Octree octree = test::randomOctree(49, 2, 6, 0.5);
  octree.transform.scale = 0.25;
  octree.transform.offset = {0.1, 0.2, 0.3};
  octree.nodes.back().twoSided = true;
  octree.nodes.back().sides = {Vec3f::UnitX(), -Vec3f::UnitX()};
  N3Tree tree = buildOrDie(octree, 4);
  tree.origin = {637301.5, 851218.25, 496.0};
  const auto path = dir / "t.n3t";
  ASSERT_TRUE(writeN3TreeFile(path, tree).ok());
  const Result<N3Tree> read = readN3TreeFile(path);
  ASSERT_TRUE(read.ok()) << read.error().message;
  EXPECT_EQ(read->pool, tree.pool);
  EXPECT_EQ(read->lod, tree.lod);
  EXPECT_EQ(read->sides, tree.sides);
  EXPECT_EQ(read->origin, tree.origin);
  EXPECT_EQ(read->transform.offset, tree.transform.offset);
  EXPECT_EQ(read->n, 4);
  EXPECT_EQ(read->levels, tree.levels);
  EXPECT_EQ(read->twoSidedLeaves, 1u);

  std::ifstream in(path, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(bytes.size(), 136 + tree.textureBytes());
  const auto refused = [&](std::string changed, const std::string& what) {
    const Result<N3Tree> parsed = parseN3TreeFile(changed);
    ASSERT_FALSE(parsed.ok()) << "accepted; expected: " << what;
    EXPECT_EQ(parsed.error().kind, ErrorKind::BadInput);
    EXPECT_THAT(parsed.error().message, HasSubstr(what));
  };
  refused(bytes.substr(0, 56), "byte 52 (origin x): the file ends");
  refused(bytes.substr(0, bytes.size() - 1), "truncated or padded");
  std::string magic = bytes;
  magic[1] = 'X';
  refused(magic, "not an .n3t file");
  std::string n = bytes;
  n[76] = 3;
  refused(n, "byte 76 (N): expected 2 or 4, found 3");
  std::string grids = bytes;
  grids[80] = 0;
  grids[81] = 2;  // 512 grids along u
  refused(grids, "grids along u");
  std::string payload = bytes;
  payload[200] = static_cast<char>(payload[200] ^ 1);
  refused(payload, "corrupt payload");
  // Every single-byte change of the header is refused or harmless, never a crash.
  for (std::size_t at = 0; at < 136; ++at) {
    std::string changed = bytes;
    changed[at] = static_cast<char>(changed[at] ^ 0x5A);
    (void)parseN3TreeFile(changed);
  }
}

}  // namespace
}  // namespace apo
