// Inside bake: the global refinement of the octree below its coarse levels
// (docs/bake.md, "Refinement"): the leaves' splits, evaluated ahead, made in
// order of the error they remove per texel until the texel budget is spent,
// no split helps, or every leaf is within the paper's threshold. The splits
// are chosen in rounds and evaluated in parallel; the tree does not depend
// on the thread count. What a split gives comes from an evaluator
// (LeafEvaluator): the L2,1 metric in the bake, a table in the tests.
#pragma once

#include "bake/cell_clip.h"
#include "bake/l21_metric.h"
#include "bake/octree_build.h"

#include <boost/container/small_vector.hpp>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/scalable_allocator.h>
#include <tbb/task_group.h>

#include <algorithm>
#include <atomic>
#include <concepts>
#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

namespace apo::octree {

// A leaf's list of m's triangles, held in the leaf up to two: 96% of the
// 1.2M bunny's leaves hold one or two, and their lists' allocations were
// most of the evaluations' (docs/benchmarks.md).
using CoarseIdList = boost::container::small_vector<std::uint32_t, 2, tbb::scalable_allocator<std::uint32_t>>;

// Records fetched this many ahead of their use in a list.
inline constexpr std::size_t kPrefetchAhead = 8;

// A leaf of the growing tree with m's and M's primitives in its cell. The
// refinement reads its node, cell, error and kept children, and lays out
// m's triangles; M's lists are the evaluator's alone (a test's leaves leave
// them empty).
struct Leaf {
  std::uint32_t node = 0;
  Cell cell;
  CoarseIdList triangles;  // m's
  IdList primitives;       // M's triangles (M a mesh), at or below the sum depth
  const FineSums* fine = nullptr;  // M's triangles' sums (M a mesh), above the sum depth
  KeyRun fineRun;
  KeyRun points;  // M's points (M points)
  LeafError error;
  // Children its split would keep (those holding some of m): counted when
  // the leaf is made, as it is cheap (m's few triangles), to bound the
  // split's value per texel before M is clipped into them.
  int keptChildren = 1;
};

// A leaf and what splitting it would give: its kept children, evaluated.
struct Candidate {
  Leaf leaf;
  std::uint8_t mask = 0;
  // In increasing child index; made on the evaluating threads and freed on
  // the main one, as the leaves' lists are (IdList).
  std::vector<Leaf, tbb::scalable_allocator<Leaf>> children;
  double gain = 0.0;           // L2,1 removed by the split
  double largestChildError = 0.0;

  // The leaf's 1 or 2 texels become an internal node's 2, plus the children's.
  std::uint64_t texels() const {
    std::uint64_t texels = 2 - leaf.error.texels();
    for (const Leaf& child : children) texels += child.error.texels();
    return texels;
  }
  // What the split is worth: the error it removes, or, when it removes
  // little because M's part stays in one child (m crosses a corner of the
  // cell, M lies along one side), the error it opens to the next split.
  // Ranked by the gain alone, such cells would never split, though the
  // threshold rule of the paper splits them (measured on bunny00 at 3 MiB:
  // by the gain, 0.252 degrees mean filtered, 0.722 p95; by the gain but
  // opening single children, 0.213 / 0.657; by this value, 0.196 / 0.598,
  // though its total L2,1 is a few percent above the paper's rule's at
  // equal texels: the filtered lookup gains most where M's normal turns
  // sharply in a part of the cell, which this value finds first).
  double value() const { return std::max(gain, largestChildError); }
  double valuePerTexel() const { return value() / static_cast<double>(texels()); }
  // A split worth making: some of m below, and worth something.
  bool worthSplitting() const { return mask != 0 && value() > 0.0; }
};

// A candidate's record (its leaf, its children's list), fetched ahead of
// its use.
inline void prefetchCandidate(const Candidate& candidate) {
  const char* bytes = reinterpret_cast<const char*>(&candidate);
  for (std::size_t offset = 0; offset < sizeof(Candidate); offset += 64) __builtin_prefetch(bytes + offset);
}

// A queued candidate's place in the splitting order, kept beside its index so
// that ordering the queue reads no candidate: the most value per texel
// first, then the node index (deterministic ties).
// 16 bytes: four to a cache line.
struct QueueEntry {
  double valuePerTexel = 0.0;  // unevaluated: an upper bound
  std::uint32_t node = 0;
  std::uint32_t slot = 0;  // the candidate's slot, and kEvaluated

  static constexpr std::uint32_t kEvaluated = 1u << 31;
  bool evaluated() const { return (slot & kEvaluated) != 0; }
  std::uint32_t candidate() const { return slot & ~kEvaluated; }

