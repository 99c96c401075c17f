// The octree as a 2D RGBA8 texture (Lacoste et al. 2007, section 4) with the
// octree completion of section 6 turned into a dense grid of entry points.
// docs/apo-format.md is the reference for the layout.
#include "format/cells.h"
#include "format/format.h"
#include "format/texel_layout.h"

#include <algorithm>
#include <bit>

namespace apo {
namespace {

using namespace cells;
using texel::kEmptyCell;

Status checkEncodeSettings(int completeDepth, int coarseDepth, int maxDepth) {
  if (completeDepth < 0 || completeDepth > texel::kMaxCompleteDepth)
    return usageError("--complete-depth {} is out of range: it must be between 0 and {} (the grid has "
                      "8^depth entries)",
                      completeDepth, texel::kMaxCompleteDepth);
  if (maxDepth > texel::kMaxDepth)
    return usageError("--max-depth {} exceeds {}, the deepest level the APO format stores", maxDepth,
                      texel::kMaxDepth);
  if (coarseDepth > maxDepth)
    return usageError("the coarse depth {} exceeds --max-depth {}", coarseDepth, maxDepth);
  if (completeDepth > coarseDepth)
    return usageError("--complete-depth {} must not exceed the coarse depth {}: only the levels above the coarse "
                      "depth are sure to be complete",
                      completeDepth, coarseDepth);
  return okStatus();
}

// For each grid cell, the octree node at depth completeDepth covering it
// (kNoNode when the cell is empty). Usage error when a node above that depth
// is a leaf: the grid would have no node to point at below it.
Result<std::vector<std::uint32_t>> gridNodes(const Octree& octree, int completeDepth) {
  struct Visit {
    std::uint32_t node;
    int depth;
    Cell cell;
  };
  std::vector<std::uint32_t> grid(std::size_t{1} << (3 * completeDepth), kNoNode);
  std::vector<Visit> stack{{0, 0, Cell{}}};
  while (!stack.empty()) {
    const Visit visit = stack.back();
    stack.pop_back();
    if (visit.depth == completeDepth) {
      grid[cellIndex(visit.cell, visit.depth)] = visit.node;
      continue;
    }
    const OctreeNode& node = octree.nodes[visit.node];
    if (node.isLeaf())
      return usageError("--complete-depth {}: node {} at depth {} (cell {}, {}, {}) is a leaf, but every node above "
                        "the completion depth must be internal (the bake's octree is complete only down to its "
                        "coarse depth)",
                        completeDepth, visit.node, visit.depth, visit.cell.x, visit.cell.y, visit.cell.z);
    checkBrood(octree, node);
    for (int child = 0; child < 8; ++child)
      if (hasChild(node.childMask, child))
        stack.push_back({childNode(node, child), visit.depth + 1, childCell(visit.cell, child)});
  }
  return grid;
}

void putTexel(std::vector<std::uint8_t>& texels, std::uint64_t index, const std::array<std::uint8_t, 3>& rgb,
              std::uint8_t alpha) {
  std::copy(rgb.begin(), rgb.end(), texels.begin() + static_cast<std::ptrdiff_t>(4 * index));
  texels[4 * index + 3] = alpha;
}

// Little-endian bytes of a grid entry or (low 3 bytes) a brood offset.
std::array<std::uint8_t, 4> littleEndian(std::uint32_t value) {
  return {static_cast<std::uint8_t>(value), static_cast<std::uint8_t>(value >> 8),
          static_cast<std::uint8_t>(value >> 16), static_cast<std::uint8_t>(value >> 24)};
}

bool takesTwoTexels(const OctreeNode& node) { return !node.isLeaf() || node.twoSided; }

std::uint8_t kindMaskOf(const Octree& octree, const OctreeNode& node) {
  std::uint8_t kind = 0;
  for (int child = 0; child < 8; ++child)
    if (hasChild(node.childMask, child) && takesTwoTexels(octree.nodes[childNode(node, child)]))
      kind |= static_cast<std::uint8_t>(1u << child);
  return kind;
}

// The code of every node's normal (encodeNormal), made ahead of the layout,
// which is serial: through `parallel` when given. On one core the codes took
// 45 ms of the 1.2M bunny's 66 ms encoding (docs/benchmarks.md).
std::vector<std::array<std::uint8_t, 3>> normalCodes(const Octree& octree, NormalEncoding encoding,
                                                     const ParallelRanges& parallel) {
  std::vector<std::array<std::uint8_t, 3>> codes(octree.nodes.size());
  const auto encodeRange = [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) codes[i] = encodeNormal(octree.nodes[i].normal, encoding);
  };
  if (parallel)
    parallel(codes.size(), encodeRange);
  else
    encodeRange(0, codes.size());
  return codes;
}

// A node waiting for its texels, in breadth-first order.
struct Pending {
  std::uint32_t node;
  std::uint64_t texel;
  int depth;
};

// Breadth-first emission of the forest below the grid: queue[k] is the k-th
// node in texture order; each node's children are appended, contiguous, when
// it is written, so its brood offset is known then.
class ForestEncoder {
 public:
  // `texture` has its settings set; nodes start after its grid. `codes`:
  // each node's normal encoded (normalCodes).
  ForestEncoder(const Octree& octree, const ApoTexture& texture, const std::vector<std::array<std::uint8_t, 3>>& codes)
      : octree_(octree), texture_(texture), codes_(codes), next_(texture.gridTexels()) {}

