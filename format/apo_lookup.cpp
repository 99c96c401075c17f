// The CPU walks of the APO texture: the walk a shader does, operation for
// operation (render/'s GLSL and the exactness check compare the two on every
// pixel), its filtered form (paper 5.3), and the same walk in the in-memory
// octree.
#include "format/cells.h"
#include "format/format.h"
#include "format/texel_layout.h"

#include <algorithm>
#include <cmath>

namespace apo {
namespace {

using namespace cells;
using texel::kEmptyCell;

// Grid coordinate of p in [0, 1] among n cells: ceil(p n) - 1, clamped, so a
// point on a cell boundary goes to the lower cell like childIndex's
// centre-plane rule (p n is exact in float: n is a power of two).
std::uint32_t gridCoordinate(float p, std::uint32_t n) {
  const long cell = std::lround(std::ceil(p * static_cast<float>(n))) - 1;
  return static_cast<std::uint32_t>(std::clamp(cell, 0L, static_cast<long>(n) - 1));
}

void checkTexel(const ApoTexture& texture, std::uint64_t index) {
  APO_CHECK_OP(index, <, texture.usedTexels());
}

Lookup textureResult(const ApoTexture& texture, std::uint64_t node, std::uint64_t normalTexel, int depth,
                     const Vec3f& coarseNormal) {
  checkTexel(texture, normalTexel);
  const bool coarse = texture.defersToCoarse &&
                      texel::rgb24(texture.texels, normalTexel) == texel::coarseCode(texture.encoding == NormalEncoding::Xyz8);
  return {true, coarse ? coarseNormal : decodeNormal(texel::rgb(texture.texels, normalTexel), texture.encoding),
          static_cast<std::uint32_t>(node), depth, coarse};
}

// A two-sided leaf at `node` (version 4): the side m's normal picks.
Lookup twoSidedResult(const ApoTexture& texture, std::uint64_t node, int depth, const Vec3f& coarseNormal) {
  checkTexel(texture, node + 1);
  const int side = leafSide(coarseNormal, texel::alpha(texture.texels, node + 1));
  Lookup result = textureResult(texture, node, node + static_cast<std::uint64_t>(side), depth, Vec3f::Zero());
  result.twoSided = true;
  return result;
}

}  // namespace

Lookup lookupTexture(const ApoTexture& texture, const Vec3f& unitPoint, int maxDepth, const Vec3f& coarseNormal) {
  if (!insideUnitCube(unitPoint)) return {};
  // The grid cell: the entry point of the walk (completeDepth 0: the root).
  const std::uint32_t n = 1u << texture.completeDepth;
  const Cell cell{gridCoordinate(unitPoint.x(), n), gridCoordinate(unitPoint.y(), n),
                  gridCoordinate(unitPoint.z(), n)};
  checkTexel(texture, cellIndex(cell, texture.completeDepth));
  const std::uint32_t entry = texel::rgba32(texture.texels, cellIndex(cell, texture.completeDepth));
  if (entry == kEmptyCell) return {};

  // The walk a shader does, with the same float operations so it can
  // reproduce it bit for bit: cell width 1/n and centre (i + 0.5) / n are
  // exact; childIndex compares P with the centre in float; childCentre moves
  // the centre by +-width/4 and the width halves, both exact in float.
  float width = 1.0f / static_cast<float>(n);
  Vec3f centre((static_cast<float>(cell.x) + 0.5f) * width, (static_cast<float>(cell.y) + 0.5f) * width,
               (static_cast<float>(cell.z) + 0.5f) * width);
  std::uint64_t node = entry;
  int depth = texture.completeDepth;
  bool twoTexels = false;  // the parent's kind bit (grid nodes have none)
  for (;;) {
    checkTexel(texture, node);
    const std::uint8_t childMask = texel::alpha(texture.texels, node);
    if (childMask == 0 && twoTexels) return twoSidedResult(texture, node, depth, coarseNormal);
    if (childMask == 0) return textureResult(texture, node, node, depth, coarseNormal);
    // A maxDepth above the grid stops at the grid's node: the levels above
    // are not stored.
    if (depth >= maxDepth) return textureResult(texture, node, node + 1, depth, coarseNormal);
    const int child = childIndex(centre, unitPoint);
    // No child there: the shader shades with this node's (mean) normal.
    if (!hasChild(childMask, child)) return textureResult(texture, node, node + 1, depth, coarseNormal);
    checkTexel(texture, node + 1);
    const std::uint8_t kindMask = texel::alpha(texture.texels, node + 1);
    std::uint64_t next = node + texel::rgb24(texture.texels, node);
    for (int before = 0; before < child; ++before)
      if (hasChild(childMask, before)) next += texelsOf(hasChild(kindMask, before));
    twoTexels = hasChild(kindMask, child);
    node = next;
    centre = childCentre(centre, width, child);
    width *= 0.5f;
    ++depth;
  }
}

Lookup lookupTextureFiltered(const ApoTexture& texture, const Vec3f& unitPoint, const Vec3f& coarseNormal) {
  const Lookup own = lookupTexture(texture, unitPoint, 255, coarseNormal);
  // A leaf showing m's normal shows it unblended: its neighbours at its
  // depth are cells as large, whose means m beats there.
  if (!own.found || own.coarse) return own;
  const Vec3f facing = coarseNormal.squaredNorm() > 0.0f ? coarseNormal : own.normal;
  Lookup filtered = own;
  // Zero only when every blended cell defers to m and the caller gave none.
  filtered.normal = blendTrilinear(unitPoint, own.depth, own.normal, [&](const Vec3f& at, int depth) -> std::optional<Vec3f> {
    const Lookup neighbour = lookupTexture(texture, at, depth, coarseNormal);
    if (!entersBlend(neighbour.found, neighbour.depth, neighbour.normal, depth, facing)) return std::nullopt;
    return neighbour.normal;
  });
  return filtered;
}

Lookup lookupOctree(const Octree& octree, const Vec3f& unitPoint, int maxDepth, const Vec3f& coarseNormal) {
  if (!insideUnitCube(unitPoint) || octree.nodes.empty()) return {};
  // The same float walk as lookupTexture, from the root; Lookup::texel holds
  // the index of the node in octree.nodes.
  float width = 1.0f;
  Vec3f centre(0.5f, 0.5f, 0.5f);
  std::uint32_t index = 0;
  int depth = 0;
  for (;;) {
    const OctreeNode& node = octree.nodes[index];
    if (node.isLeaf() && node.twoSided)
      return {true, node.sides[leafSide(coarseNormal, node.sideAxis)], index, depth, false, true};
    const Lookup stop{true, node.coarseNormal ? coarseNormal : node.normal, index, depth, node.coarseNormal};
    if (node.isLeaf() || depth >= maxDepth) return stop;
    const int child = childIndex(centre, unitPoint);
    if (!hasChild(node.childMask, child)) return stop;
    checkBrood(octree, node);
    index = childNode(node, child);
    centre = childCentre(centre, width, child);
    width *= 0.5f;
    ++depth;
  }
}

}  // namespace apo