  // The queue's order: true when `a` comes after `b`.
  static bool after(const QueueEntry& a, const QueueEntry& b) {
    if (a.valuePerTexel != b.valuePerTexel) return a.valuePerTexel < b.valuePerTexel;
    return a.node > b.node;
  }
};

// The candidates in splitting order: a heap with four children to a node.
// A round pops and pushes hundreds of thousands of entries on one thread
// while the other core waits; a binary heap of them (std::push_heap) spent
// twice the levels, each a cache miss (docs/benchmarks.md).
class SplitQueue {
 public:
  bool empty() const { return heap_.empty(); }
  std::size_t size() const { return heap_.size(); }
  const QueueEntry& top() const { return heap_.front(); }
  // In no particular order.
  const std::vector<QueueEntry>& entries() const { return heap_; }
  void clear() { heap_.clear(); }

  void push(const QueueEntry& entry);
  QueueEntry pop();

 private:
  static constexpr std::size_t kArity = 4;
  std::vector<QueueEntry> heap_;
};

// Texels the encoding of the octree as it stands takes: the completion grid,
// then 1 per leaf and 2 per internal node at or below the completion depth.
std::uint64_t texelsOf(const std::vector<OctreeNode>& nodes, int completeDepth);

// Renumbers the nodes breadth first from the root (each brood contiguous, in
// child order, as before); returns the new number of each old node.
std::vector<std::uint32_t> renumberBreadthFirst(std::vector<OctreeNode>& nodes);

// Leaves evaluated per task while a round goes on (GlobalRefinement::round).
inline constexpr std::size_t kEvaluationBatch = 16;

// Candidates expanded per round: enough to keep both cores busy, few enough
// that the order stays close to one split at a time.
std::size_t roundSize(std::size_t queued, bool budgeted);

// Leaves that will not split: m's triangles of each (for the sampling) kept
// in the leaf's own list until the layout, and their errors summed as they
// come. (Copying every list into one array as leaves finished, then again
// into the layout, left the second core idle for 0.1 s at the end of the
// 1.2M bunny's build.)
class FinishedLeaves {
 public:
  // `leavesAtMost`: a bound of the leaves to come (0: none known), so that
  // the records are never copied into larger fresh memory as they come.
  FinishedLeaves(int maxDepth, std::size_t leavesAtMost) : maxDepth_(maxDepth) { records_.reserve(leavesAtMost); }

  void add(Leaf&& leaf, RefinementOutcome& outcome);

  // The leaves still queued when the refinement stops (a third of the
  // bunny's), left where they are until the layout: moved into records one
  // by one, on one core, they took 70 ms of the 1.2M bunny's build, mostly
  // cache misses on the candidates' slots. Read on every core, and summed in
  // their order, as `add` would have.
  void addInPlace(std::vector<Leaf*> leaves, RefinementOutcome& outcome);

  // The CSR of m's triangles per node, nodes renumbered by `newNumber`, and
  // the leaves that show m's normals marked; each leaf's list copied and
  // freed in parallel.
  void layOut(const std::vector<std::uint32_t>& newNumber, BuiltOctree& built);

 private:
  struct Record {
    std::uint32_t node;
    CoarseIdList triangles;
    bool showsCoarse, twoSided;
    std::uint8_t sideAxis;
  };
  // What a leaf adds to the outcome. No initializers: made for overwrite.
  struct Summary {
    double shown, area;
    bool showsCoarse, twoSided, atMaxDepth;
  };

  Summary summaryOf(const Leaf& leaf) const;
  static void count(const Summary& summary, RefinementOutcome& outcome);

  // Leaf i: the records, then the leaves left in place.
  std::size_t leaves() const { return records_.size() + inPlace_.size(); }
  std::uint32_t nodeOf(std::size_t i) const {
    return i < records_.size() ? records_[i].node : inPlace_[i - records_.size()]->node;
  }
  CoarseIdList& trianglesOf(std::size_t i) {
    return i < records_.size() ? records_[i].triangles : inPlace_[i - records_.size()]->triangles;
  }

  int maxDepth_;
  std::vector<Record> records_;
  std::vector<Leaf*> inPlace_;
};

// The candidates' slots, in blocks of 4,096: growing the store moves no
// candidate (the leaves left queued are read through their addresses at the
// end), and finding a slot reads a table of a few hundred blocks, where
// std::deque's blocks of 512 bytes held two candidates each, and its table
// of blocks missed the cache on its own.
class CandidateSlots {
 public:
  std::size_t size() const { return size_; }
  Candidate& operator[](std::size_t i) { return blocks_[i >> kShift][i & kMask]; }
  Candidate& emplace_back() {
    if ((size_ & kMask) == 0) blocks_.push_back(std::make_unique<Candidate[]>(kBlock));
    return (*this)[size_++];
  }

