// The global refinement (bake/refinement.h) driven by a table of errors in
// place of the L2,1 metric: the order of the splits under a texel budget
// against the plain greedy written below (and, on a small tree, by hand),
// its stop reasons, its counts of texels and error, and a tree that does not
// depend on the thread count.
#include "bake/refinement.h"

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <functional>
#include <map>
#include <random>
#include <string>
#include <vector>

namespace apo::octree {
namespace {

// A cell by its depth and grid coordinates at that depth.
using CellKey = std::array<int, 4>;

CellKey keyOf(const Cell& cell) {
  const Vec3f corner = cell.lower() * std::ldexp(1.0f, cell.depth);  // exact: dyadic
  return {cell.depth, static_cast<int>(corner.x()), static_cast<int>(corner.y()), static_cast<int>(corner.z())};
}

// What the table says of a cell: its L2,1 (M's area in it 1, so that no
// listed error is negligible) and the children a split would keep.
struct TableEntry {
  double variation = 0.0;
  std::uint8_t children = 0;
};
using ErrorTable = std::function<TableEntry(const CellKey&)>;

LeafError errorOf(const TableEntry& entry) { return LeafError{entry.variation, 0.0, 1.0}; }

// The refinement's evaluator, reading the table.
struct TableEvaluator {
  struct Scratch {};
  ErrorTable table;