  // Queues a grid node; returns its texel.
  Result<std::uint64_t> queueGridNode(std::uint32_t node) {
    return queue(node, texture_.completeDepth);
  }

  // Writes every queued node (and so every node below the grid).
  Status writeAll(std::vector<std::uint8_t>& texels) {
    for (std::size_t k = 0; k < queue_.size(); ++k) {
      const Pending item = queue_[k];  // a copy: writing the node grows the queue
      APO_RETURN_IF_ERROR(writeNode(item, texels));
    }
    return okStatus();
  }

  std::uint64_t usedTexels() const { return next_; }
  std::uint64_t leaves() const { return leaves_; }
  std::uint64_t internalNodes() const { return internal_; }
  std::uint64_t twoSidedLeaves() const { return twoSided_; }

 private:
  Result<std::uint64_t> queue(std::uint32_t node, int depth) {
    const OctreeNode& octreeNode = octree_.nodes[node];
    APO_CHECK_OP(int{octreeNode.depth}, ==, depth);
    if (depth > texture_.maxDepth)
      return internalError("octree node {} is at depth {}, deeper than the max depth {} of the bake", node, depth,
                           int{texture_.maxDepth});
    if (octreeNode.isLeaf() && octreeNode.twoSided && depth <= texture_.completeDepth)
      return internalError("octree node {} is a two-sided leaf at the completion depth {}: no parent's kind bit "
                           "would say it takes two texels",
                           node, depth);
    if (octreeNode.isLeaf() && octreeNode.twoSided && octreeNode.sideAxis > 2)
      return internalError("octree node {} is a two-sided leaf on axis {} (expected 0, 1 or 2)", node,
                           int{octreeNode.sideAxis});
    const std::uint64_t size = texelsOf(takesTwoTexels(octreeNode));
    if (next_ + size > texel::kMaxUsedTexels)
      return usageError("the octree needs more than {} texels, the most a 32-bit texel index can address; lower "
                        "--max-depth or raise --error",
                        texel::kMaxUsedTexels);
    queue_.push_back({node, next_, depth});
    (octreeNode.isLeaf() ? leaves_ : internal_) += 1;
    twoSided_ += octreeNode.isLeaf() && octreeNode.twoSided ? 1 : 0;
    next_ += size;
    return queue_.back().texel;
  }

  Status writeNode(const Pending& item, std::vector<std::uint8_t>& texels) {
    const OctreeNode& node = octree_.nodes[item.node];
    const std::array<std::uint8_t, 3>& normal = codes_[item.node];
    if (node.isLeaf() && node.twoSided) {
      // sides[0] where the child mask of a leaf (0) is, sides[1] and the axis
      // in the second texel (docs/apo-format.md, "Two-sided leaves").
      grow(texels);
      putTexel(texels, item.texel, encodeNormal(node.sides[0], texture_.encoding), 0);
      putTexel(texels, item.texel + 1, encodeNormal(node.sides[1], texture_.encoding), node.sideAxis);
      return okStatus();
    }
    if (node.isLeaf()) {
      grow(texels);
      putTexel(texels, item.texel, node.coarseNormal ? coarseBytes() : normal, 0);
      return okStatus();
    }
    checkBrood(octree_, node);
    const std::uint64_t brood = next_;
    for (int child = 0; child < 8; ++child)
      if (hasChild(node.childMask, child)) APO_RETURN_IF_ERROR(queue(childNode(node, child), item.depth + 1));
    const Result<std::uint32_t> offset = texel::broodOffset(item.texel, brood);
    if (!offset.ok()) return offset.error();
    const std::array<std::uint8_t, 4> offsetBytes = littleEndian(*offset);
    grow(texels);
    putTexel(texels, item.texel, {offsetBytes[0], offsetBytes[1], offsetBytes[2]}, node.childMask);
    putTexel(texels, item.texel + 1, node.coarseNormal ? coarseBytes() : normal, kindMaskOf(octree_, node));
    return okStatus();
  }