 private:
  static constexpr std::size_t kShift = 12, kBlock = std::size_t{1} << kShift, kMask = kBlock - 1;
  std::vector<std::unique_ptr<Candidate[]>> blocks_;
  std::size_t size_ = 0;
};

// What the refinement asks of the metric, resolved at compile time (the
// bake's evaluator, octree_build.cpp, clips M into the children; a test's
// reads a table of errors):
//   Scratch                  each evaluating thread's own scratch;
//   prepare(leaves)          the coarse cells' leaves made ready, each one's
//                            error set (run once, before any split);
//   keptChildrenOf(leaf)     how many children a split would keep (a bound
//                            of the split's texels, taken before evaluating);
//   split(leaf, candidate, scratch)
//                            the kept children into candidate.children (in
//                            increasing child index, with their cells and
//                            errors) and their bits into candidate.mask;
//                            none where no child is kept. Called on several
//                            threads at once;
//   release()                frees what only the splitting needed.
template <class Evaluator>
concept LeafEvaluator = requires(Evaluator& evaluator, const Evaluator& reader, std::vector<Leaf>& leaves,
                                 const Leaf& leaf, Leaf& splitting, Candidate& candidate,
                                 typename Evaluator::Scratch& scratch) {
  evaluator.prepare(leaves);
  { reader.keptChildrenOf(leaf) } -> std::convertible_to<int>;
  reader.split(splitting, candidate, scratch);
  evaluator.release();
};

// The global refinement (docs/bake.md, "Refinement"). Leaves that may split
// are queued unevaluated (by an upper bound of their split's value per
// texel) or evaluated (by the value itself). A leaf reaching the top
// unevaluated is evaluated and queued again, so only leaves near the top are
// ever clipped into children (a lazy greedy). `nodes` holds the tree above
// the leaves given to `start`; splits append their children to it, in the
// order they are made.
template <LeafEvaluator Evaluator>
class GlobalRefinement {
 public:
  GlobalRefinement(Evaluator& evaluator, const BuildSettings& settings, std::vector<OctreeNode>& nodes,
                   RefinementOutcome& outcome)
      : evaluator_(evaluator), settings_(settings), nodes_(nodes), outcome_(outcome),
        finished_(settings.maxDepth, settings.budgetTexels) {}

  // The coarse cells' leaves, made ready and their errors computed by the
  // evaluator, then queued or finished. `outcome.texels` counts their
  // nodes, as one texel each.
  void start(std::vector<Leaf> leaves) {
    evaluator_.prepare(leaves);
    tbb::parallel_for(std::size_t{0}, leaves.size(), [&](std::size_t i) {
      if (mayRefine(leaves[i])) leaves[i].keptChildren = evaluator_.keptChildrenOf(leaves[i]);
    });
    for (const Leaf& leaf : leaves) outcome_.texels += leaf.error.texels() - 1;
    for (Leaf& leaf : leaves) file(std::move(leaf));
  }

  // Splits until the budget is spent or no leaf may split; sets
  // outcome.stoppedBy.
  void run() {
    const bool budgeted = settings_.budgetTexels > 0;
    // The coarse levels alone may exceed the budget: then nothing splits.
    bool budgetReached = budgeted && outcome_.texels > settings_.budgetTexels;
    while (!queue_.empty() && !budgetReached) budgetReached = round(budgeted);
    std::vector<Leaf*> left;
    left.reserve(queue_.size());
    for (const QueueEntry& entry : queue_.entries()) left.push_back(&slots_[entry.candidate()].leaf);
    finished_.addInPlace(std::move(left), outcome_);
    queue_.clear();
    outcome_.stoppedBy = budgetReached ? "budget" : settings_.error > 0.0 ? "error" : "converged";
  }

  // What only the splitting needed (the evaluator's, the splits evaluated
  // but not made), freed while the nodes are renumbered: a tenth of the
  // 1.2M bunny's build, freed after the layout on one core.
  void releaseSplitState() {
    evaluator_.release();
    toEvaluate_ = {};
    evaluating_ = {};
    tbb::parallel_for(std::size_t{0}, slots_.size(), [&](std::size_t i) {
      decltype(Candidate::children)().swap(slots_[i].children);
      IdList().swap(slots_[i].leaf.primitives);
    });
  }

