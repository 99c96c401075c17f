// The N^3-tree of GPU Gems 2's chapter 37 built from the APO's octree, its
// validation, and its CPU lookups, which repeat render/'s GLSL walk
// operation for operation (the exactness pass compares them on every pixel).
#include "format/cells.h"
#include "format/format.h"
#include "format/texel_layout.h"

#include <algorithm>
#include <cmath>
#include <unordered_map>

namespace apo {
namespace {

using Rgba = std::array<std::uint8_t, 4>;

constexpr std::uint32_t kMostGridsPerAxis = 256;  // a pointer's coordinate is one byte

Rgba normalCell(const Vec3f& normal, bool coarse, NormalEncoding encoding, std::uint8_t kind) {
  if (coarse) {
    const std::uint32_t code = texel::coarseCode(encoding == NormalEncoding::Xyz8);
    return {static_cast<std::uint8_t>(code & 0xFF), static_cast<std::uint8_t>((code >> 8) & 0xFF),
            static_cast<std::uint8_t>(code >> 16), kind};
  }
  const std::array<std::uint8_t, 3> rgb = encodeNormal(normal, encoding);
  return {rgb[0], rgb[1], rgb[2], kind};
}

// The octree child holding the sub-cell `inNode` (cell coordinates inside
// an N^3 grid, x = 0 lowest) at sub-level `step` of the log2(N) levels a
// grid spans: the bit of each coordinate for that level, lower side = 1.
int childAt(const std::array<std::uint32_t, 3>& inNode, int log2n, int step) {
  const int shift = log2n - 1 - step;
  const auto lower = [&](int axis) { return ((inNode[axis] >> shift) & 1u) == 0; };
  return (lower(0) ? 4 : 0) | (lower(1) ? 2 : 0) | (lower(2) ? 1 : 0);
}

// Builds the grids breadth-first: grid g's cells at g N^3 .. (g + 1) N^3,
// x fastest; its node's average in lod[g].
struct GridBuilder {
  const Octree& octree;
  int n, log2n;
  NormalEncoding encoding;
  std::vector<Rgba> cells, lod;
  std::vector<std::uint32_t> nodeOfGrid;  // octree node of each grid
  std::vector<std::array<Rgba, 2>> sides;
  std::unordered_map<std::uint32_t, std::uint32_t> sideOfLeaf;  // a two-sided leaf covers several cells of N = 4
  bool defersToCoarse = false, coarseAtInternalNodes = false;

  std::uint32_t addGrid(std::uint32_t node) {
    const OctreeNode& at = octree.nodes[node];
    nodeOfGrid.push_back(node);
    lod.push_back(normalCell(at.normal, at.coarseNormal, encoding, N3Tree::kData));
    coarseAtInternalNodes = coarseAtInternalNodes || at.coarseNormal;
    cells.resize(cells.size() + static_cast<std::size_t>(n * n * n), Rgba{0, 0, 0, N3Tree::kEmpty});
    return static_cast<std::uint32_t>(nodeOfGrid.size() - 1);
  }

  Rgba leafCell(std::uint32_t leaf) {
    const OctreeNode& at = octree.nodes[leaf];
    if (!at.twoSided) {
      defersToCoarse = defersToCoarse || at.coarseNormal;
      return normalCell(at.normal, at.coarseNormal, encoding, N3Tree::kData);
    }
    const auto [entry, added] = sideOfLeaf.try_emplace(leaf, static_cast<std::uint32_t>(sides.size()));
    if (added) sides.push_back({normalCell(at.sides[0], false, encoding, 0), normalCell(at.sides[1], false, encoding, 0)});
    const std::uint32_t index = entry->second;
    return {static_cast<std::uint8_t>(index & 0xFF), static_cast<std::uint8_t>((index >> 8) & 0xFF),
            static_cast<std::uint8_t>(index >> 16), static_cast<std::uint8_t>(N3Tree::kTwoSided + at.sideAxis)};
  }

