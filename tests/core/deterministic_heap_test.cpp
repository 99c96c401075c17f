// The deterministic heap: the same allocations get addresses in the same
// order whatever malloc's heap looked like before, and memory crosses the
// scope's bounds safely both ways.
#include "core/deterministic_heap.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <list>
#include <memory>
#include <random>
#include <thread>
#include <vector>

namespace apo {
namespace {

// malloc's heap left in a state of its own: blocks the size of a list node
// (glibc reuses freed blocks last in, first out) and of many other sizes,
// two of every three freed in the order they were made; the rest are kept
// until the returned holder dies.
std::vector<std::unique_ptr<char[]>> fragmentHeap(unsigned seed) {
  std::mt19937 random(seed);
  std::vector<std::unique_ptr<char[]>> blocks, kept;
  for (int i = 0; i < 20000; ++i) blocks.push_back(std::make_unique<char[]>(i % 2 == 0 ? 24 : 16 + random() % 200));
  for (std::size_t i = 0; i < blocks.size(); ++i) {
    if (i % 3 == 0)
      kept.push_back(std::move(blocks[i]));
    else
      blocks[i].reset();
  }
  return kept;
}

// Where list nodes land, as ranks: node i's rank among all nodes' addresses
// (std::list nodes are separate allocations, as CGAL's edge records are).
std::vector<std::size_t> addressRanksOfListNodes() {
  std::list<std::uint64_t> nodes;
  for (std::uint64_t i = 0; i < 5000; ++i) {
    nodes.push_back(i);
    if (i % 3 == 0) nodes.pop_front();  // frees, so that later nodes reuse blocks
  }
  std::vector<std::pair<std::uintptr_t, std::uint64_t>> byAddress;
  for (const std::uint64_t& value : nodes) byAddress.emplace_back(reinterpret_cast<std::uintptr_t>(&value), value);
  std::sort(byAddress.begin(), byAddress.end());
  std::vector<std::size_t> ranks;
  for (const auto& entry : byAddress) ranks.push_back(entry.second);
  return ranks;
}

TEST(DeterministicHeap, GivesTheSameAddressOrderWhateverTheHeapBefore) {
  const auto first = madeInDeterministicHeap(addressRanksOfListNodes);
  const auto holder = fragmentHeap(7);
  const auto second = madeInDeterministicHeap(addressRanksOfListNodes);
  EXPECT_EQ(first, second);
}

TEST(DeterministicHeap, WithoutAScopeTheOrderFollowsMallocsHeap) {
  // The point of the scope: the same sequence outside it lands in an order
  // set by what the heap held (if this ever passes by luck of the allocator,
  // the test above proves nothing).
  const auto before = addressRanksOfListNodes();
  const auto holder = fragmentHeap(11);
  const auto after = addressRanksOfListNodes();
  EXPECT_NE(before, after);
}

TEST(DeterministicHeap, MemoryCrossesTheScopesBoundsBothWays) {
  auto fromMalloc = std::make_unique<std::vector<int>>(1000, 1);
  std::unique_ptr<std::vector<int>> fromScope;
  {
    DeterministicHeapScope scope;
    ASSERT_TRUE(scope.active());
    fromScope = std::make_unique<std::vector<int>>(1000, 2);
    fromMalloc.reset();  // malloc's memory freed inside the scope
    // A nested scope takes a region of its own and gives it back.
    DeterministicHeapScope nested;
    EXPECT_TRUE(nested.active());
    std::vector<double> inner(100, 3.0);
    EXPECT_EQ(inner.back(), 3.0);
  }
  // The region's memory outlives the scope, readable, and freed after it.
  EXPECT_EQ(fromScope->at(999), 2);
  std::thread other([&] { fromScope.reset(); });  // freed from another thread
  other.join();
  // Both regions were given back: four scopes open at once still succeed.
  DeterministicHeapScope a, b, c, d;
  EXPECT_TRUE(a.active() && b.active() && c.active() && d.active());
}

TEST(DeterministicHeap, LargeBlocksAreUsableWholeAndReused) {
  const auto addresses = madeInDeterministicHeap([] {
    std::vector<std::uintptr_t> seen;
    for (int round = 0; round < 3; ++round) {
      std::vector<std::uint8_t> big(std::size_t{100} << 20, 0xAB);  // 100 MiB, written through
      EXPECT_EQ(big.front(), 0xAB);
      EXPECT_EQ(big.back(), 0xAB);
      seen.push_back(reinterpret_cast<std::uintptr_t>(big.data()));
    }
    return seen;
  });
  ASSERT_EQ(addresses.size(), 3u);
  EXPECT_EQ(addresses[0], addresses[1]);  // the freed block is taken again
  EXPECT_EQ(addresses[1], addresses[2]);
}

}  // namespace
}  // namespace apo