  // The leaves' lists of m's triangles laid out (FinishedLeaves::layOut).
  void layOut(const std::vector<std::uint32_t>& newNumber, BuiltOctree& built) { finished_.layOut(newNumber, built); }

  // Whether the leaf may split at all (before its split is evaluated).
  bool mayRefine(const Leaf& leaf) const {
    if (leaf.cell.depth >= settings_.maxDepth || leaf.error.negligible()) return false;
    return !(settings_.error > 0.0) || leaf.error.variation > settings_.error;
  }

 private:
  // The leaf's split as the evaluator gives it, valued: the kept children's
  // bounds for their own splits (only a leaf that may split is queued), the
  // error the split removes and the largest child's.
  Candidate evaluate(Leaf leaf, typename Evaluator::Scratch& scratch) const {
    Candidate candidate;
    evaluator_.split(leaf, candidate, scratch);
    if (candidate.mask != 0) {
      double childError = 0.0;
      for (Leaf& child : candidate.children) {
        if (mayRefine(child)) child.keptChildren = evaluator_.keptChildrenOf(child);
        childError += child.error.ranked();
        candidate.largestChildError = std::max(candidate.largestChildError, child.error.ranked());
      }
      candidate.gain = leaf.error.ranked() - childError;
    }
    candidate.leaf = std::move(leaf);
    return candidate;
  }

  // A round: the top entries; evaluated ones split (while the budget lasts),
  // unevaluated ones are evaluated together, in parallel. Returns whether
  // the budget ran out.
  bool round(bool budgeted) {
    const std::size_t count = roundSize(queue_.size(), budgeted);
    // The leaves to evaluate are evaluated on the other cores as they come,
    // in batches, while this thread goes on popping and splitting (done
    // after the pops, the evaluation left the second core idle for a fifth
    // of the 1.2M bunny's build). Each is evaluated in its slot, through an
    // address taken here (the slots' store may grow meanwhile), and read
    // only after the wait: the round is the same on any number of threads.
    // In place, this thread moves no candidate in and out of the slots for
    // them (bunny build -3%).
    std::vector<std::uint32_t>& toEvaluate = toEvaluate_;
    std::vector<Candidate*>& evaluating = evaluating_;
    toEvaluate.clear();
    evaluating.clear();
    tbb::task_group evaluations;
    // Set once the budget is spent: the round is the last, and the leaves
    // popped for evaluation stay leaves whatever their split would give, so
    // the batches not yet begun are skipped (the 1.2M bunny's last round
    // sent 4,520 leaves to be evaluated in vain).
    std::atomic<bool> lastRound{false};
    std::size_t batched = 0;
    const auto evaluateFrom = [&](std::size_t end) {
      evaluations.run([this, candidates = evaluating.data(), first = batched, end, &lastRound] {
        typename Evaluator::Scratch& scratch = scratch_.local();
        for (std::size_t i = first; i < end && !lastRound.load(std::memory_order_relaxed); ++i) {
          Candidate& candidate = *candidates[i];
          candidate = evaluate(std::move(candidate.leaf), scratch);
        }
      });
      batched = end;
    };
    // Reserved: no batch may see the addresses move.
    evaluating.reserve(count);
    bool budgetReached = false;
    for (std::size_t k = 0; k < count && !queue_.empty(); ++k) {
      const QueueEntry entry = queue_.pop();
      // The next entry's candidate fetched while this one is handled: the
      // slots are read in the queue's order, a cache miss each (this
      // thread's pops, takes and splits took 0.3 s of the 1.2M bunny's
      // build, while one core evaluated; build 1.252 -> 1.219 s).
      if (!queue_.empty()) prefetchCandidate(slots_[queue_.top().candidate()]);
      if (!entry.evaluated()) {
        toEvaluate.push_back(entry.candidate());
        evaluating.push_back(&slots_[entry.candidate()]);
        if (evaluating.size() - batched == kEvaluationBatch) evaluateFrom(evaluating.size());
        continue;
      }
      const std::uint32_t slot = entry.candidate();
      Candidate& candidate = slots_[slot];
      if (budgeted && outcome_.texels + candidate.texels() > settings_.budgetTexels) {
        // Less than one split's texels (at most 9) are left: stop here.
        finished_.add(std::move(candidate.leaf), outcome_);
        freeSlots_.push_back(slot);
        budgetReached = true;
        lastRound.store(true, std::memory_order_relaxed);
        break;
      }
      split(slot);
    }
    if (!budgetReached && batched < evaluating.size()) evaluateFrom(evaluating.size());
    evaluations.wait();
    if (budgetReached) {
      // Evaluated or not (which depends on the threads' timing), each goes
      // back as it came: the leaves left, and their order, do not depend on
      // which were.
      for (const std::uint32_t slot : toEvaluate) queueSlot(slot, false);
      return true;
    }
    for (std::size_t i = 0; i < toEvaluate.size(); ++i) {
      // Written by the evaluating threads: fetched ahead into this one's cache.
      if (i + kPrefetchAhead < toEvaluate.size()) prefetchCandidate(*evaluating[i + kPrefetchAhead]);
      const std::uint32_t slot = toEvaluate[i];
      if (slots_[slot].worthSplitting()) {
        queueSlot(slot, true);
      } else {
        finished_.add(std::move(slots_[slot].leaf), outcome_);
        freeSlots_.push_back(slot);
      }
    }
    return budgetReached;
  }

