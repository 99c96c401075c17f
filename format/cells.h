// Internal to format/: integer cells of the octree's levels and the child
// conventions over plain octree nodes, shared by the encoder, the decoder and
// the CPU lookups (texel_layout.h holds the byte layout itself).
#pragma once

#include "format/format.h"

#include <bit>
#include <cstdint>
#include <optional>

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

// Written so NaN coordinates are outside too.
inline bool insideUnitCube(const Vec3f& p) { return (p.array() >= 0.0f).all() && (p.array() <= 1.0f).all(); }

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

// Paper 5.3's blend, shared by the filtered lookups of both layouts, in the
// shaders' float operations: lattice coordinates of P among the cell centres
// of `ownDepth`, the 8 corners around it, trilinear weights. `neighbourAt`
// (a cell centre, the depth) gives the normal a corner contributes, or
// nothing when it does not enter the blend (the corner then takes
// `ownNormal`). Zero when every weight lands on zero normals.
template <class NeighbourAt>
Vec3f blendTrilinear(const Vec3f& unitPoint, int ownDepth, const Vec3f& ownNormal, NeighbourAt neighbourAt) {
  const float width = 1.0f / static_cast<float>(1u << ownDepth);
  const Eigen::Array3f lattice = unitPoint.array() / width - 0.5f;
  const Eigen::Array3f base = lattice.floor();
  const Eigen::Array3f t = lattice - base;
  Vec3f sum = Vec3f::Zero();
  for (int corner = 0; corner < 8; ++corner) {
    const Eigen::Array3f c((corner >> 2) & 1, (corner >> 1) & 1, corner & 1);
    const Eigen::Array3f weight3 = (1.0f - t) * (1.0f - c) + t * c;
    const std::optional<Vec3f> neighbour = neighbourAt(Vec3f(((base + c + 0.5f) * width).matrix()), ownDepth);
    sum += weight3.prod() * neighbour.value_or(ownNormal);
  }
  return sum.squaredNorm() > 0.0f ? Vec3f(sum.normalized()) : Vec3f(Vec3f::Zero());
}

// A neighbour's normal enters the blend when its walk reaches P's depth or
// stops one level above; a coarser leaf's mean describes a region too far
// from P (measured: docs/benchmarks.md, "Filtering"), a missing one nothing.
// It must also face the side P is on (`facing`: m's normal at P, or P's own
// cell's normal without m): across a part thinner than a cell, the next cell
// holds the other side (measured on blade.off: 8.6 degrees mean filtered
// against 1.5 unfiltered before this rule).
inline bool entersBlend(bool found, int depth, const Vec3f& normal, int ownDepth, const Vec3f& facing) {
  return found && depth + 1 >= ownDepth && normal.dot(facing) > 0.0f;
}

}  // namespace apo::cells