  void prepare(std::vector<Leaf>& leaves) {
    for (Leaf& leaf : leaves) leaf.error = errorOf(table(keyOf(leaf.cell)));
  }
  int keptChildrenOf(const Leaf& leaf) const { return std::popcount(table(keyOf(leaf.cell)).children); }
  void split(Leaf& leaf, Candidate& candidate, Scratch&) const {
    candidate.mask = table(keyOf(leaf.cell)).children;
    for (int c = 0; c < 8; ++c) {
      if (!(candidate.mask & (1u << c))) continue;
      Leaf child;
      child.cell = leaf.cell.child(c);
      child.error = errorOf(table(keyOf(child.cell)));
      candidate.children.push_back(child);
    }
  }
  void release() {}
};

ErrorTable tableOf(std::map<CellKey, TableEntry> entries) {
  return [entries = std::move(entries)](const CellKey& key) {
    const auto found = entries.find(key);
    return found == entries.end() ? TableEntry{} : found->second;
  };
}

// What a refinement from the root made: the cells split, in the order the
// splits were made (their broods appended to the nodes), and its outcome.
struct Refined {
  std::vector<CellKey> splits;
  RefinementOutcome outcome;
  std::vector<OctreeNode> nodes;
};

Refined refine(const ErrorTable& table, const BuildSettings& settings) {
  Refined refined;
  refined.nodes.assign(1, OctreeNode{});
  refined.outcome.texels = texelsOf(refined.nodes, settings.completeDepth);
  TableEvaluator evaluator{table};
  GlobalRefinement refinement(evaluator, settings, refined.nodes, refined.outcome);
  Leaf root;
  refinement.start({root});
  refinement.run();
  // Each node's cell, walking down from the root.
  std::vector<Cell> cells(refined.nodes.size());
  std::vector<std::uint32_t> stack = {0};
  std::vector<std::pair<std::uint32_t, CellKey>> splitAt;  // (first child, cell split)
  while (!stack.empty()) {
    const std::uint32_t n = stack.back();
    stack.pop_back();
    const OctreeNode& node = refined.nodes[n];
    if (node.isLeaf()) continue;
    splitAt.emplace_back(node.firstChild, keyOf(cells[n]));
    std::uint32_t child = node.firstChild;
    for (int c = 0; c < 8; ++c)
      if (node.childMask & (1u << c)) {
        cells[child] = cells[n].child(c);
        stack.push_back(child++);
      }
  }
  std::sort(splitAt.begin(), splitAt.end());
  for (const auto& [firstChild, key] : splitAt) refined.splits.push_back(key);
  return refined;
}

// The plain greedy the refinement approximates in rounds: among all leaves
// that may split and whose split is worth something, split the one worth
// most per texel, until the next split's texels are over the budget.
struct Greedy {
  std::vector<CellKey> splits;
  std::string stoppedBy;
  std::uint64_t texels = 0;
  double error = 0.0;
};

Greedy greedy(const ErrorTable& table, const BuildSettings& settings) {
  struct Option {
    Cell cell;
    double variation;
  };
  std::vector<Option> leaves = {{Cell{}, table(keyOf(Cell{})).variation}};
  Greedy result;
  result.texels = 2;  // the completion grid of depth 0 and the root
  const auto mayRefine = [&](const Option& leaf) {
    return leaf.cell.depth < settings.maxDepth && leaf.variation > squaredRadians(kNegligibleDegrees) &&
           (settings.error <= 0.0 || leaf.variation > settings.error);
  };
  for (;;) {
    int best = -1;
    double bestValue = 0.0;
    std::uint64_t bestTexels = 0;
    for (std::size_t i = 0; i < leaves.size(); ++i) {
      const TableEntry entry = table(keyOf(leaves[i].cell));
      if (!mayRefine(leaves[i]) || entry.children == 0) continue;
      double childErrors = 0.0, largest = 0.0;
      for (int c = 0; c < 8; ++c)
        if (entry.children & (1u << c)) {
          const double e = table(keyOf(leaves[i].cell.child(c))).variation;
          childErrors += e;
          largest = std::max(largest, e);
        }
      const double value = std::max(leaves[i].variation - childErrors, largest);
      const std::uint64_t texels = 1 + static_cast<std::uint64_t>(std::popcount(entry.children));
      if (value > 0.0 && value / static_cast<double>(texels) > bestValue) {
        best = static_cast<int>(i);
        bestValue = value / static_cast<double>(texels);
        bestTexels = texels;
      }
    }
    if (best < 0) {
      result.stoppedBy = settings.error > 0.0 ? "error" : "converged";
      break;
    }
    if (settings.budgetTexels > 0 && result.texels + bestTexels > settings.budgetTexels) {
      result.stoppedBy = "budget";
      break;
    }
    const Option split = leaves[best];
    leaves.erase(leaves.begin() + best);
    result.splits.push_back(keyOf(split.cell));
    result.texels += bestTexels;
    const TableEntry entry = table(keyOf(split.cell));
    for (int c = 0; c < 8; ++c)
      if (entry.children & (1u << c))
        leaves.push_back({split.cell.child(c), table(keyOf(split.cell.child(c))).variation});
  }
  for (const Option& leaf : leaves) result.error += leaf.variation;
  return result;
}

BuildSettings settingsWith(std::uint64_t budget, double error = 0.0) {
  BuildSettings settings;
  settings.coarseDepth = 0;
  settings.maxDepth = 8;
  settings.completeDepth = 0;
  settings.budgetTexels = budget;
  settings.error = error;
  return settings;
}

// The root splits into children 0, 1 and 2; child 0 into two, child 2 into
// one, child 1 keeps none. By hand (value = the larger of the error removed
// and the largest child's, texels = 1 + children):
//   root:    gain 10 - (4 + 2 + 1) = 3, largest child 4: 4 / 4 = 1.0
//   child 0: gain 4 - 1 = 3:                            3 / 3 = 1.0
//   child 2: gain 0.1, largest child 0.9:             0.9 / 2 = 0.45
// so root, child 0, child 2, the texels going 2 -> 6 -> 9 -> 11.
const std::map<CellKey, TableEntry> kSmallTree = {
    {{0, 0, 0, 0}, {10.0, 0b111}},
    {{1, 1, 1, 1}, {4.0, 0b11}},   // child 0: the upper half on every axis
    {{1, 1, 1, 0}, {2.0, 0}},      // child 1
    {{1, 1, 0, 1}, {1.0, 0b10000000}},  // child 2, splitting into its child 7
    {{2, 3, 3, 3}, {0.5, 0}},      // child 0's child 0
    {{2, 3, 3, 2}, {0.5, 0}},      // child 0's child 1
    {{2, 2, 0, 2}, {0.9, 0}},      // child 2's child 7
};

TEST(GlobalRefinement, SplitsBestValuePerTexelFirstUntilTheBudget) {
  const ErrorTable table = tableOf(kSmallTree);
  const CellKey root{0, 0, 0, 0}, child0{1, 1, 1, 1}, child2{1, 1, 0, 1};
  struct Expected {
    std::uint64_t budget;
    std::vector<CellKey> splits;
    std::string stoppedBy;
    std::uint64_t texels;
    double error;
  };
  const std::vector<Expected> cases = {
      {5, {}, "budget", 2, 10.0},
      {6, {root}, "budget", 6, 7.0},
      {8, {root}, "budget", 6, 7.0},
      {9, {root, child0}, "budget", 9, 4.0},
      {10, {root, child0}, "budget", 9, 4.0},
      {11, {root, child0, child2}, "converged", 11, 3.9},
      {0, {root, child0, child2}, "converged", 11, 3.9},  // no budget
  };
  for (const Expected& expected : cases) {
    const Refined refined = refine(table, settingsWith(expected.budget));
    EXPECT_EQ(refined.splits, expected.splits) << "budget " << expected.budget;
    EXPECT_EQ(refined.outcome.stoppedBy, expected.stoppedBy) << "budget " << expected.budget;
    EXPECT_EQ(refined.outcome.texels, expected.texels) << "budget " << expected.budget;
    EXPECT_EQ(refined.outcome.texels, texelsOf(refined.nodes, 0));
    EXPECT_NEAR(refined.outcome.error, expected.error, 1e-12) << "budget " << expected.budget;
    EXPECT_DOUBLE_EQ(refined.outcome.area, static_cast<double>(refined.nodes.size() - refined.splits.size()));
  }
}

// With the paper's threshold, a leaf whose L2,1 is at most it stays a leaf:
// child 2 (1.0) does not split under 1.5, and neither does child 0 (4.0)
// under 5.
TEST(GlobalRefinement, StopsAtTheErrorThreshold) {
  const ErrorTable table = tableOf(kSmallTree);
  const Refined underOneAndAHalf = refine(table, settingsWith(0, 1.5));
  EXPECT_EQ(underOneAndAHalf.splits, (std::vector<CellKey>{{0, 0, 0, 0}, {1, 1, 1, 1}}));
  EXPECT_EQ(underOneAndAHalf.outcome.stoppedBy, "error");
  EXPECT_NEAR(underOneAndAHalf.outcome.error, 0.5 + 0.5 + 2.0 + 1.0, 1e-12);
  const Refined underFive = refine(table, settingsWith(0, 5.0));
  EXPECT_EQ(underFive.splits, (std::vector<CellKey>{{0, 0, 0, 0}}));
  EXPECT_EQ(underFive.outcome.stoppedBy, "error");
  const Refined underTwenty = refine(table, settingsWith(0, 20.0));
  EXPECT_TRUE(underTwenty.splits.empty());
  EXPECT_EQ(underTwenty.outcome.texels, 2u);
}

// No budget: the refinement splits until every leaf is negligible, keeps no
// child (a split worth nothing) or is at the maximum depth. A split whose
// children hold all of the leaf's error is still worth its largest child's
// error, as the error it opens to the next split (Candidate::value).
TEST(GlobalRefinement, ConvergesWhereNoLeafMaySplitOrIsWorthSplitting) {
  const ErrorTable table = tableOf({
      {{0, 0, 0, 0}, {5.0, 0b111}},
      {{1, 1, 1, 1}, {0.0, 0b1}},  // child 0, negligible: stays a leaf
      {{1, 1, 1, 0}, {1.0, 0b1}},  // child 1, into one child as bad as itself: worth 1 / 2
      {{1, 1, 0, 1}, {3.0, 0}},    // child 2 keeps no child
      {{2, 3, 3, 1}, {1.0, 0b1}},  // child 1's child 0: worth 1 / 2 again
      {{3, 7, 7, 3}, {1.0, 0b1}},  // and its child 0, at the maximum depth 3: stays a leaf
  });
  BuildSettings settings = settingsWith(1000);
  settings.maxDepth = 3;
  const Refined refined = refine(table, settings);
  EXPECT_EQ(refined.splits, (std::vector<CellKey>{{0, 0, 0, 0}, {1, 1, 1, 0}, {2, 3, 3, 1}}));
  EXPECT_EQ(refined.outcome.stoppedBy, "converged");
  EXPECT_EQ(refined.outcome.texels, 2u + 4u + 2u + 2u);
  EXPECT_EQ(refined.outcome.leavesAtMaxDepth, 1u);
  EXPECT_NEAR(refined.outcome.error, 0.0 + 3.0 + 1.0, 1e-12);
}

// A cell's error drawn from a hash of its key: with `levelsApart`, in
// [1, 2) 30^-depth, so that a split of depth d is worth at least
// (1 - 8 * 2 / 30) 30^-d / 9 = 0.052 30^-d per texel and one of depth d + 1
// at most 2 30^-(d+1) / 2 = 0.033 30^-d (and the refinement's rounds, which
// split the leaves evaluated in the round before, split in the plain
// greedy's order); otherwise in [0, 1). Its children: each of the eight
// with probability `keep`.
ErrorTable randomTable(std::uint64_t seed, double keep, bool levelsApart) {
  return [=](const CellKey& key) {
    std::uint64_t h = seed;
    for (const int k : key) h = (h ^ static_cast<std::uint64_t>(k + 1)) * 0x9E3779B97F4A7C15ull;
    std::mt19937_64 rng(h);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    TableEntry entry;
    entry.variation = levelsApart ? (1.0 + unit(rng)) * std::pow(30.0, -key[0]) : unit(rng);
    for (int c = 0; c < 8; ++c)
      if (unit(rng) < keep) entry.children |= static_cast<std::uint8_t>(1u << c);
    return entry;
  };
}

// On random trees whose levels are apart in value, every budget gives the
// plain greedy's splits, in its order, and its stop reason.
TEST(GlobalRefinement, MatchesThePlainGreedyUnderEveryBudget) {
  int budgets = 0, stoppedByBudget = 0;
  for (std::uint64_t seed = 1; seed <= 6; ++seed) {
    const ErrorTable table = randomTable(seed, 0.3, true);
    for (std::uint64_t budget = 2; budget <= 80; budget += 3) {
      BuildSettings settings = settingsWith(budget);
      settings.maxDepth = 4;
      const Refined refined = refine(table, settings);
      const Greedy expected = greedy(table, settings);
      ASSERT_EQ(refined.splits, expected.splits) << "seed " << seed << " budget " << budget;
      EXPECT_EQ(refined.outcome.stoppedBy, expected.stoppedBy) << "seed " << seed << " budget " << budget;
      EXPECT_EQ(refined.outcome.texels, expected.texels) << "seed " << seed << " budget " << budget;
      EXPECT_NEAR(refined.outcome.error, expected.error, 1e-12) << "seed " << seed << " budget " << budget;
      ++budgets;
      stoppedByBudget += expected.stoppedBy == "budget" ? 1 : 0;
    }
  }
  EXPECT_GT(stoppedByBudget, budgets / 2);  // the budget mostly decided
  EXPECT_LT(stoppedByBudget, budgets);      // and some trees converged first
}

// Thousands of leaves (rounds of hundreds, evaluated in batches on the
// other threads): the same splits in the same order on one thread or two.
TEST(GlobalRefinement, SameSplitsOnOneOrTwoThreads) {
  const ErrorTable table = randomTable(99, 0.5, false);
  BuildSettings settings = settingsWith(6000);
  settings.maxDepth = 6;
  const auto run = [&](int threads) {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
    return refine(table, settings);
  };
  const Refined one = run(1), two = run(2);
  EXPECT_GT(one.splits.size(), 500u);
  EXPECT_EQ(one.outcome.stoppedBy, "budget");
  EXPECT_LE(one.outcome.texels, 6000u);
  EXPECT_GT(one.outcome.texels, 6000u - 9u);  // stopped by a split of at most 9 texels
  EXPECT_EQ(one.splits, two.splits);
  EXPECT_EQ(one.outcome.texels, two.outcome.texels);
  EXPECT_EQ(one.outcome.error, two.outcome.error);
}

}  // namespace
}  // namespace apo::octree
