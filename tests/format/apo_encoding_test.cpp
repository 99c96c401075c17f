#include "format/format.h"
#include "format/texel_layout.h"
#include "tests/format/apo_test_trees.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
#include <random>
#include <thread>

namespace apo {
namespace {

using ::testing::HasSubstr;
using test::ChildPath;

// ---- A tiny tree, encoded by hand ---------------------------------------------
//
// The root has children 0, 3 and 7; child 3 is internal with children 1 and
// 6. Each node has an axis normal, so its xyz8 bytes are literal:
// +x = FF 80 80, -x = 00 80 80, +y = 80 FF 80, -y = 80 00 80, +z = 80 80 FF,
// -z = 80 80 00.
Octree tinyTree() {
  return test::octreeFromPaths({{0}, {3, 1}, {3, 6}, {7}}, [](const ChildPath& path) -> Vec3f {
    if (path.empty()) return Vec3f::UnitZ();
    if (path == ChildPath{0}) return Vec3f::UnitX();
    if (path == ChildPath{3}) return -Vec3f::UnitX();
    if (path == ChildPath{7}) return Vec3f::UnitY();
    if (path == ChildPath{3, 1}) return -Vec3f::UnitY();
    return -Vec3f::UnitZ();  // {3, 6}
  });
}

using Texels = std::vector<std::array<std::uint8_t, 4>>;

Texels texelsOf(const ApoTexture& texture) {
  Texels texels(texture.texels.size() / 4);
  for (std::size_t i = 0; i < texels.size(); ++i)
    for (int channel = 0; channel < 4; ++channel) texels[i][channel] = texture.texels[4 * i + channel];
  return texels;
}

ApoTexture encodeOrDie(const Octree& octree, int completeDepth, NormalEncoding encoding, int coarseDepth = 3,
                       int maxDepth = 12) {
  Result<ApoTexture> texture = encodeApo(octree, completeDepth, encoding, static_cast<std::uint8_t>(coarseDepth),
                                         static_cast<std::uint8_t>(maxDepth));
  EXPECT_TRUE(texture.ok()) << texture.error().message;
  return texture.ok() ? *texture : ApoTexture{};
}

TEST(EncodeApo, TinyTreeWithoutCompletionByHand) {
  const ApoTexture texture = encodeOrDie(tinyTree(), 0, NormalEncoding::Xyz8);
  // 1 grid texel, 4 leaves, 2 internal nodes: 9 texels; width 4 (4^2 >= 9),
  // 3 rows.
  EXPECT_EQ(texture.width, 4u);
  EXPECT_EQ(texture.height, 3u);
  EXPECT_EQ(texture.leafNodes, 4u);
  EXPECT_EQ(texture.internalNodes, 2u);
  EXPECT_EQ(texture.usedTexels(), 9u);
  const Texels expected = {
      {0x01, 0x00, 0x00, 0x00},  // 0: grid entry -> the root at texel 1
      {0x02, 0x00, 0x00, 0x89},  // 1: root: brood at 1 + 2 = 3; children 0, 3, 7
      {0x80, 0x80, 0xFF, 0x08},  // 2: root normal +z; kind: child 3 internal
      {0xFF, 0x80, 0x80, 0x00},  // 3: child 0, leaf +x
      {0x03, 0x00, 0x00, 0x42},  // 4: child 3: brood at 4 + 3 = 7; children 1, 6
      {0x00, 0x80, 0x80, 0x00},  // 5: child 3 normal -x; kind: both leaves
      {0x80, 0xFF, 0x80, 0x00},  // 6: child 7, leaf +y
      {0x80, 0x00, 0x80, 0x00},  // 7: child 3.1, leaf -y
      {0x80, 0x80, 0x00, 0x00},  // 8: child 3.6, leaf -z
      {0, 0, 0, 0},              // 9-11: the rest of the last row
      {0, 0, 0, 0},
      {0, 0, 0, 0},
  };
  EXPECT_EQ(texelsOf(texture), expected);
}

TEST(EncodeApo, TinyTreeWithCompletionByHand) {
  const ApoTexture texture = encodeOrDie(tinyTree(), 1, NormalEncoding::Xyz8);
  // Grid cell (ix, iy, iz) of child c: a bit set means the lower half (0).
  // Child 7 = (0, 0, 0) -> cell 0; child 3 = (1, 0, 0) -> cell 4; child 0 =
  // (1, 1, 1) -> cell 7. 8 grid texels + 2 leaves + 1 internal + 2 leaves =
  // 14 texels: width 4, 4 rows.
  EXPECT_EQ(texture.width, 4u);
  EXPECT_EQ(texture.height, 4u);
  EXPECT_EQ(texture.gridTexels(), 8u);
  EXPECT_EQ(texture.usedTexels(), 14u);
  const std::array<std::uint8_t, 4> empty = {0xFF, 0xFF, 0xFF, 0xFF};
  const Texels expected = {
      {0x08, 0x00, 0x00, 0x00},  // 0: cell (0,0,0) -> child 7 at texel 8
      empty, empty, empty,       // 1-3: cells without nodes
      {0x09, 0x00, 0x00, 0x00},  // 4: cell (1,0,0) -> child 3 at texel 9
      empty, empty,              // 5-6
      {0x0B, 0x00, 0x00, 0x00},  // 7: cell (1,1,1) -> child 0 at texel 11
      {0x80, 0xFF, 0x80, 0x00},  // 8: child 7, leaf +y
      {0x03, 0x00, 0x00, 0x42},  // 9: child 3: brood at 9 + 3 = 12
      {0x00, 0x80, 0x80, 0x00},  // 10: child 3 normal -x
      {0xFF, 0x80, 0x80, 0x00},  // 11: child 0, leaf +x
      {0x80, 0x00, 0x80, 0x00},  // 12: child 3.1, leaf -y
      {0x80, 0x80, 0x00, 0x00},  // 13: child 3.6, leaf -z
      {0, 0, 0, 0},              // 14-15: padding
      {0, 0, 0, 0},
  };
  EXPECT_EQ(texelsOf(texture), expected);
}

void expectLookup(const Lookup& lookup, std::uint32_t texel, int depth, const Vec3f& axis) {
  EXPECT_TRUE(lookup.found);
  EXPECT_EQ(lookup.texel, texel);
  EXPECT_EQ(lookup.depth, depth);
  EXPECT_GT(lookup.normal.dot(axis), 0.9999f) << lookup.normal.transpose();
}

TEST(LookupTexture, TinyTreeByHand) {
  const ApoTexture flat = encodeOrDie(tinyTree(), 0, NormalEncoding::Xyz8);
  const ApoTexture grid = encodeOrDie(tinyTree(), 1, NormalEncoding::Xyz8);
  // Child 3 (x upper, y and z lower) is centred at (0.75, 0.25, 0.25); its
  // child 1 (z lower) at (0.875, 0.375, 0.125), its child 6 (x, y lower) at
  // (0.625, 0.125, 0.375).
  expectLookup(lookupTexture(flat, {0.875f, 0.375f, 0.125f}), 7, 2, -Vec3f::UnitY());
  expectLookup(lookupTexture(grid, {0.875f, 0.375f, 0.125f}), 12, 2, -Vec3f::UnitY());
  expectLookup(lookupTexture(flat, {0.625f, 0.125f, 0.375f}), 8, 2, -Vec3f::UnitZ());
  // Child 3 has no child 0 (all upper): the walk stops at child 3.
  expectLookup(lookupTexture(flat, {0.875f, 0.375f, 0.375f}), 4, 1, -Vec3f::UnitX());
  // The root has no child 1: the root's normal; with the grid, an empty cell.
  expectLookup(lookupTexture(flat, {0.75f, 0.75f, 0.25f}), 1, 0, Vec3f::UnitZ());
  EXPECT_FALSE(lookupTexture(grid, {0.75f, 0.75f, 0.25f}).found);
  // On the centre planes a point goes to the lower side: child 7; at the
  // far corner, child 0.
  expectLookup(lookupTexture(flat, {0.5f, 0.5f, 0.5f}), 6, 1, Vec3f::UnitY());
  expectLookup(lookupTexture(grid, {0.5f, 0.5f, 0.5f}), 8, 1, Vec3f::UnitY());
  expectLookup(lookupTexture(flat, {0.0f, 0.0f, 0.0f}), 6, 1, Vec3f::UnitY());
  expectLookup(lookupTexture(grid, {1.0f, 1.0f, 1.0f}), 11, 1, Vec3f::UnitX());
  // Outside the cube, or NaN.
  EXPECT_FALSE(lookupTexture(flat, {1.0001f, 0.5f, 0.5f}).found);
  EXPECT_FALSE(lookupTexture(flat, {0.5f, -1e-30f, 0.5f}).found);
  EXPECT_FALSE(lookupTexture(flat, {0.5f, 0.5f, std::numeric_limits<float>::quiet_NaN()}).found);
}

TEST(LookupTexture, MaxDepthStopsTheWalk) {
  const ApoTexture flat = encodeOrDie(tinyTree(), 0, NormalEncoding::Xyz8);
  const ApoTexture grid = encodeOrDie(tinyTree(), 1, NormalEncoding::Xyz8);
  const Vec3f p(0.875f, 0.375f, 0.125f);  // in child 3.1
  expectLookup(lookupTexture(flat, p, 0), 1, 0, Vec3f::UnitZ());   // the root's normal (texel 2)
  expectLookup(lookupTexture(flat, p, 1), 4, 1, -Vec3f::UnitX());  // child 3's normal (texel 5)
  expectLookup(lookupTexture(flat, p, 2), 7, 2, -Vec3f::UnitY());
  // Above the grid the walk cannot go: it stops at the grid's node.
  expectLookup(lookupTexture(grid, p, 0), 9, 1, -Vec3f::UnitX());
  // The octree walk stops at maxDepth too; Lookup::texel is then the node.
  const Octree octree = tinyTree();
  const Lookup root = lookupOctree(octree, p, 0);
  EXPECT_EQ(root.depth, 0);
  EXPECT_EQ(root.texel, 0u);
  EXPECT_EQ(lookupOctree(octree, p, 1).normal, -Vec3f::UnitX());
}

// ---- Settings and limits --------------------------------------------------------

TEST(EncodeApo, RejectsACompletionBelowTheCoarseDepth) {
  const Result<ApoTexture> texture = encodeApo(tinyTree(), 2, NormalEncoding::Oct24, 1, 5);
  ASSERT_FALSE(texture.ok());
  EXPECT_EQ(texture.error().kind, ErrorKind::Usage);
  EXPECT_THAT(texture.error().message, HasSubstr("--complete-depth 2 must not exceed the coarse depth 1"));
}

TEST(EncodeApo, RejectsALeafAboveTheGrid) {
  // Child 0 at depth 1 is a leaf, so the tree is complete to depth 1 only.
  const Result<ApoTexture> texture = encodeApo(tinyTree(), 2, NormalEncoding::Oct24, 2, 5);
  ASSERT_FALSE(texture.ok());
  EXPECT_EQ(texture.error().kind, ErrorKind::Usage);
  EXPECT_THAT(texture.error().message, HasSubstr("at depth 1"));
  EXPECT_THAT(texture.error().message, HasSubstr("is a leaf"));
}

TEST(EncodeApo, RejectsOutOfRangeDepths) {
  const Result<ApoTexture> deepGrid = encodeApo(tinyTree(), 11, NormalEncoding::Oct24, 11, 12);
  ASSERT_FALSE(deepGrid.ok());
  EXPECT_EQ(deepGrid.error().kind, ErrorKind::Usage);
  EXPECT_THAT(deepGrid.error().message, HasSubstr("between 0 and 10"));
  const Result<ApoTexture> negative = encodeApo(tinyTree(), -1, NormalEncoding::Oct24, 1, 5);
  ASSERT_FALSE(negative.ok());
  const Result<ApoTexture> tooDeep = encodeApo(tinyTree(), 0, NormalEncoding::Oct24, 1, 21);
  ASSERT_FALSE(tooDeep.ok());
  EXPECT_THAT(tooDeep.error().message, HasSubstr("--max-depth 21"));
  // The tree (depth 2) deeper than the bake's max depth is a bug upstream.
  const Result<ApoTexture> deeperTree = encodeApo(tinyTree(), 0, NormalEncoding::Oct24, 1, 1);
  ASSERT_FALSE(deeperTree.ok());
  EXPECT_EQ(deeperTree.error().kind, ErrorKind::Internal);
  EXPECT_THAT(deeperTree.error().message, HasSubstr("deeper than the max depth 1"));
}

TEST(TexelLayout, BroodOffsetsMustFit24Bits) {
  // A tree with 2^24 texels between a node and its brood would take
  // gigabytes here; the encoder's check is this function.
  EXPECT_EQ(*texel::broodOffset(5, 5 + 0xFFFFFF), 0xFFFFFFu);
  const Result<std::uint32_t> tooFar = texel::broodOffset(5, 5 + 0x1000000);
  ASSERT_FALSE(tooFar.ok());
  EXPECT_EQ(tooFar.error().kind, ErrorKind::Usage);
  EXPECT_THAT(tooFar.error().message, HasSubstr("does not fit the 24 bits"));
}

TEST(TexelLayout, WidthIsThePowerOfTwoThatMakesItClosestToSquare) {
  EXPECT_EQ(texel::textureWidthFor(1), 2u);  // K >= 1
  EXPECT_EQ(texel::textureWidthFor(4), 2u);
  EXPECT_EQ(texel::textureWidthFor(5), 4u);
  EXPECT_EQ(texel::textureWidthFor(16), 4u);
  EXPECT_EQ(texel::textureWidthFor(17), 8u);
  EXPECT_EQ(texel::textureWidthFor(std::uint64_t{1} << 28), 16384u);
  EXPECT_EQ(texel::textureWidthFor(std::uint64_t{1} << 31), 16384u);  // capped
  EXPECT_EQ(texel::rowsFor(17, 8), 3u);
}

// ---- Random trees -------------------------------------------------------------

TEST(DecodeApo, InvertsEncodeOnRandomTrees) {
  for (std::uint64_t seed = 1; seed <= 12; ++seed) {
    Octree octree = test::randomOctree(seed, 3, 8, 0.45);
    octree.transform.scale = 2.5;
    octree.transform.offset = {0.1, -0.2, 0.3};
    for (int completeDepth = 0; completeDepth <= 3; ++completeDepth) {
      for (NormalEncoding encoding : {NormalEncoding::Xyz8, NormalEncoding::Oct24}) {
        const ApoTexture texture = encodeOrDie(octree, completeDepth, encoding);
        const Result<Octree> decoded = decodeApo(texture);
        ASSERT_TRUE(decoded.ok()) << decoded.error().message;
        EXPECT_EQ(decoded->nodes.size(), octree.nodes.size());
        EXPECT_EQ(decoded->transform.scale, 2.5);
        EXPECT_EQ(decoded->transform.offset, octree.transform.offset);
        EXPECT_EQ(test::firstDifference(test::expectedDecoding(octree, encoding, completeDepth), *decoded), "")
            << "seed " << seed << ", complete depth " << completeDepth << ", " << normalEncodingName(encoding);
      }
    }
  }
}

TEST(DecodeApo, InvertsEncodeOnADepthFirstTree) {
  const Octree octree = tinyTree();
  for (int completeDepth = 0; completeDepth <= 1; ++completeDepth) {
    const Result<Octree> decoded = decodeApo(encodeOrDie(octree, completeDepth, NormalEncoding::Oct24));
    ASSERT_TRUE(decoded.ok()) << decoded.error().message;
    EXPECT_EQ(test::firstDifference(test::expectedDecoding(octree, NormalEncoding::Oct24, completeDepth), *decoded),
              "");
  }
}

TEST(EncodeApo, TextureShapeAndDeterminism) {
  const Octree octree = test::randomOctree(5, 2, 7, 0.5);
  const ApoTexture texture = encodeOrDie(octree, 2, NormalEncoding::Oct24);
  const auto aboveGrid = std::count_if(octree.nodes.begin(), octree.nodes.end(),
                                       [](const OctreeNode& node) { return node.depth < 2; });
  EXPECT_EQ(texture.leafNodes + texture.internalNodes + static_cast<std::uint64_t>(aboveGrid), octree.nodes.size());
  EXPECT_EQ(texture.width, texel::textureWidthFor(texture.usedTexels()));
  EXPECT_EQ(texture.height, texel::rowsFor(texture.usedTexels(), texture.width));
  EXPECT_EQ(texture.texels.size(), 4ull * texture.width * texture.height);
  EXPECT_EQ(encodeOrDie(octree, 2, NormalEncoding::Oct24).texels, texture.texels);
}

// The normals' codes made in ranges, out of order and on other threads,
// give the texture made on one thread, byte for byte.
TEST(EncodeApo, TheTextureDoesNotDependOnHowTheCodesAreShared) {
  const Octree octree = test::randomOctree(9, 2, 7, 0.6);
  ASSERT_GT(octree.nodes.size(), 1000u);
  std::size_t ranges = 0;
  const ParallelRanges backwardsOnThreads = [&](std::size_t count, const auto& body) {
    constexpr std::size_t kRange = 97;
    std::vector<std::thread> threads;
    for (std::size_t end = count; end > 0; end -= std::min(end, kRange)) {
      threads.emplace_back(body, end - std::min(end, kRange), end);
      ++ranges;
    }
    for (std::thread& thread : threads) thread.join();
  };
  for (const NormalEncoding encoding : {NormalEncoding::Oct24, NormalEncoding::Xyz8}) {
    const Result<ApoTexture> shared = encodeApo(octree, 2, encoding, 2, 7, backwardsOnThreads);
    ASSERT_TRUE(shared.ok()) << shared.error().message;
    EXPECT_EQ(shared->texels, encodeOrDie(octree, 2, encoding).texels);
  }
  EXPECT_GT(ranges, 20u);  // the codes were shared out
}

using test::lookupPoints;

bool insideCube(const Vec3f& p) { return (p.array() >= 0.0f).all() && (p.array() <= 1.0f).all(); }

TEST(LookupTexture, AgreesWithTheOctreeAndDoesNotDependOnCompletion) {
  const Octree octree = test::randomOctree(42, 3, 8, 0.45);
  const NormalEncoding encoding = NormalEncoding::Oct24;
  const ApoTexture flat = encodeOrDie(octree, 0, encoding);
  const ApoTexture grid2 = encodeOrDie(octree, 2, encoding);
  const ApoTexture grid3 = encodeOrDie(octree, 3, encoding);
  std::size_t inside = 0, emptyCells = 0;
  for (const Vec3f& p : lookupPoints(100000, 9)) {
    const Lookup expected = lookupOctree(octree, p);
    const Lookup actual = lookupTexture(flat, p);
    ASSERT_EQ(actual.found, insideCube(p)) << p.transpose();
    ASSERT_EQ(expected.found, actual.found) << p.transpose();
    if (!actual.found) continue;
    ++inside;
    ASSERT_EQ(actual.depth, expected.depth) << p.transpose();
    ASSERT_EQ(actual.normal, decodeNormal(encodeNormal(expected.normal, encoding), encoding)) << p.transpose();
    for (const ApoTexture* completed : {&grid2, &grid3}) {
      const Lookup lookup = lookupTexture(*completed, p);
      if (!lookup.found) {
        // An empty grid cell: the octree walk ended above the grid.
        ASSERT_LT(expected.depth, completed->completeDepth) << p.transpose();
        ++emptyCells;
        continue;
      }
      ASSERT_EQ(lookup.depth, actual.depth) << p.transpose();
      ASSERT_EQ(lookup.normal, actual.normal) << p.transpose();
    }
  }
  // The sample reached both cases.
  EXPECT_GT(inside, 50000u);
  EXPECT_GT(emptyCells, 100u);
}

TEST(LookupTexture, MaxDepthAgreesWithTheOctreeOnRandomTrees) {
  const Octree octree = test::randomOctree(43, 2, 8, 0.5);
  const ApoTexture flat = encodeOrDie(octree, 0, NormalEncoding::Oct24);
  const ApoTexture grid = encodeOrDie(octree, 2, NormalEncoding::Oct24);
  for (const Vec3f& p : lookupPoints(20000, 10)) {
    for (int maxDepth = 0; maxDepth <= 8; ++maxDepth) {
      const Lookup expected = lookupOctree(octree, p, maxDepth);
      const Lookup actual = lookupTexture(flat, p, maxDepth);
      ASSERT_EQ(actual.found, expected.found);
      if (!actual.found) continue;
      ASSERT_LE(actual.depth, maxDepth);
      ASSERT_EQ(actual.depth, expected.depth);
      ASSERT_EQ(actual.normal, decodeNormal(encodeNormal(expected.normal, NormalEncoding::Oct24),
                                            NormalEncoding::Oct24));
      // With a grid of depth 2, the walk starts at depth 2: above it, it
      // stops at the grid's node; from there on, it is the same walk.
      const Lookup completed = lookupTexture(grid, p, maxDepth);
      if (!completed.found) continue;  // an empty grid cell
      if (maxDepth < 2) {
        ASSERT_EQ(completed.depth, 2);
      } else {
        ASSERT_EQ(completed.depth, actual.depth);
        ASSERT_EQ(completed.normal, actual.normal);
      }
    }
  }
}

// ---- Validation by the decoder ----------------------------------------------------

ApoTexture tinyFlat() { return encodeOrDie(tinyTree(), 0, NormalEncoding::Xyz8); }

void expectRejected(const ApoTexture& texture, const std::string& what) {
  const Result<Octree> decoded = decodeApo(texture);
  ASSERT_FALSE(decoded.ok()) << "accepted; expected: " << what;
  EXPECT_EQ(decoded.error().kind, ErrorKind::BadInput);
  EXPECT_THAT(decoded.error().message, HasSubstr(what));
}

TEST(DecodeApo, RejectsAGridEntryOffTheLayout) {
  ApoTexture texture = tinyFlat();
  texture.texels[0] = 2;
  expectRejected(texture, "grid entry of cell (0, 0, 0) points to texel 2, expected 1");
}

TEST(DecodeApo, RejectsAnOffsetOffTheLayout) {
  ApoTexture texture = tinyFlat();
  texture.texels[4 * 4] = 0x04;  // child 3's offset: 3 -> 4
  expectRejected(texture, "texel 4: the offset 4 to the children points to texel 8, expected 7");
  texture.texels[4 * 4 + 2] = 0x80;  // far beyond the texture
  expectRejected(texture, "texel 4: the offset");
}

TEST(DecodeApo, RejectsAKindMaskThatDisagreesWithTheChild) {
  ApoTexture texture = tinyFlat();
  texture.texels[4 * 2 + 3] = 0x09;  // root says child 0 is internal too
  // A kind bit on a leaf would make it two-sided: not in a texture counting none.
  expectRejected(texture, "texel 3: its parent's kind mask says two texels, but its child mask is 0");
  texture.texels[4 * 2 + 3] = 0x18;  // a kind bit for the absent child 4
  expectRejected(texture, "kind mask 0x18 marks children absent from the child mask 0x89");
}

TEST(DecodeApo, RejectsNonZeroPaddingAndWrongCounts) {
  ApoTexture padded = tinyFlat();
  padded.texels[4 * 10 + 1] = 1;
  expectRejected(padded, "texel 10: the unused texels");
  ApoTexture counts = tinyFlat();
  counts.leafNodes -= 2;
  counts.internalNodes += 1;  // same used texels, other split
  expectRejected(counts, "with 4 leaves (0 two-sided) and 2 internal nodes");
  ApoTexture shortTexels = tinyFlat();
  shortTexels.texels.pop_back();
  expectRejected(shortTexels, "bytes of texels for a 4 x 3 texture");
  ApoTexture tooMany = tinyFlat();
  tooMany.leafNodes = std::numeric_limits<std::uint64_t>::max();
  expectRejected(tooMany, "do not fit");
  ApoTexture noNode = tinyFlat();
  noNode.texels.assign(noNode.texels.size(), 0);
  noNode.texels[0] = noNode.texels[1] = noNode.texels[2] = noNode.texels[3] = 0xFF;
  noNode.leafNodes = noNode.internalNodes = 0;
  expectRejected(noNode, "every grid cell is empty");
}

TEST(DecodeApo, CorruptTexturesNeverCrashIt) {
  // Byte flips anywhere: decodeApo either rejects the texture or returns a
  // tree, and then lookups stay inside the texture (they check it).
  std::mt19937_64 random(3);
  const std::vector<Vec3f> points = lookupPoints(200, 4);
  for (int completeDepth = 0; completeDepth <= 1; ++completeDepth) {
    const ApoTexture valid = encodeOrDie(test::randomOctree(11, 1, 5, 0.5), completeDepth, NormalEncoding::Oct24);
    std::uniform_int_distribution<std::size_t> byteDist(0, valid.texels.size() - 1);
    std::uniform_int_distribution<int> valueDist(0, 255);
    for (int trial = 0; trial < 2000; ++trial) {
      ApoTexture texture = valid;
      for (int flips = 1 + trial % 3; flips > 0; --flips)
        texture.texels[byteDist(random)] = static_cast<std::uint8_t>(valueDist(random));
      if (!decodeApo(texture).ok()) continue;
      for (const Vec3f& p : points) (void)lookupTexture(texture, p);
    }
  }
}


// ---- Leaves that show m's own normal (format version 3) ---------------------

// The tiny tree with its leaf {3, 6} (normal -z) showing m's normal.
Octree tinyTreeShowingM() {
  Octree octree = tinyTree();
  for (OctreeNode& node : octree.nodes)
    if (node.isLeaf() && node.normal.z() < -0.5f) node.coarseNormal = true;
  return octree;
}

TEST(LeavesShowingM, HoldTheReservedCodeAndAnswerTheCallersNormal) {
  const Vec3f inShowingLeaf(0.625f, 0.125f, 0.375f), elsewhere(0.875f, 0.375f, 0.125f);
  const Vec3f m = Vec3f(1.0f, 2.0f, 2.0f).normalized();
  for (const NormalEncoding encoding : {NormalEncoding::Xyz8, NormalEncoding::Oct24}) {
    const ApoTexture texture = encodeOrDie(tinyTreeShowingM(), 0, encoding);
    EXPECT_TRUE(texture.defersToCoarse);
    // Texel 8 is the leaf {3, 6} (LookupTexture.TinyTreeByHand).
    const std::uint32_t code = encoding == NormalEncoding::Xyz8 ? 0x808080u : 0x000FFFu;
    const std::array<std::uint8_t, 4> expected = {static_cast<std::uint8_t>(code & 0xFF),
                                                  static_cast<std::uint8_t>((code >> 8) & 0xFF),
                                                  static_cast<std::uint8_t>(code >> 16), 0};
    EXPECT_EQ(texelsOf(texture)[8], expected);
    const Lookup shown = lookupTexture(texture, inShowingLeaf, 255, m);
    EXPECT_TRUE(shown.found && shown.coarse);
    EXPECT_EQ(shown.normal, m);
    EXPECT_EQ(lookupTexture(texture, inShowingLeaf).normal, Vec3f::Zero());  // no m given: nothing to answer
    const Lookup filtered = lookupTextureFiltered(texture, inShowingLeaf, m);
    EXPECT_EQ(filtered.normal, m) << "a leaf showing m shows it unblended";
    const Lookup other = lookupTexture(texture, elsewhere, 255, m);
    EXPECT_FALSE(other.coarse);
    EXPECT_GT(other.normal.dot(-Vec3f::UnitY()), 0.9999f);
    // Decoded, the leaf still says so.
    const Result<Octree> decoded = decodeApo(texture);
    ASSERT_TRUE(decoded.ok()) << decoded.error().message;
    EXPECT_EQ(std::count_if(decoded->nodes.begin(), decoded->nodes.end(), [](const OctreeNode& n) { return n.coarseNormal; }), 1);
  }
}

TEST(LeavesShowingM, WithoutThemTheCodesAreNormalsAndNoNormalIsEncodedToThem) {
  // A texture without leaves showing m (versions 1 and 2) reads the oct24
  // code as the direction it decodes to, -z.
  ApoTexture texture = encodeOrDie(tinyTreeShowingM(), 0, NormalEncoding::Oct24);
  texture.defersToCoarse = false;
  const Lookup plain = lookupTexture(texture, {0.625f, 0.125f, 0.375f}, 255, Vec3f::UnitX());
  EXPECT_FALSE(plain.coarse);
  EXPECT_GT(plain.normal.dot(-Vec3f::UnitZ()), 0.9999f);
  // Directions around -z, where the octahedral fold meets the code's corner.
  std::mt19937 random(7);
  std::normal_distribution<float> jitter(0.0f, 1e-3f);
  for (int i = 0; i < 100000; ++i) {
    const Vec3f n = Vec3f(jitter(random), jitter(random), -1.0f).normalized();
    for (const NormalEncoding encoding : {NormalEncoding::Xyz8, NormalEncoding::Oct24}) {
      const auto bytes = encodeNormal(n, encoding);
      const std::uint32_t value = bytes[0] | bytes[1] << 8 | bytes[2] << 16;
      ASSERT_NE(value, texel::coarseCode(encoding == NormalEncoding::Xyz8)) << n.transpose();
    }
  }
}

TEST(LeavesShowingM, AnInternalNodeHoldingTheCodeIsRefused) {
  ApoTexture texture = encodeOrDie(tinyTreeShowingM(), 0, NormalEncoding::Xyz8);
  // Texel 2 is the root's normal texel (the root is internal at texel 1).
  for (int channel = 0; channel < 3; ++channel) texture.texels[4 * 2 + channel] = 0x80;
  const Result<Octree> decoded = decodeApo(texture);
  ASSERT_FALSE(decoded.ok());
  EXPECT_THAT(decoded.error().message, HasSubstr("only leaves hold"));
}

// ---- Two-sided leaves (format version 4) --------------------------------------
//
// The tiny tree with leaf {3, 1} two-sided on z: +z where m's normal has
// z >= 0, -z elsewhere.
Octree tinyTreeTwoSided() {
  Octree octree = tinyTree();
  for (OctreeNode& node : octree.nodes)
    if (node.isLeaf() && node.normal.y() < -0.5f) {
      node.twoSided = true;
      node.sideAxis = 2;
      node.sides = {Vec3f::UnitZ(), -Vec3f::UnitZ()};
    }
  return octree;
}

TEST(TwoSidedLeaves, TakeTwoTexelsFlaggedByTheParentsKindBitByHand) {
  const ApoTexture texture = encodeOrDie(tinyTreeTwoSided(), 0, NormalEncoding::Xyz8);
  EXPECT_EQ(texture.leafNodes, 4u);
  EXPECT_EQ(texture.twoSidedLeaves, 1u);
  EXPECT_EQ(texture.internalNodes, 2u);
  EXPECT_EQ(texture.usedTexels(), 10u);
  EXPECT_TRUE(texture.needsCoarseNormals());
  const Texels expected = {
      {0x01, 0x00, 0x00, 0x00},  // 0: grid entry -> the root at texel 1
      {0x02, 0x00, 0x00, 0x89},  // 1: root: brood at 3; children 0, 3, 7
      {0x80, 0x80, 0xFF, 0x08},  // 2: root normal +z; kind: child 3 takes two texels
      {0xFF, 0x80, 0x80, 0x00},  // 3: child 0, leaf +x
      {0x03, 0x00, 0x00, 0x42},  // 4: child 3: brood at 7; children 1, 6
      {0x00, 0x80, 0x80, 0x02},  // 5: child 3 normal -x; kind: child 1 takes two texels
      {0x80, 0xFF, 0x80, 0x00},  // 6: child 7, leaf +y
      {0x80, 0x80, 0xFF, 0x00},  // 7: child 3.1, side 0 +z (a leaf: mask 0)
      {0x80, 0x80, 0x00, 0x02},  // 8: child 3.1, side 1 -z, axis z
      {0x80, 0x80, 0x00, 0x00},  // 9: child 3.6, leaf -z
      {0, 0, 0, 0},              // 10-11: the rest of the last row
      {0, 0, 0, 0},
  };
  EXPECT_EQ(texelsOf(texture), expected);
}

TEST(TwoSidedLeaves, TheLookupsPickTheSideByMsNormal) {
  const Vec3f inTwoSided(0.875f, 0.375f, 0.125f);
  const Octree octree = tinyTreeTwoSided();
  for (const int completeDepth : {0, 1}) {
    const ApoTexture texture = encodeOrDie(octree, completeDepth, NormalEncoding::Oct24);
    const std::uint32_t first = completeDepth == 0 ? 7 : 12;
    const Lookup up = lookupTexture(texture, inTwoSided, 255, Vec3f(0.3f, -0.9f, 0.1f).normalized());
    EXPECT_TRUE(up.found && up.twoSided);
    EXPECT_EQ(up.texel, first);
    EXPECT_GT(up.normal.dot(Vec3f::UnitZ()), 0.9999f);
    const Lookup down = lookupTexture(texture, inTwoSided, 255, Vec3f(0.9f, 0.3f, -0.1f).normalized());
    EXPECT_EQ(down.texel, first) << "the node is the same, only its normal differs";
    EXPECT_GT(down.normal.dot(-Vec3f::UnitZ()), 0.9999f);
    // Without m, side 0; z exactly 0 is side 0 too.
    EXPECT_GT(lookupTexture(texture, inTwoSided).normal.dot(Vec3f::UnitZ()), 0.9999f);
    EXPECT_GT(lookupTexture(texture, inTwoSided, 255, Vec3f::UnitX()).normal.dot(Vec3f::UnitZ()), 0.9999f);
    // The same answers from the octree, and from the decoded octree.
    const Result<Octree> decoded = decodeApo(texture);
    ASSERT_TRUE(decoded.ok()) << decoded.error().message;
    for (const Octree* tree : {&octree, &*decoded}) {
      EXPECT_GT(lookupOctree(*tree, inTwoSided, 255, Vec3f(0, 0, 1)).normal.dot(Vec3f::UnitZ()), 0.9999f);
      EXPECT_GT(lookupOctree(*tree, inTwoSided, 255, Vec3f(0, 0, -1)).normal.dot(-Vec3f::UnitZ()), 0.9999f);
    }
    EXPECT_EQ(std::count_if(decoded->nodes.begin(), decoded->nodes.end(),
                            [](const OctreeNode& n) { return n.twoSided && n.sideAxis == 2; }),
              1);
    // The filter blends the side m picks: every neighbour of the leaf at its
    // depth is elsewhere in the tree, so the side shows through the blend.
    const Lookup filteredUp = lookupTextureFiltered(texture, inTwoSided, Vec3f::UnitZ());
    const Lookup filteredDown = lookupTextureFiltered(texture, inTwoSided, -Vec3f::UnitZ());
    EXPECT_GT(filteredUp.normal.dot(Vec3f::UnitZ()), 0.0f);
    EXPECT_LT(filteredDown.normal.dot(Vec3f::UnitZ()), 0.0f);
  }
}

// Random trees with random two-sided leaves below the grid: the texture's
// walk, the octree's and the decoded octree's agree for random m normals.
TEST(TwoSidedLeaves, TheTextureWalkAgreesWithTheOctreeOnRandomTrees) {
  for (const int completeDepth : {0, 2}) {
    Octree octree = test::randomOctree(44, 2, 7, 0.6);
    std::mt19937_64 random(45);
    std::bernoulli_distribution pick(0.5);
    std::uniform_int_distribution<int> axis(0, 2);
    int twoSided = 0;
    for (OctreeNode& node : octree.nodes)
      if (node.isLeaf() && node.depth > completeDepth && pick(random)) {
        node.twoSided = true;
        node.sideAxis = static_cast<std::uint8_t>(axis(random));
        node.sides = {test::randomUnitVector(random), test::randomUnitVector(random)};
        ++twoSided;
      }
    ASSERT_GT(twoSided, 50);
    const NormalEncoding encoding = NormalEncoding::Oct24;
    const ApoTexture texture = encodeOrDie(octree, completeDepth, encoding);
    EXPECT_EQ(texture.twoSidedLeaves, static_cast<std::uint64_t>(twoSided));
    const Result<Octree> decoded = decodeApo(texture);
    ASSERT_TRUE(decoded.ok()) << decoded.error().message;
    std::size_t onTwoSided = 0;
    for (const Vec3f& p : lookupPoints(50000, 10)) {
      const Vec3f m = test::randomUnitVector(random);
      const Lookup expected = lookupOctree(octree, p, 255, m);
      const Lookup actual = lookupTexture(texture, p, 255, m);
      if (!actual.found) continue;
      ASSERT_EQ(actual.twoSided, expected.twoSided) << p.transpose();
      ASSERT_EQ(actual.normal, decodeNormal(encodeNormal(expected.normal, encoding), encoding)) << p.transpose();
      ASSERT_EQ(lookupOctree(*decoded, p, 255, m).normal, actual.normal) << p.transpose();
      onTwoSided += actual.twoSided ? 1 : 0;
    }
    EXPECT_GT(onTwoSided, 300u);
  }
}

TEST(TwoSidedLeaves, TheDecoderRefusesWhatTheEncoderNeverWrites) {
  const ApoTexture good = encodeOrDie(tinyTreeTwoSided(), 0, NormalEncoding::Xyz8);
  ApoTexture axis = good;
  axis.texels[4 * 8 + 3] = 3;
  expectRejected(axis, "texel 8: a two-sided leaf's axis is 3");
  ApoTexture code = good;
  for (int channel = 0; channel < 3; ++channel) code.texels[4 * 8 + channel] = 0x80;
  expectRejected(code, "a side of a two-sided leaf holds the code of m's own normal");
  ApoTexture uncounted = good;
  uncounted.twoSidedLeaves = 0;
  uncounted.leafNodes += 1;  // the same used texels, counted as one-texel leaves
  expectRejected(uncounted, "which only files counting two-sided leaves (format version 4) hold");
}

TEST(TwoSidedLeaves, TheEncoderRefusesOneAtTheCompletionDepth) {
  // Grid nodes have no parent to flag their two texels.
  Octree octree = test::octreeFromPaths({{0, 1}, {3, 1}, {3, 6}}, [](const ChildPath&) { return Vec3f(Vec3f::UnitX()); });
  octree.nodes.back().twoSided = true;
  octree.nodes.back().sides = {Vec3f::UnitX(), -Vec3f::UnitX()};
  ASSERT_TRUE(encodeApo(octree, 1, NormalEncoding::Xyz8, 2, 12).ok());
  const Result<ApoTexture> texture = encodeApo(octree, 2, NormalEncoding::Xyz8, 2, 12);
  ASSERT_FALSE(texture.ok());
  EXPECT_THAT(texture.error().message, HasSubstr("two-sided leaf at the completion depth 2"));
}

// Internal nodes showing m (version 4): a walk stopped early at one (the
// mip-mapping's maxDepth, or a missing child) answers m's normal.
TEST(InternalNodesShowingM, AnswerTheCallersNormalWhereAWalkStopsAtThem) {
  Octree octree = tinyTree();
  for (OctreeNode& node : octree.nodes)
    if (!node.isLeaf() && node.depth == 1) node.coarseNormal = true;  // child 3
  const Vec3f m = Vec3f(1.0f, 2.0f, 2.0f).normalized();
  for (const NormalEncoding encoding : {NormalEncoding::Xyz8, NormalEncoding::Oct24}) {
    const ApoTexture texture = encodeOrDie(octree, 0, encoding);
    EXPECT_TRUE(texture.coarseAtInternalNodes && texture.defersToCoarse);
    // Texel 5 is child 3's normal texel (EncodeApo.TinyTreeWithoutCompletionByHand).
    const std::uint32_t code = encoding == NormalEncoding::Xyz8 ? 0x808080u : 0x000FFFu;
    EXPECT_EQ(texelsOf(texture)[5][0], static_cast<std::uint8_t>(code & 0xFF));
    EXPECT_EQ(texelsOf(texture)[5][3], 0x00) << "its kind mask is unchanged";
    // Stopped at depth 1 inside child 3, or at its missing child 0: m.
    const Lookup early = lookupTexture(texture, {0.875f, 0.375f, 0.125f}, 1, m);
    EXPECT_TRUE(early.found && early.coarse);
    EXPECT_EQ(early.normal, m);
    EXPECT_EQ(lookupTexture(texture, {0.875f, 0.375f, 0.375f}, 255, m).normal, m);
    // The walk to the leaf below is unchanged.
    EXPECT_GT(lookupTexture(texture, {0.875f, 0.375f, 0.125f}, 255, m).normal.dot(-Vec3f::UnitY()), 0.9999f);
    // The octree and the decoded octree answer the same.
    const Result<Octree> decoded = decodeApo(texture);
    ASSERT_TRUE(decoded.ok()) << decoded.error().message;
    for (const Octree* tree : {static_cast<const Octree*>(&octree), &*decoded})
      EXPECT_EQ(lookupOctree(*tree, {0.875f, 0.375f, 0.125f}, 1, m).normal, m);
    // A texture that does not allow it (version 3) refuses it.
    ApoTexture older = texture;
    older.coarseAtInternalNodes = false;
    expectRejected(older, "which only leaves hold before format version 4");
  }
}

}  // namespace
}  // namespace apo