  std::array<std::uint8_t, 3> coarseBytes() const {
    const std::uint32_t code = texel::coarseCode(texture_.encoding == NormalEncoding::Xyz8);
    return {static_cast<std::uint8_t>(code & 0xFF), static_cast<std::uint8_t>((code >> 8) & 0xFF),
            static_cast<std::uint8_t>(code >> 16)};
  }

  // Room for every texel assigned so far.
  void grow(std::vector<std::uint8_t>& texels) const {
    if (texels.size() < 4 * next_) texels.resize(4 * next_, 0);
  }

  const Octree& octree_;
  const ApoTexture& texture_;
  const std::vector<std::array<std::uint8_t, 3>>& codes_;
  std::vector<Pending> queue_;
  std::uint64_t next_;
  std::uint64_t leaves_ = 0, internal_ = 0, twoSided_ = 0;
};

}  // namespace

Result<ApoTexture> encodeApo(const Octree& octree, int completeDepth, NormalEncoding encoding,
                             std::uint8_t coarseDepth, std::uint8_t maxDepth, const ParallelRanges& parallel) {
  APO_RETURN_IF_ERROR(checkEncodeSettings(completeDepth, coarseDepth, maxDepth));
  if (octree.nodes.empty()) return internalError("encodeApo: the octree has no root node");
  const Result<std::vector<std::uint32_t>> grid = gridNodes(octree, completeDepth);
  if (!grid.ok()) return grid.error();

  ApoTexture texture;
  texture.transform = octree.transform;
  texture.coarseDepth = coarseDepth;
  texture.maxDepth = maxDepth;
  texture.completeDepth = static_cast<std::uint8_t>(completeDepth);
  texture.encoding = encoding;
  // Nodes above the grid are not stored: their marks do not count.
  const auto shownCoarse = [&](const OctreeNode& node) { return node.coarseNormal && node.depth >= completeDepth; };
  texture.defersToCoarse = std::any_of(octree.nodes.begin(), octree.nodes.end(), shownCoarse);
  texture.coarseAtInternalNodes = std::any_of(octree.nodes.begin(), octree.nodes.end(), [&](const OctreeNode& node) {
    return !node.isLeaf() && shownCoarse(node);
  });
  // Grid entries of empty cells stay kEmptyCell.
  texture.texels.assign(4 * texture.gridTexels(), 0xFF);

  const std::vector<std::array<std::uint8_t, 3>> codes = normalCodes(octree, encoding, parallel);
  ForestEncoder encoder(octree, texture, codes);
  for (std::uint64_t cell = 0; cell < grid->size(); ++cell) {
    if ((*grid)[cell] == kNoNode) continue;
    const Result<std::uint64_t> at = encoder.queueGridNode((*grid)[cell]);
    if (!at.ok()) return at.error();
    const std::array<std::uint8_t, 4> entry = littleEndian(static_cast<std::uint32_t>(*at));
    putTexel(texture.texels, cell, {entry[0], entry[1], entry[2]}, entry[3]);
  }
  APO_RETURN_IF_ERROR(encoder.writeAll(texture.texels));

  texture.leafNodes = encoder.leaves();
  texture.internalNodes = encoder.internalNodes();
  texture.twoSidedLeaves = encoder.twoSidedLeaves();
  // Version 4 files are version 3 files with two-sided leaves or internal
  // nodes showing m: a reader takes the code of m's normal as such in both.
  texture.defersToCoarse = texture.defersToCoarse || texture.twoSidedLeaves > 0;
  const std::uint64_t used = encoder.usedTexels();
  APO_CHECK_OP(used, ==, texture.usedTexels());
  texture.width = texel::textureWidthFor(used);
  texture.height = static_cast<std::uint32_t>(texel::rowsFor(used, texture.width));
  texture.texels.resize(4 * std::uint64_t{texture.width} * texture.height, 0);
  return texture;
}

}  // namespace apo
