// The sorted-sides edge map and the union-find, against edges counted by
// hand on small soups.
#include "core/mesh_edges.h"

#include <gtest/gtest.h>

#include <map>
#include <utility>

namespace apo {
namespace {

// Edge runs of the soup as a map from (smaller, larger) vertex to the sides' triangles.
std::map<std::pair<std::uint32_t, std::uint32_t>, std::vector<std::uint32_t>> runsOf(const std::vector<Triangle>& triangles) {
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::vector<std::uint32_t>> runs;
  const std::vector<TriangleSide> sides = sortedSides(triangles);
  forEachEdge(sides, [&](std::size_t first, std::size_t last) {
    auto& run = runs[{sides[first].from(), sides[first].to()}];
    EXPECT_TRUE(run.empty()) << "an edge's sides must be adjacent";
    for (std::size_t i = first; i < last; ++i) run.push_back(sides[i].triangle);
  });
  return runs;
}

TEST(MeshEdges, SidesOfOneEdgeAreAdjacentAndCollapsedSidesLieOnNone) {
  // Two triangles sharing 1-2, a third on 1-2 too (a fin), and a collapsed one.
  const std::vector<Triangle> triangles = {{0, 1, 2}, {2, 1, 3}, {1, 2, 4}, {5, 5, 6}};
  const auto runs = runsOf(triangles);
  EXPECT_EQ(runs.size(), 8u);  // 0-1 0-2 1-2 1-3 2-3 1-4 2-4 5-6
  EXPECT_EQ(runs.at({1, 2}), (std::vector<std::uint32_t>{0, 1, 2}));
  EXPECT_EQ(runs.at({0, 1}), (std::vector<std::uint32_t>{0}));
  EXPECT_EQ(runs.at({5, 6}), (std::vector<std::uint32_t>{3, 3}));  // the collapsed triangle's two real sides
  EXPECT_EQ(runs.count({5, 5}), 0u);
  // Each side knows its corner: triangle 1's side 2 -> 1 starts at corner 0.
  for (const TriangleSide& side : sortedSides(triangles)) {
    const Triangle& t = triangles[side.triangle];
    const std::uint32_t a = t[side.corner], b = t[(side.corner + 1) % 3];
    EXPECT_EQ(std::min(a, b), side.from());
    EXPECT_EQ(std::max(a, b), side.to());
  }
}

TEST(MeshEdges, DisjointSetsAnswerTheSmallestIndexWhateverTheOrderOfUnions) {
  DisjointSets forward(6), backward(6);
  forward.unite(4, 5);
  forward.unite(5, 1);
  forward.unite(2, 3);
  backward.unite(3, 2);
  backward.unite(1, 5);
  backward.unite(5, 4);
  for (std::uint32_t i = 0; i < 6; ++i) EXPECT_EQ(forward.find(i), backward.find(i)) << i;
  EXPECT_EQ(forward.find(4), 1u);
  EXPECT_EQ(forward.find(3), 2u);
  EXPECT_EQ(forward.find(0), 0u);
}

}  // namespace
}  // namespace apo
