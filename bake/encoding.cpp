// The octree as a 2D RGBA8 texture (Lacoste et al. 2007, section 4) with the
// octree completion of section 6 turned into a dense grid of entry points:
// the encoder, the decoder (which is also the structural validator of every
// texture read from disk) and the two lookups that tests compare.
// docs/apo-format.md is the reference for the layout.
#include "bake/bake.h"
#include "bake/texel_layout.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <optional>

namespace apo {

// ---- Layout helpers shared with apo_file.cpp (texel_layout.h) --------------

namespace texel {

std::uint32_t textureWidthFor(std::uint64_t usedTexels) {
  // Smallest 2^K, K >= 1, with (2^K)^2 >= used: K = ceil(log2(sqrt(used)))
  // in integers, so no rounding of a floating-point log decides the width.
  std::uint64_t width = 2;
  while (width < kMaxWidth && width * width < usedTexels) width *= 2;
  return static_cast<std::uint32_t>(width);
}

Result<std::uint32_t> broodOffset(std::uint64_t nodeTexel, std::uint64_t broodTexel) {
  APO_CHECK_OP(broodTexel, >, nodeTexel);
  const std::uint64_t offset = broodTexel - nodeTexel;
  if (offset > kMaxBroodOffset)
    return usageError(
        "the internal node at texel {} has its children at texel {}: the offset {} does not fit the 24 bits "
        "of the APO layout (at most {}); the octree is too large, lower --max-depth or raise --error",
        nodeTexel, broodTexel, offset, kMaxBroodOffset);
  return static_cast<std::uint32_t>(offset);
}

}  // namespace texel

namespace {

using texel::kEmptyCell;
constexpr std::uint32_t kNoNode = OctreeNode::kNoChild;

// ---- Cells and children ----------------------------------------------------

// Integer coordinates of a cell among the 2^depth cells per axis of its
// depth; x = 0 is the lowest x.
struct Cell {
  std::uint32_t x = 0, y = 0, z = 0;
};

// Child c's bit for an axis is 1 on the lower side (bake.h childIndex).
Cell childCell(const Cell& cell, int child) {
  auto along = [child](std::uint32_t parent, int bit) { return 2 * parent + (((child >> bit) & 1) ? 0u : 1u); };
  return {along(cell.x, 2), along(cell.y, 1), along(cell.z, 0)};
}

Cell parentCell(const Cell& cell) { return {cell.x / 2, cell.y / 2, cell.z / 2}; }

std::uint64_t cellIndex(const Cell& cell, int depth) {
  const std::uint64_t n = std::uint64_t{1} << depth;
  return (cell.x * n + cell.y) * n + cell.z;
}

Cell cellOfIndex(std::uint64_t index, int depth) {
  const std::uint64_t mask = (std::uint64_t{1} << depth) - 1;
  return {static_cast<std::uint32_t>((index >> (2 * depth)) & mask),
          static_cast<std::uint32_t>((index >> depth) & mask), static_cast<std::uint32_t>(index & mask)};
}

bool hasChild(std::uint8_t childMask, int child) { return (childMask >> child) & 1; }

// Number of existing children before child c: its place in the brood.
int childrenBefore(std::uint8_t childMask, int child) {
  return std::popcount(static_cast<unsigned>(childMask & ((1u << child) - 1)));
}

// Octree node index of existing child c of `node`.
std::uint32_t childNode(const OctreeNode& node, int child) {
  return node.firstChild + static_cast<std::uint32_t>(childrenBefore(node.childMask, child));
}

std::uint64_t texelsOf(bool internal) { return internal ? 2 : 1; }

// ---- Encoding ---------------------------------------------------------------

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

void checkBrood(const Octree& octree, const OctreeNode& node) {
  APO_CHECK(node.firstChild != kNoNode);
  APO_CHECK_OP(std::uint64_t{node.firstChild} + std::popcount(static_cast<unsigned>(node.childMask)), <=,
               octree.nodes.size());
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

std::uint8_t kindMaskOf(const Octree& octree, const OctreeNode& node) {
  std::uint8_t kind = 0;
  for (int child = 0; child < 8; ++child)
    if (hasChild(node.childMask, child) && !octree.nodes[childNode(node, child)].isLeaf())
      kind |= static_cast<std::uint8_t>(1u << child);
  return kind;
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
  // `texture` has its settings set; nodes start after its grid.
  ForestEncoder(const Octree& octree, const ApoTexture& texture)
      : octree_(octree), texture_(texture), next_(texture.gridTexels()) {}

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

 private:
  Result<std::uint64_t> queue(std::uint32_t node, int depth) {
    const OctreeNode& octreeNode = octree_.nodes[node];
    APO_CHECK_OP(int{octreeNode.depth}, ==, depth);
    if (depth > texture_.maxDepth)
      return internalError("octree node {} is at depth {}, deeper than the max depth {} of the bake", node, depth,
                           int{texture_.maxDepth});
    const std::uint64_t size = texelsOf(!octreeNode.isLeaf());
    if (next_ + size > texel::kMaxUsedTexels)
      return usageError("the octree needs more than {} texels, the most a 32-bit texel index can address; lower "
                        "--max-depth or raise --error",
                        texel::kMaxUsedTexels);
    queue_.push_back({node, next_, depth});
    (octreeNode.isLeaf() ? leaves_ : internal_) += 1;
    next_ += size;
    return queue_.back().texel;
  }

  Status writeNode(const Pending& item, std::vector<std::uint8_t>& texels) {
    const OctreeNode& node = octree_.nodes[item.node];
    const std::array<std::uint8_t, 3> normal = encodeNormal(node.normal, texture_.encoding);
    if (node.isLeaf()) {
      grow(texels);
      putTexel(texels, item.texel, normal, 0);
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
    putTexel(texels, item.texel + 1, normal, kindMaskOf(octree_, node));
    return okStatus();
  }

  // Room for every texel assigned so far.
  void grow(std::vector<std::uint8_t>& texels) const {
    if (texels.size() < 4 * next_) texels.resize(4 * next_, 0);
  }

  const Octree& octree_;
  const ApoTexture& texture_;
  std::vector<Pending> queue_;
  std::uint64_t next_;
  std::uint64_t leaves_ = 0, internal_ = 0;
};

// ---- Decoding and validation ------------------------------------------------

// A node of the texture's forest as the validator found it.
struct ForestNode {
  std::uint8_t childMask = 0, kindMask = 0;
  std::array<std::uint8_t, 3> normal{};
  std::uint32_t firstChild = kNoNode;  // index in Forest::nodes
  int depth = 0;
};

struct Forest {
  std::vector<std::uint32_t> gridNode;  // per grid cell: index in nodes, or kNoNode
  std::vector<ForestNode> nodes;        // texture order
};

Status checkTextureFields(const ApoTexture& texture) {
  if (texture.completeDepth > texel::kMaxCompleteDepth || texture.maxDepth > texel::kMaxDepth ||
      texture.coarseDepth > texture.maxDepth || texture.completeDepth > texture.coarseDepth)
    return badInput("depths out of range: coarse {}, max {}, complete {} (need complete <= min({}, coarse), "
                    "coarse <= max <= {})",
                    int{texture.coarseDepth}, int{texture.maxDepth}, int{texture.completeDepth},
                    texel::kMaxCompleteDepth, texel::kMaxDepth);
  if (texture.encoding != NormalEncoding::Xyz8 && texture.encoding != NormalEncoding::Oct24)
    return badInput("unknown normal encoding {}", static_cast<int>(texture.encoding));
  const std::uint64_t texels = std::uint64_t{texture.width} * texture.height;
  if (texture.texels.size() != 4 * texels)
    return badInput("{} bytes of texels for a {} x {} texture (expected {})", texture.texels.size(), texture.width,
                    texture.height, 4 * texels);
  // Each count alone first, so their sum cannot overflow.
  if (texture.leafNodes > texels || texture.internalNodes > texels || texture.usedTexels() > texels)
    return badInput("{} leaves and {} internal nodes after a grid of {} texels do not fit the {} texels of the "
                    "texture",
                    texture.leafNodes, texture.internalNodes, texture.gridTexels(), texels);
  return okStatus();
}

// Walks the texture in the order the encoder wrote it, checking that it is
// exactly that layout: each grid entry and brood offset points at the next
// unread texel, kinds agree with child masks, the nodes end at usedTexels()
// and the padding is zero. So offsets stay inside the used texels, each node
// is read once and every lookup terminates.
class ForestReader {
 public:
  explicit ForestReader(const ApoTexture& texture)
      : texture_(texture), used_(texture.usedTexels()), next_(texture.gridTexels()) {}

  Result<Forest> read() {
    APO_RETURN_IF_ERROR(readGrid());
    for (std::size_t k = 0; k < forest_.nodes.size(); ++k) APO_RETURN_IF_ERROR(readBrood(k));
    APO_RETURN_IF_ERROR(checkEnd());
    return std::move(forest_);
  }

 private:
  Status readGrid() {
    const std::uint64_t cells = texture_.gridTexels();
    forest_.gridNode.assign(cells, kNoNode);
    for (std::uint64_t cell = 0; cell < cells; ++cell) {
      const std::uint32_t entry = texel::rgba32(texture_.texels, cell);
      if (entry == kEmptyCell) continue;
      if (entry != next_) {
        const Cell at = cellOfIndex(cell, texture_.completeDepth);
        return badInput("texel {}: the grid entry of cell ({}, {}, {}) points to texel {}, expected {} (the next "
                        "node in breadth-first order)",
                        cell, at.x, at.y, at.z, entry, next_);
      }
      forest_.gridNode[cell] = static_cast<std::uint32_t>(forest_.nodes.size());
      APO_RETURN_IF_ERROR(readNode(texture_.completeDepth, std::nullopt));
    }
    if (forest_.nodes.empty()) return badInput("every grid cell is empty: the texture holds no node");
    return okStatus();
  }

  // Reads the node at next_; `expectInternal` is the parent's kind bit.
  Status readNode(int depth, std::optional<bool> expectInternal) {
    if (next_ >= used_)
      return badInput("texel {}: a node starts past the {} used texels", next_, used_);
    if (depth > texture_.maxDepth)
      return badInput("texel {}: a node at depth {}, deeper than the max depth {}", next_, depth,
                      int{texture_.maxDepth});
    ForestNode node;
    node.depth = depth;
    node.childMask = texel::alpha(texture_.texels, next_);
    const bool internal = node.childMask != 0;
    if (expectInternal && *expectInternal != internal)
      return badInput("texel {}: its parent's kind mask says {}, but its child mask is {:#04x}", next_,
                      *expectInternal ? "internal node" : "leaf", node.childMask);
    if (internal && next_ + 2 > used_)
      return badInput("texel {}: an internal node's second texel is past the {} used texels", next_, used_);
    node.normal = texel::rgb(texture_.texels, internal ? next_ + 1 : next_);
    if (internal) node.kindMask = texel::alpha(texture_.texels, next_ + 1);
    if (node.kindMask & ~node.childMask)
      return badInput("texel {}: kind mask {:#04x} marks children absent from the child mask {:#04x}", next_ + 1,
                      node.kindMask, node.childMask);
    texels_.push_back(next_);
    forest_.nodes.push_back(node);
    next_ += texelsOf(internal);
    (internal ? internal_ : leaves_) += 1;
    return okStatus();
  }

  Status readBrood(std::size_t index) {
    const ForestNode node = forest_.nodes[index];  // a copy: reading the brood grows the list
    if (node.childMask == 0) return okStatus();
    const std::uint64_t at = texels_[index];
    const std::uint64_t brood = at + texel::rgb24(texture_.texels, at);
    if (brood != next_)
      return badInput("texel {}: the offset {} to the children points to texel {}, expected {} (the next node in "
                      "breadth-first order)",
                      at, brood - at, brood, next_);
    forest_.nodes[index].firstChild = static_cast<std::uint32_t>(forest_.nodes.size());
    for (int child = 0; child < 8; ++child)
      if (hasChild(node.childMask, child)) APO_RETURN_IF_ERROR(readNode(node.depth + 1, hasChild(node.kindMask, child)));
    return okStatus();
  }

  Status checkEnd() const {
    if (next_ != used_ || leaves_ != texture_.leafNodes || internal_ != texture_.internalNodes)
      return badInput("the nodes end at texel {} with {} leaves and {} internal nodes, but the texture counts {} "
                      "used texels, {} leaves and {} internal nodes",
                      next_, leaves_, internal_, used_, texture_.leafNodes, texture_.internalNodes);
    const auto padding = texture_.texels.begin() + static_cast<std::ptrdiff_t>(4 * used_);
    const auto nonZero = std::find_if(padding, texture_.texels.end(), [](std::uint8_t b) { return b != 0; });
    if (nonZero != texture_.texels.end())
      return badInput("texel {}: the unused texels after the {} used ones must be zero",
                      static_cast<std::uint64_t>(nonZero - texture_.texels.begin()) / 4, used_);
    return okStatus();
  }

  const ApoTexture& texture_;
  const std::uint64_t used_;
  std::uint64_t next_;
  std::uint64_t leaves_ = 0, internal_ = 0;
  Forest forest_;
  std::vector<std::uint64_t> texels_;  // first texel of each node of forest_
};

// Which cells of each level above the grid hold some non-empty grid cell.
std::vector<std::vector<bool>> upperOccupancy(const Forest& forest, int completeDepth) {
  std::vector<std::vector<bool>> occupied(static_cast<std::size_t>(completeDepth));
  for (int depth = 0; depth < completeDepth; ++depth) occupied[depth].assign(std::size_t{1} << (3 * depth), false);
  for (std::uint64_t index = 0; index < forest.gridNode.size(); ++index) {
    if (forest.gridNode[index] == kNoNode) continue;
    Cell cell = cellOfIndex(index, completeDepth);
    for (int depth = completeDepth - 1; depth >= 0; --depth) {
      cell = parentCell(cell);
      occupied[depth][cellIndex(cell, depth)] = true;
    }
  }
  return occupied;
}

// Rebuilds the Octree breadth-first from the root: above the grid, complete
// internal levels made from the occupancy; from the grid down, the forest.
class OctreeBuilder {
 public:
  OctreeBuilder(const ApoTexture& texture, const Forest& forest)
      : texture_(texture), forest_(forest), occupied_(upperOccupancy(forest, texture.completeDepth)) {}

  Octree build() {
    Octree octree;
    octree.transform = texture_.transform;
    const int grid = texture_.completeDepth;
    add(grid == 0 ? Source{Cell{}, 0, forest_.gridNode[0]} : Source{Cell{}, 0, kNoNode}, octree);
    for (std::size_t k = 0; k < sources_.size(); ++k) {
      const Source source = sources_[k];
      const std::vector<Source> children = childrenOf(source);
      if (!children.empty()) octree.nodes[k].firstChild = static_cast<std::uint32_t>(octree.nodes.size());
      for (const Source& child : children) add(child, octree);
    }
    return octree;
  }

 private:
  // A node to create: a cell above the grid (forestNode == kNoNode) or a
  // node of the forest.
  struct Source {
    Cell cell;
    int depth;
    std::uint32_t forestNode;
  };

  std::vector<Source> childrenOf(const Source& source) const {
    std::vector<Source> children;
    if (source.forestNode != kNoNode) {
      const ForestNode& node = forest_.nodes[source.forestNode];
      std::uint32_t next = node.firstChild;
      for (int child = 0; child < 8; ++child)
        if (hasChild(node.childMask, child)) children.push_back({Cell{}, source.depth + 1, next++});
      return children;
    }
    const int depth = source.depth + 1;
    for (int child = 0; child < 8; ++child) {
      const Cell cell = childCell(source.cell, child);
      const std::uint64_t index = cellIndex(cell, depth);
      if (depth == texture_.completeDepth) {
        if (forest_.gridNode[index] != kNoNode) children.push_back({cell, depth, forest_.gridNode[index]});
      } else if (occupied_[depth][index]) {
        children.push_back({cell, depth, kNoNode});
      }
    }
    return children;
  }

  // Appends the node of `source`; its childMask is known now, its
  // firstChild once its turn in the breadth-first loop comes.
  void add(const Source& source, Octree& octree) {
    OctreeNode node;
    node.depth = static_cast<std::uint8_t>(source.depth);
    if (source.forestNode != kNoNode) {
      const ForestNode& forestNode = forest_.nodes[source.forestNode];
      node.normal = decodeNormal(forestNode.normal, texture_.encoding);
      node.childMask = forestNode.childMask;
    } else {
      for (const Source& child : childrenOf(source))
        node.childMask |= static_cast<std::uint8_t>(1u << childIndexOf(source.cell, child.cell));
    }
    octree.nodes.push_back(node);
    sources_.push_back(source);
  }

  // Inverse of childCell.
  static int childIndexOf(const Cell& parent, const Cell& child) {
    auto bit = [](std::uint32_t p, std::uint32_t c) { return c == 2 * p ? 1 : 0; };
    return bit(parent.x, child.x) << 2 | bit(parent.y, child.y) << 1 | bit(parent.z, child.z);
  }

  const ApoTexture& texture_;
  const Forest& forest_;
  const std::vector<std::vector<bool>> occupied_;
  std::vector<Source> sources_;  // sources_[k] made octree.nodes[k]
};

// ---- Lookups ----------------------------------------------------------------

bool insideUnitCube(const Vec3f& p) {
  // Written so NaN coordinates are outside too.
  return (p.array() >= 0.0f).all() && (p.array() <= 1.0f).all();
}

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

Lookup textureResult(const ApoTexture& texture, std::uint64_t node, std::uint64_t normalTexel, int depth) {
  checkTexel(texture, normalTexel);
  return {true, decodeNormal(texel::rgb(texture.texels, normalTexel), texture.encoding),
          static_cast<std::uint32_t>(node), depth};
}

}  // namespace

// ---- Public functions ---------------------------------------------------------

std::uint64_t ApoTexture::usedTexels() const { return gridTexels() + leafNodes + 2 * internalNodes; }

Result<ApoTexture> encodeApo(const Octree& octree, int completeDepth, NormalEncoding encoding,
                             std::uint8_t coarseDepth, std::uint8_t maxDepth) {
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
  // Grid entries of empty cells stay kEmptyCell.
  texture.texels.assign(4 * texture.gridTexels(), 0xFF);

  ForestEncoder encoder(octree, texture);
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
  const std::uint64_t used = encoder.usedTexels();
  APO_CHECK_OP(used, ==, texture.usedTexels());
  texture.width = texel::textureWidthFor(used);
  texture.height = static_cast<std::uint32_t>(texel::rowsFor(used, texture.width));
  texture.texels.resize(4 * std::uint64_t{texture.width} * texture.height, 0);
  return texture;
}

Result<Octree> decodeApo(const ApoTexture& texture) {
  APO_RETURN_IF_ERROR(checkTextureFields(texture));
  Result<Forest> forest = ForestReader(texture).read();
  if (!forest.ok()) return forest.error();
  return OctreeBuilder(texture, *forest).build();
}

Lookup lookupTexture(const ApoTexture& texture, const Vec3f& unitPoint, int maxDepth) {
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
  for (;;) {
    checkTexel(texture, node);
    const std::uint8_t childMask = texel::alpha(texture.texels, node);
    if (childMask == 0) return textureResult(texture, node, node, depth);
    // A maxDepth above the grid stops at the grid's node: the levels above
    // are not stored.
    if (depth >= maxDepth) return textureResult(texture, node, node + 1, depth);
    const int child = childIndex(centre, unitPoint);
    // No child there: the shader shades with this node's (mean) normal.
    if (!hasChild(childMask, child)) return textureResult(texture, node, node + 1, depth);
    checkTexel(texture, node + 1);
    const std::uint8_t kindMask = texel::alpha(texture.texels, node + 1);
    std::uint64_t next = node + texel::rgb24(texture.texels, node);
    for (int before = 0; before < child; ++before)
      if (hasChild(childMask, before)) next += texelsOf(hasChild(kindMask, before));
    node = next;
    centre = childCentre(centre, width, child);
    width *= 0.5f;
    ++depth;
  }
}

// A neighbour's normal enters the blend when its walk reaches P's depth or
// stops one level above; a coarser leaf's mean describes a region too far
// from P (measured: docs/benchmarks.md, "Filtering"), a missing one nothing.
bool isFilterNeighbour(const Lookup& neighbour, int ownDepth) {
  return neighbour.found && neighbour.depth + 1 >= ownDepth;
}

Lookup lookupTextureFiltered(const ApoTexture& texture, const Vec3f& unitPoint) {
  const Lookup own = lookupTexture(texture, unitPoint);
  if (!own.found) return own;
  // The shader's float operations: lattice coordinates of P among the cell
  // centres of its depth, the 8 corners around it, trilinear weights.
  const float width = 1.0f / static_cast<float>(1u << own.depth);
  const Eigen::Array3f lattice = unitPoint.array() / width - 0.5f;
  const Eigen::Array3f base = lattice.floor();
  const Eigen::Array3f t = lattice - base;
  Vec3f sum = Vec3f::Zero();
  for (int corner = 0; corner < 8; ++corner) {
    const Eigen::Array3f c((corner >> 2) & 1, (corner >> 1) & 1, corner & 1);
    const Eigen::Array3f weight3 = (1.0f - t) * (1.0f - c) + t * c;
    const Vec3f at = ((base + c + 0.5f) * width).matrix();
    const Lookup neighbour = lookupTexture(texture, at, own.depth);
    sum += weight3.prod() * (isFilterNeighbour(neighbour, own.depth) ? neighbour.normal : own.normal);
  }
  Lookup filtered = own;
  filtered.normal = sum.normalized();
  return filtered;
}

Lookup lookupOctree(const Octree& octree, const Vec3f& unitPoint, int maxDepth) {
  if (!insideUnitCube(unitPoint) || octree.nodes.empty()) return {};
  // The same float walk as lookupTexture, from the root; Lookup::texel holds
  // the index of the node in octree.nodes.
  float width = 1.0f;
  Vec3f centre(0.5f, 0.5f, 0.5f);
  std::uint32_t index = 0;
  int depth = 0;
  for (;;) {
    const OctreeNode& node = octree.nodes[index];
    if (node.isLeaf() || depth >= maxDepth) return {true, node.normal, index, depth};
    const int child = childIndex(centre, unitPoint);
    if (!hasChild(node.childMask, child)) return {true, node.normal, index, depth};
    checkBrood(octree, node);
    index = childNode(node, child);
    centre = childCentre(centre, width, child);
    width *= 0.5f;
    ++depth;
  }
}

}  // namespace apo
