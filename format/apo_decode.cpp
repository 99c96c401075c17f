// The decoder of the APO texture, which is also the structural validator of
// every texture read from disk: it accepts exactly the layout the encoder
// writes (docs/apo-format.md), so that every later lookup stays inside the
// used texels and terminates.
#include "format/cells.h"
#include "format/format.h"
#include "format/texel_layout.h"

#include <algorithm>
#include <optional>

namespace apo {
namespace {

using namespace cells;
using texel::kEmptyCell;

// A node of the texture's forest as the validator found it.
// Whether normal bytes are version 3's "m's own normal" code.
bool isCoarseCode(const ApoTexture& texture, const std::array<std::uint8_t, 3>& bytes) {
  const std::uint32_t value = std::uint32_t{bytes[0]} | std::uint32_t{bytes[1]} << 8 | std::uint32_t{bytes[2]} << 16;
  return texture.defersToCoarse && value == texel::coarseCode(texture.encoding == NormalEncoding::Xyz8);
}

struct ForestNode {
  std::uint8_t childMask = 0, kindMask = 0;
  std::array<std::uint8_t, 3> normal{};
  bool twoSided = false;  // a leaf of two texels: `normal` is side 0, `otherSide` side 1
  std::array<std::uint8_t, 3> otherSide{};
  std::uint8_t sideAxis = 0;
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
  if (texture.leafNodes > texels || texture.internalNodes > texels || texture.twoSidedLeaves > texture.leafNodes ||
      texture.usedTexels() > texels)
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

  // Reads the node at next_; `twoTexels` is the parent's kind bit.
  Status readNode(int depth, std::optional<bool> twoTexels) {
    if (next_ >= used_)
      return badInput("texel {}: a node starts past the {} used texels", next_, used_);
    if (depth > texture_.maxDepth)
      return badInput("texel {}: a node at depth {}, deeper than the max depth {}", next_, depth,
                      int{texture_.maxDepth});
    ForestNode node;
    node.depth = depth;
    node.childMask = texel::alpha(texture_.texels, next_);
    const bool internal = node.childMask != 0;
    if (twoTexels && !*twoTexels && internal)
      return badInput("texel {}: its parent's kind mask says leaf, but its child mask is {:#04x}", next_,
                      node.childMask);
    node.twoSided = twoTexels && *twoTexels && !internal;
    if (node.twoSided) APO_RETURN_IF_ERROR(readTwoSidedLeaf(node));
    if (internal && next_ + 2 > used_)
      return badInput("texel {}: an internal node's second texel is past the {} used texels", next_, used_);
    node.normal = texel::rgb(texture_.texels, internal ? next_ + 1 : next_);
    if (internal && isCoarseCode(texture_, node.normal) && !texture_.coarseAtInternalNodes)
      return badInput("texel {}: an internal node's normal is the code of m's own normal, which only leaves hold "
                      "before format version 4",
                      next_ + 1);
    if (internal) node.kindMask = texel::alpha(texture_.texels, next_ + 1);
    if (node.kindMask & ~node.childMask)
      return badInput("texel {}: kind mask {:#04x} marks children absent from the child mask {:#04x}", next_ + 1,
                      node.kindMask, node.childMask);
    texels_.push_back(next_);
    forest_.nodes.push_back(node);
    next_ += texelsOf(internal || node.twoSided);
    (internal ? internal_ : leaves_) += 1;
    twoSided_ += node.twoSided ? 1 : 0;
    return okStatus();
  }

  // A leaf its parent's kind bit gives two texels (version 4): side 0 in
  // the first, side 1 and the axis in the second; neither side m's code.
  Status readTwoSidedLeaf(ForestNode& node) const {
    if (texture_.twoSidedLeaves == 0)
      return badInput("texel {}: its parent's kind mask says two texels, but its child mask is 0: a two-sided leaf, "
                      "which only files counting two-sided leaves (format version 4) hold",
                      next_);
    if (next_ + 2 > used_)
      return badInput("texel {}: a two-sided leaf's second texel is past the {} used texels", next_, used_);
    node.otherSide = texel::rgb(texture_.texels, next_ + 1);
    node.sideAxis = texel::alpha(texture_.texels, next_ + 1);
    if (node.sideAxis > 2)
      return badInput("texel {}: a two-sided leaf's axis is {} (expected 0 x, 1 y or 2 z)", next_ + 1,
                      int{node.sideAxis});
    if (isCoarseCode(texture_, node.normal) || isCoarseCode(texture_, node.otherSide))
      return badInput("texel {}: a side of a two-sided leaf holds the code of m's own normal", next_);
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
    if (next_ != used_ || leaves_ != texture_.leafNodes || internal_ != texture_.internalNodes ||
        twoSided_ != texture_.twoSidedLeaves)
      return badInput("the nodes end at texel {} with {} leaves ({} two-sided) and {} internal nodes, but the "
                      "texture counts {} used texels, {} leaves ({} two-sided) and {} internal nodes",
                      next_, leaves_, twoSided_, internal_, used_, texture_.leafNodes, texture_.twoSidedLeaves,
                      texture_.internalNodes);
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
  std::uint64_t leaves_ = 0, internal_ = 0, twoSided_ = 0;
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
      node.coarseNormal = isCoarseCode(texture_, forestNode.normal);
      node.normal = node.coarseNormal ? Vec3f(Vec3f::Zero()) : decodeNormal(forestNode.normal, texture_.encoding);
      node.childMask = forestNode.childMask;
      if (forestNode.twoSided) {
        node.twoSided = true;
        node.sideAxis = forestNode.sideAxis;
        node.sides = {decodeNormal(forestNode.normal, texture_.encoding),
                      decodeNormal(forestNode.otherSide, texture_.encoding)};
        const Vec3f mean = node.sides[0] + node.sides[1];
        node.normal = mean.squaredNorm() > 0.0f ? Vec3f(mean.normalized()) : node.sides[0];
      }
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

}  // namespace

Result<Octree> decodeApo(const ApoTexture& texture) {
  APO_RETURN_IF_ERROR(checkTextureFields(texture));
  Result<Forest> forest = ForestReader(texture).read();
  if (!forest.ok()) return forest.error();
  return OctreeBuilder(texture, *forest).build();
}

}  // namespace apo
