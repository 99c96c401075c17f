// The global refinement's parts that do not depend on the evaluator
// (refinement.h): the split queue, the leaves that finished, the texel count
// and the breadth-first renumbering.
#include "bake/refinement.h"

#include <bit>
#include <numeric>

namespace apo::octree {
namespace {

constexpr std::uint32_t kNotALeaf = ~0u;

// Moves nodes[order[i]] to nodes[i] for every i, along the permutation's
// cycles: a second array of the nodes would be fresh memory, whose zeroing
// by the kernel took most of the renumbering's 0.1 s on the 1.2M bunny.
void permuteInPlace(std::vector<OctreeNode>& nodes, const std::vector<std::uint32_t>& order) {
  std::vector<bool> placed(nodes.size(), false);
  for (std::size_t start = 0; start < nodes.size(); ++start) {
    if (placed[start]) continue;
    const OctreeNode first = nodes[start];
    std::size_t at = start;
    for (;;) {
      placed[at] = true;
      const std::size_t from = order[at];
      if (from == start) break;
      nodes[at] = nodes[from];
      at = from;
    }
    nodes[at] = first;
  }
}

}  // namespace

void SplitQueue::push(const QueueEntry& entry) {
  std::size_t at = heap_.size();
  heap_.push_back(entry);
  while (at > 0) {
    const std::size_t parent = (at - 1) / kArity;
    if (!QueueEntry::after(heap_[parent], entry)) break;
    heap_[at] = heap_[parent];
    at = parent;
  }
  heap_[at] = entry;
}

QueueEntry SplitQueue::pop() {
  const QueueEntry top = heap_.front();
  const QueueEntry last = heap_.back();
  heap_.pop_back();
  const std::size_t n = heap_.size();
  if (n == 0) return top;
  std::size_t at = 0;
  for (;;) {
    const std::size_t first = kArity * at + 1;
    if (first >= n) break;
    std::size_t best = first;
    for (std::size_t c = first + 1; c < std::min(first + kArity, n); ++c)
      if (QueueEntry::after(heap_[best], heap_[c])) best = c;
    if (!QueueEntry::after(last, heap_[best])) break;
    heap_[at] = heap_[best];
    at = best;
  }
  heap_[at] = last;
  return top;
}

std::uint64_t texelsOf(const std::vector<OctreeNode>& nodes, int completeDepth) {
  std::uint64_t texels = std::uint64_t{1} << (3 * completeDepth);
  for (const OctreeNode& node : nodes)
    if (node.depth >= completeDepth) texels += node.isLeaf() ? 1 : 2;
  return texels;
}

std::vector<std::uint32_t> renumberBreadthFirst(std::vector<OctreeNode>& nodes) {
  std::vector<std::uint32_t> order = {0};  // old numbers, in the new order
  order.reserve(nodes.size());
  for (std::size_t i = 0; i < order.size(); ++i) {
    const OctreeNode& node = nodes[order[i]];
    for (int k = 0; k < std::popcount(static_cast<unsigned>(node.childMask)); ++k)
      order.push_back(node.firstChild + static_cast<std::uint32_t>(k));
  }
  std::vector<std::uint32_t> newNumber(nodes.size());
  for (std::size_t i = 0; i < order.size(); ++i) newNumber[order[i]] = static_cast<std::uint32_t>(i);
  permuteInPlace(nodes, order);
  tbb::parallel_for(std::size_t{0}, nodes.size(), [&](std::size_t i) {
    if (!nodes[i].isLeaf()) nodes[i].firstChild = newNumber[nodes[i].firstChild];
  });
  return newNumber;
}

std::size_t roundSize(std::size_t queued, bool budgeted) {
  if (!budgeted) return queued;
  return std::max<std::size_t>(256, queued / 16);
}

void FinishedLeaves::add(Leaf&& leaf, RefinementOutcome& outcome) {
  count(summaryOf(leaf), outcome);
  records_.push_back({leaf.node, std::move(leaf.triangles), leaf.error.showsCoarse(), leaf.error.showsTwoSides(),
                      static_cast<std::uint8_t>(leaf.error.sideAxis)});
}


void FinishedLeaves::addInPlace(std::vector<Leaf*> leaves, RefinementOutcome& outcome) {
  const auto summaries = std::make_unique_for_overwrite<Summary[]>(leaves.size());  // its pages touched in parallel
  tbb::parallel_for(std::size_t{0}, leaves.size(), [&](std::size_t i) { summaries[i] = summaryOf(*leaves[i]); });
  for (std::size_t i = 0; i < leaves.size(); ++i) count(summaries[i], outcome);
  inPlace_ = std::move(leaves);
}


void FinishedLeaves::layOut(const std::vector<std::uint32_t>& newNumber, BuiltOctree& built) {
  std::vector<std::uint32_t> leafOf(newNumber.size(), kNotALeaf);
  std::vector<std::uint64_t>& begin = built.leafTriangleBegin;
  begin.assign(newNumber.size() + 1, 0);
  tbb::parallel_for(std::size_t{0}, leaves(), [&](std::size_t i) {
    const std::uint32_t n = newNumber[nodeOf(i)];
    leafOf[n] = static_cast<std::uint32_t>(i);
    begin[n + 1] = trianglesOf(i).size();
  });
  std::partial_sum(begin.begin(), begin.end(), begin.begin());
  built.leafTriangles.resize(begin.back());
  tbb::parallel_for(std::size_t{0}, newNumber.size(), [&](std::size_t n) {
    if (leafOf[n] == kNotALeaf) return;
    const std::size_t i = leafOf[n];
    OctreeNode& node = built.octree.nodes[n];
    if (i < records_.size()) {
      node.coarseNormal = records_[i].showsCoarse;
      node.twoSided = records_[i].twoSided;
      node.sideAxis = records_[i].sideAxis;
    } else {
      const LeafError& error = inPlace_[i - records_.size()]->error;
      node.coarseNormal = error.showsCoarse();
      node.twoSided = error.showsTwoSides();
      node.sideAxis = static_cast<std::uint8_t>(error.sideAxis);
    }
    CoarseIdList& triangles = trianglesOf(i);
    std::copy(triangles.begin(), triangles.end(), built.leafTriangles.begin() + static_cast<std::ptrdiff_t>(begin[n]));
    CoarseIdList().swap(triangles);
  });
}

FinishedLeaves::Summary FinishedLeaves::summaryOf(const Leaf& leaf) const {
  return {leaf.error.shown(), leaf.error.area, leaf.error.showsCoarse(), leaf.error.showsTwoSides(),
          leaf.cell.depth >= maxDepth_};
}
void FinishedLeaves::count(const Summary& summary, RefinementOutcome& outcome) {
  outcome.error += summary.shown;
  outcome.area += summary.area;
  outcome.leavesShowingCoarse += summary.showsCoarse ? 1 : 0;
  outcome.twoSidedLeaves += summary.twoSided ? 1 : 0;
  outcome.leavesAtMaxDepth += summary.atMaxDepth ? 1 : 0;
}

}  // namespace apo::octree
