// Internal to format/: integer cells of the octree's levels and the child
// conventions over plain octree nodes, shared by the encoder, the decoder and
// the CPU lookups (texel_layout.h holds the byte layout itself).
#pragma once

#include "format/format.h"

#include <bit>
#include <cstdint>

namespace apo::cells {

inline constexpr std::uint32_t kNoNode = OctreeNode::kNoChild;

// Integer coordinates of a cell among the 2^depth cells per axis of its
// depth; x = 0 is the lowest x.
struct Cell {
  std::uint32_t x = 0, y = 0, z = 0;
};

// Child c's bit for an axis is 1 on the lower side (format.h childIndex).
inline Cell childCell(const Cell& cell, int child) {
  auto along = [child](std::uint32_t parent, int bit) { return 2 * parent + (((child >> bit) & 1) ? 0u : 1u); };
  return {along(cell.x, 2), along(cell.y, 1), along(cell.z, 0)};
}

inline Cell parentCell(const Cell& cell) { return {cell.x / 2, cell.y / 2, cell.z / 2}; }

inline std::uint64_t cellIndex(const Cell& cell, int depth) {
  const std::uint64_t n = std::uint64_t{1} << depth;
  return (cell.x * n + cell.y) * n + cell.z;
}

inline Cell cellOfIndex(std::uint64_t index, int depth) {
  const std::uint64_t mask = (std::uint64_t{1} << depth) - 1;
  return {static_cast<std::uint32_t>((index >> (2 * depth)) & mask),
          static_cast<std::uint32_t>((index >> depth) & mask), static_cast<std::uint32_t>(index & mask)};
}

inline bool hasChild(std::uint8_t childMask, int child) { return (childMask >> child) & 1; }

// Number of existing children before child c: its place in the brood.
inline int childrenBefore(std::uint8_t childMask, int child) {
  return std::popcount(static_cast<unsigned>(childMask & ((1u << child) - 1)));
}

// Octree node index of existing child c of `node`.
inline std::uint32_t childNode(const OctreeNode& node, int child) {
  return node.firstChild + static_cast<std::uint32_t>(childrenBefore(node.childMask, child));
}

// Texels of a node: two for an internal node or a two-sided leaf (the
// parent's kind bit), one for a leaf.
inline std::uint64_t texelsOf(bool twoTexels) { return twoTexels ? 2 : 1; }

// The brood of an internal node lies inside the octree.
inline void checkBrood(const Octree& octree, const OctreeNode& node) {
  APO_CHECK(node.firstChild != kNoNode);
  APO_CHECK_OP(std::uint64_t{node.firstChild} + std::popcount(static_cast<unsigned>(node.childMask)), <=,
               octree.nodes.size());
}

}  // namespace apo::cells