  // Fills grid g's cells; returns the octree nodes that need grids of their
  // own, with the cell that will point to them.
  std::vector<std::pair<std::uint32_t, std::size_t>> fill(std::uint32_t grid) {
    std::vector<std::pair<std::uint32_t, std::size_t>> internal;
    const std::uint32_t un = static_cast<std::uint32_t>(n);
    for (std::uint32_t z = 0; z < un; ++z)
      for (std::uint32_t y = 0; y < un; ++y)
        for (std::uint32_t x = 0; x < un; ++x) {
          const std::size_t at = static_cast<std::size_t>(grid) * un * un * un + (z * un + y) * un + x;
          std::uint32_t node = nodeOfGrid[grid];
          bool missing = false;
          for (int step = 0; step < log2n && !octree.nodes[node].isLeaf(); ++step) {
            const OctreeNode& parent = octree.nodes[node];
            const int child = childAt({x, y, z}, log2n, step);
            if (!cells::hasChild(parent.childMask, child)) {
              missing = true;
              break;
            }
            cells::checkBrood(octree, parent);
            node = cells::childNode(parent, child);
          }
          if (missing) continue;  // empty: the walk shows the grid's average, as the APO's its node's
          if (octree.nodes[node].isLeaf())
            cells[at] = leafCell(node);
          else
            internal.emplace_back(node, at);
        }
    return internal;
  }
};

std::uint32_t ceilDiv(std::uint32_t a, std::uint32_t b) { return (a + b - 1) / b; }

std::array<std::uint32_t, 3> gridPlace(std::uint32_t grid, const std::array<std::uint32_t, 3>& grids) {
  return {grid % grids[0], grid / grids[0] % grids[1], grid / grids[0] / grids[1]};
}

std::uint64_t poolIndex(const N3Tree& tree, const std::array<std::uint32_t, 3>& cell) {
  const std::array<std::uint32_t, 3> size = tree.poolSize();
  return cell[0] + std::uint64_t{size[0]} * (cell[1] + std::uint64_t{size[1]} * cell[2]);
}

std::uint64_t lodIndex(const N3Tree& tree, const std::array<std::uint32_t, 3>& grid) {
  return grid[0] + std::uint64_t{tree.grids[0]} * (grid[1] + std::uint64_t{tree.grids[1]} * grid[2]);
}

void place(N3Tree& tree, const GridBuilder& built) {
  const std::uint32_t un = static_cast<std::uint32_t>(tree.n);
  tree.pool.assign(4 * tree.poolCells(), 0);
  tree.lod.assign(4 * std::uint64_t{tree.grids[0]} * tree.grids[1] * tree.grids[2], 0);
  for (std::uint32_t grid = 0; grid < tree.usedGrids; ++grid) {
    const std::array<std::uint32_t, 3> at = gridPlace(grid, tree.grids);
    std::copy(built.lod[grid].begin(), built.lod[grid].end(), tree.lod.begin() + 4 * lodIndex(tree, at));
    for (std::uint32_t z = 0; z < un; ++z)
      for (std::uint32_t y = 0; y < un; ++y)
        for (std::uint32_t x = 0; x < un; ++x) {
          const Rgba& cell = built.cells[static_cast<std::size_t>(grid) * un * un * un + (z * un + y) * un + x];
          const std::uint64_t to = poolIndex(tree, {at[0] * un + x, at[1] * un + y, at[2] * un + z});
          std::copy(cell.begin(), cell.end(), tree.pool.begin() + 4 * to);
        }
  }
  tree.sides.assign(4 * std::uint64_t{N3Tree::kSidesWidth} * tree.sidesRows(), 0);
  for (std::size_t i = 0; i < built.sides.size(); ++i)
    for (int side = 0; side < 2; ++side)
      std::copy(built.sides[i][side].begin(), built.sides[i][side].end(), tree.sides.begin() + 4 * (2 * i + side));
}

Vec3f decodeCell(const N3Tree& tree, const std::uint8_t* cell, bool mayDeferToCoarse, const Vec3f& coarseNormal, bool& coarse) {
  const std::uint32_t bits = std::uint32_t{cell[0]} | std::uint32_t{cell[1]} << 8 | std::uint32_t{cell[2]} << 16;
  coarse = mayDeferToCoarse && bits == texel::coarseCode(tree.encoding == NormalEncoding::Xyz8);
  return coarse ? coarseNormal : decodeNormal({cell[0], cell[1], cell[2]}, tree.encoding);
}

N3Lookup averageOf(const N3Tree& tree, const std::array<std::uint32_t, 3>& grid, int level, std::uint32_t reads,
                   const Vec3f& coarseNormal) {
  N3Lookup result;
  result.found = true;
  result.average = true;
  result.depth = level * tree.log2n();
  const std::uint64_t index = lodIndex(tree, grid);
  result.place = tree.poolCells() + index;
  result.normal = decodeCell(tree, &tree.lod[4 * index], tree.coarseAtInternalNodes, coarseNormal, result.coarse);
  result.reads = reads + 1;
  return result;
}

}  // namespace

std::string textureLayoutName(TextureLayout layout) { return layout == TextureLayout::N3Tree ? "n3tree" : "apo"; }

std::uint64_t N3Tree::poolCells() const {
  const std::array<std::uint32_t, 3> size = poolSize();
  return std::uint64_t{size[0]} * size[1] * size[2];
}

Result<N3Tree> buildN3Tree(const Octree& octree, int n, NormalEncoding encoding, std::uint32_t maxPoolSide) {
  if (n != 2 && n != 4) return usageError("the N^3-tree's N must be 2 or 4, got {}", n);
  if (octree.nodes.empty()) return usageError("the N^3-tree of an empty octree");
  N3Tree tree;
  tree.n = n;
  tree.transform = octree.transform;
  tree.encoding = encoding;
  GridBuilder built{octree, n, tree.log2n(), encoding, {}, {}, {}, {}, {}};
  built.addGrid(0);
  // Breadth first: a grid's children come after it, level after level.
  std::vector<std::uint32_t> levelOfGrid = {0};
  for (std::uint32_t grid = 0; grid < built.nodeOfGrid.size(); ++grid) {
    for (const auto& [node, cell] : built.fill(grid)) {
      const std::uint32_t child = built.addGrid(node);
      levelOfGrid.push_back(levelOfGrid[grid] + 1);
      // The pointer's place is set once the pool's shape is known; keep the
      // linear grid index for now.
      built.cells[cell] = {static_cast<std::uint8_t>(child & 0xFF), static_cast<std::uint8_t>((child >> 8) & 0xFF),
                           static_cast<std::uint8_t>(child >> 16), N3Tree::kPointer};
      if (child >= kMostGridsPerAxis * kMostGridsPerAxis * kMostGridsPerAxis)
        return usageError("the N^3-tree of N = {} needs more than 256^3 grids (pointers are three bytes)", n);
    }
  }
  tree.usedGrids = static_cast<std::uint32_t>(built.nodeOfGrid.size());
  tree.levels = static_cast<int>(levelOfGrid.back()) + 1;
  tree.grids[0] = std::min(tree.usedGrids, kMostGridsPerAxis);
  tree.grids[1] = std::min(ceilDiv(tree.usedGrids, tree.grids[0]), kMostGridsPerAxis);
  tree.grids[2] = ceilDiv(tree.usedGrids, tree.grids[0] * tree.grids[1]);
  for (const std::uint32_t side : tree.poolSize())
    if (side > maxPoolSide)
      return usageError("the N^3-tree of N = {} needs a pool of {} x {} x {} cells; this renderer takes at most {} per side",
                        n, tree.poolSize()[0], tree.poolSize()[1], tree.poolSize()[2], maxPoolSide);
  // Pointers from linear grid indices to (u, v, w).
  for (Rgba& cell : built.cells) {
    if (cell[3] != N3Tree::kPointer) continue;
    const std::uint32_t grid = std::uint32_t{cell[0]} | std::uint32_t{cell[1]} << 8 | std::uint32_t{cell[2]} << 16;
    const std::array<std::uint32_t, 3> at = gridPlace(grid, tree.grids);
    cell = {static_cast<std::uint8_t>(at[0]), static_cast<std::uint8_t>(at[1]), static_cast<std::uint8_t>(at[2]),
            N3Tree::kPointer};
  }
  tree.twoSidedLeaves = static_cast<std::uint32_t>(built.sides.size());
  tree.defersToCoarse = built.defersToCoarse;
  tree.coarseAtInternalNodes = built.coarseAtInternalNodes;
  place(tree, built);
  return tree;
}

Status validateN3Tree(const N3Tree& tree) {
  if (tree.n != 2 && tree.n != 4) return badInput("N is {}, expected 2 or 4", tree.n);
  for (int axis = 0; axis < 3; ++axis)
    if (tree.grids[axis] == 0 || tree.grids[axis] > kMostGridsPerAxis)
      return badInput("grids per axis {} is {}, expected 1 to 256", axis, tree.grids[axis]);
  const std::uint64_t capacity = std::uint64_t{tree.grids[0]} * tree.grids[1] * tree.grids[2];
  if (tree.usedGrids == 0 || tree.usedGrids > capacity)
    return badInput("{} grids used, expected 1 to the pool's {}", tree.usedGrids, capacity);
  if (tree.pool.size() != 4 * tree.poolCells() || tree.lod.size() != 4 * capacity ||
      tree.sides.size() != 4 * std::uint64_t{N3Tree::kSidesWidth} * tree.sidesRows())
    return badInput("the textures' sizes do not match the pool's shape");
  if (tree.levels < 1 || tree.levels * tree.log2n() > texel::kMaxDepth)
    return badInput("{} levels of N = {}, expected 1 to {} octree levels", tree.levels, tree.n, texel::kMaxDepth);
  const std::uint32_t un = static_cast<std::uint32_t>(tree.n);
  std::vector<int> levelOf(tree.usedGrids, -1);
  levelOf[0] = 0;
  for (std::uint32_t grid = 0; grid < tree.usedGrids; ++grid) {
    if (levelOf[grid] < 0) return badInput("grid {} is not pointed to by any cell (grids are stored breadth first)", grid);
    const std::array<std::uint32_t, 3> at = gridPlace(grid, tree.grids);
    for (std::uint32_t z = 0; z < un; ++z)
      for (std::uint32_t y = 0; y < un; ++y)
        for (std::uint32_t x = 0; x < un; ++x) {
          const std::uint64_t index = poolIndex(tree, {at[0] * un + x, at[1] * un + y, at[2] * un + z});
          const std::uint8_t* cell = &tree.pool[4 * index];
          const std::uint8_t kind = cell[3];
          if (kind == N3Tree::kEmpty || kind == N3Tree::kData) continue;
          if (kind >= N3Tree::kTwoSided && kind <= N3Tree::kTwoSided + 2) {
            const std::uint32_t side = std::uint32_t{cell[0]} | std::uint32_t{cell[1]} << 8 | std::uint32_t{cell[2]} << 16;
            if (side >= tree.twoSidedLeaves)
              return badInput("pool cell {}: two-sided leaf {}, but there are {}", index, side, tree.twoSidedLeaves);
            continue;
          }
          if (kind != N3Tree::kPointer) return badInput("pool cell {}: kind {} (alpha), expected 0, 128, 192 to 194 or 255", index, kind);
          const std::array<std::uint32_t, 3> to = {cell[0], cell[1], cell[2]};
          if (to[0] >= tree.grids[0] || to[1] >= tree.grids[1] || to[2] >= tree.grids[2])
            return badInput("pool cell {}: points to grid ({}, {}, {}) outside the pool's {} x {} x {}", index, to[0], to[1],
                            to[2], tree.grids[0], tree.grids[1], tree.grids[2]);
          const std::uint64_t target = lodIndex(tree, to);
          if (target <= grid || target >= tree.usedGrids)
            return badInput("pool cell {} of grid {}: points to grid {}, expected a later grid below {}", index, grid, target,
                            tree.usedGrids);
          if (levelOf[target] >= 0) return badInput("pool cell {}: grid {} is pointed to twice", index, target);
          levelOf[target] = levelOf[grid] + 1;
          if (levelOf[target] >= tree.levels)
            return badInput("pool cell {}: grid {} is at level {}, the header says {} levels", index, target, levelOf[target],
                            tree.levels);
        }
  }
  return okStatus();
}

N3Lookup lookupN3Tree(const N3Tree& tree, const Vec3f& unitPoint, int maxDepth, const Vec3f& coarseNormal) {
  if (!cells::insideUnitCube(unitPoint) || tree.pool.empty()) return {};
  const auto fn = static_cast<float>(tree.n);
  const std::uint32_t un = static_cast<std::uint32_t>(tree.n);
  const int log2n = tree.log2n();
  std::array<std::uint32_t, 3> grid = {0, 0, 0};
  // P N^(L+1), exact in float (N is a power of two): its cell at each level
  // is ceil(.) - 1, so that a point on a boundary goes to the lower cell
  // as in the APO's walk.
  Vec3f scaled = unitPoint;
  std::uint32_t reads = 0;
  for (int level = 0; level < tree.levels; ++level) {
    if ((level + 1) * log2n > maxDepth) return averageOf(tree, grid, level, reads, coarseNormal);
    scaled *= fn;
    std::array<std::uint32_t, 3> cell{};
    for (int axis = 0; axis < 3; ++axis) {
      const auto global = static_cast<std::int64_t>(std::ceil(scaled[axis])) - 1;
      cell[axis] = grid[axis] * un + (static_cast<std::uint32_t>(std::max<std::int64_t>(global, 0)) & (un - 1));
    }
    const std::uint64_t index = poolIndex(tree, cell);
    const std::uint8_t* value = &tree.pool[4 * index];
    ++reads;
    const std::uint8_t kind = value[3];
    if (kind == N3Tree::kPointer) {
      grid = {value[0], value[1], value[2]};
      continue;
    }
    if (kind == N3Tree::kEmpty) return averageOf(tree, grid, level, reads, coarseNormal);
    N3Lookup result;
    result.found = true;
    result.place = index;
    result.depth = (level + 1) * log2n;
    result.reads = reads;
    if (kind == N3Tree::kData) {
      result.normal = decodeCell(tree, value, tree.defersToCoarse, coarseNormal, result.coarse);
      return result;
    }
    const std::uint32_t leaf = std::uint32_t{value[0]} | std::uint32_t{value[1]} << 8 | std::uint32_t{value[2]} << 16;
    const int side = leafSide(coarseNormal, kind - N3Tree::kTwoSided);
    const std::uint64_t at = 2 * std::uint64_t{leaf} + static_cast<std::uint64_t>(side);
    APO_CHECK_OP(4 * at, <, tree.sides.size());
    result.twoSided = true;
    result.reads = reads + 1;
    result.normal = decodeNormal({tree.sides[4 * at], tree.sides[4 * at + 1], tree.sides[4 * at + 2]}, tree.encoding);
    return result;
  }
  // validateN3Tree: no pointer below the last level.
  APO_CHECK(!"an N^3-tree walk went past its levels");
  return {};
}

N3Lookup lookupN3TreeFiltered(const N3Tree& tree, const Vec3f& unitPoint, const Vec3f& coarseNormal) {
  const N3Lookup own = lookupN3Tree(tree, unitPoint, 255, coarseNormal);
  if (!own.found || own.coarse) return own;
  const Vec3f facing = coarseNormal.squaredNorm() > 0.0f ? coarseNormal : own.normal;
  N3Lookup filtered = own;
  filtered.normal = cells::blendTrilinear(unitPoint, own.depth, own.normal, [&](const Vec3f& at, int depth) -> std::optional<Vec3f> {
    const N3Lookup neighbour = lookupN3Tree(tree, at, depth, coarseNormal);
    if (!cells::entersBlend(neighbour.found, neighbour.depth, neighbour.normal, depth, facing)) return std::nullopt;
    return neighbour.normal;
  });
  return filtered;
}

}  // namespace apo