  // The candidate in `slot` split: its children into the tree and the
  // queue, the first of them into its slot, still in cache.
  void split(std::uint32_t slot) {
    Candidate& candidate = slots_[slot];
    outcome_.texels += candidate.texels();
    OctreeNode& parent = nodes_[candidate.leaf.node];
    parent.firstChild = static_cast<std::uint32_t>(nodes_.size());
    parent.childMask = candidate.mask;
    auto children = std::move(candidate.children);
    freeSlots_.push_back(slot);
    // The slots the other children will take (last freed, first taken),
    // fetched ahead.
    for (std::size_t k = 1; k < children.size() && k < freeSlots_.size(); ++k)
      prefetchCandidate(slots_[freeSlots_[freeSlots_.size() - 1 - k]]);
    for (Leaf& child : children) {
      child.node = static_cast<std::uint32_t>(nodes_.size());
      OctreeNode node;
      node.depth = static_cast<std::uint8_t>(child.cell.depth);
      nodes_.push_back(node);
      file(std::move(child));
    }
  }

  void file(Leaf leaf) {
    if (!mayRefine(leaf)) {
      finished_.add(std::move(leaf), outcome_);
      return;
    }
    queueSlot(put(std::move(leaf)), false);
  }

  void queueSlot(std::uint32_t slot, bool evaluated) {
    const Candidate& candidate = slots_[slot];
    const LeafError& error = candidate.leaf.error;
    // Unevaluated: a split is worth at most the leaf's one-normal L2,1 (its
    // gain, or a child's error) and adds at least 1 texel per kept child and
    // 1 for the node (none to a two-sided leaf), so that ratio bounds its
    // key, and the first evaluated entry on top is the best split of all
    // (the greedy order; rounds of many entries stay close to it). Guesses
    // tighter than a bound (the parent's ratio) evaluated half as many
    // leaves but lost 2-4% of the accuracy on bunny00.
    const int texelsAtLeast = 2 - static_cast<int>(error.texels()) + std::max(1, candidate.leaf.keptChildren);
    const double key = evaluated ? candidate.valuePerTexel() : error.variation / static_cast<double>(texelsAtLeast);
    const std::uint32_t node = candidate.leaf.node;
    queue_.push({key, node, slot | (evaluated ? QueueEntry::kEvaluated : 0u)});
  }

  // Candidates live in reused slots: the queue holds only their keys.
  std::uint32_t put(Leaf leaf) {
    if (freeSlots_.empty()) {
      slots_.emplace_back().leaf = std::move(leaf);
      return static_cast<std::uint32_t>(slots_.size() - 1);
    }
    const std::uint32_t slot = freeSlots_.back();
    freeSlots_.pop_back();
    // Written in place: the slot holds what its last candidate left.
    Candidate& candidate = slots_[slot];
    candidate.leaf = std::move(leaf);
    candidate.mask = 0;
    decltype(Candidate::children)().swap(candidate.children);
    candidate.gain = candidate.largestChildError = 0.0;
    return slot;
  }

  Evaluator& evaluator_;
  const BuildSettings& settings_;
  std::vector<OctreeNode>& nodes_;
  RefinementOutcome& outcome_;
  FinishedLeaves finished_;
  CandidateSlots slots_;
  std::vector<std::uint32_t> freeSlots_;
  SplitQueue queue_;
  // A round's leaves to evaluate: their slots and addresses; kept from round
  // to round, as fresh memory for each cost the kernel's zeroing of its pages.
  std::vector<std::uint32_t> toEvaluate_;
  std::vector<Candidate*> evaluating_;
  tbb::enumerable_thread_specific<typename Evaluator::Scratch> scratch_;  // the evaluations', per thread
};

}  // namespace apo::octree
