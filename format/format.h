// format: the APO octree texture as data (Lacoste et al. 2007, section 4,
// with the completion grid of section 6): the octree in memory, its encoding
// into an RGBA8 texture, the decoder that validates it, the CPU lookups
// (plain and filtered) that the shaders repeat, and the .apo file.
// docs/apo-format.md describes the layout and the file byte by byte. bake/
// writes this format; render/ and every other reader use only this room.
#pragma once

#include "core/error.h"
#include "core/geometry.h"

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <string_view>
#include <vector>

namespace apo {

// ---- The unit cube --------------------------------------------------------

// World to the unit cube by one uniform scale and a translation:
// unit = world * scale + offset.
struct UnitCubeTransform {
  double scale = 1.0;
  std::array<double, 3> offset = {0.0, 0.0, 0.0};

  Vec3f toUnit(const Vec3f& world) const;
  Vec3f toWorld(const Vec3f& unit) const;
};


// ---- The octree in memory -------------------------------------------------

// Child c of a cell holds bit 2 for x, 1 for y, 0 for z; a bit is 1 when the
// child lies on the lower side of the centre, and a point exactly on the
// centre plane goes to the lower side (the paper's getChildIndex:
// step(0, sign(centre - P))).
int childIndex(const Vec3f& centre, const Vec3f& point);
// Centre of child c of a cell of width `width` centred at `centre`.
Vec3f childCentre(const Vec3f& centre, float width, int child);

struct OctreeNode {
  static constexpr std::uint32_t kNoChild = ~0u;
  Vec3f normal = Vec3f::Zero();  // unit; internal nodes: area-weighted mean of the children
  double weight = 0.0;           // area of m inside the cell (world units squared)
  std::uint32_t firstChild = kNoChild;  // the children are contiguous, in increasing child index
  std::uint8_t childMask = 0;           // bit c set when child c exists (intersects m)
  std::uint8_t depth = 0;
  // A node that shows m's own interpolated normal where a walk stops at it
  // (m is closer to M there than the cell's one normal): stored as the
  // reserved normal code, for leaves since format version 3, for internal
  // nodes (walks stopped early: mip-mapping) since version 4; `normal` is
  // still the cell's, for the levels above.
  bool coarseNormal = false;
  // A two-sided leaf (format version 4): a cell holding both sides of a
  // thin part (or a surface that turns), whose M normals form two groups
  // told apart by m's normal. sides[0] shows where m's interpolated normal
  // has a non-negative coordinate on `sideAxis` (0 x, 1 y, 2 z), sides[1]
  // where it is negative (leafSide); `normal` is still their mean, for the
  // levels above. Never at or above the completion depth (docs/apo-format.md).
  bool twoSided = false;
  std::uint8_t sideAxis = 0;
  std::array<Vec3f, 2> sides = {Vec3f::Zero(), Vec3f::Zero()};

  bool isLeaf() const { return childMask == 0; }
};

// Which side of a two-sided leaf a point shows: 0 where m's normal there has
// a non-negative coordinate on the leaf's axis, else 1. The bake groups M's
// normals by the same rule, the lookups and the shader pick by it.
inline int leafSide(const Vec3f& coarseNormal, int sideAxis) { return coarseNormal[sideAxis] >= 0.0f ? 0 : 1; }

// nodes[0] is the root, the unit cube [0, 1]^3 (centre 0.5, width 1).
struct Octree {
  UnitCubeTransform transform;
  std::vector<OctreeNode> nodes;
};

// ---- Encoding (paper section 4, completion of section 6) -----------------

enum class NormalEncoding : std::uint8_t { Xyz8 = 0, Oct24 = 1 };
std::string normalEncodingName(NormalEncoding encoding);  // "xyz8", "oct24"

// Three bytes of a unit normal: xyz8 rounds (n + 1) / 2 * 255 per axis;
// oct24 is the octahedral map, 12 bits per coordinate.
std::array<std::uint8_t, 3> encodeNormal(const Vec3f& normal, NormalEncoding encoding);
Vec3f decodeNormal(const std::array<std::uint8_t, 3>& bytes, NormalEncoding encoding);  // unit length

// The encoded APO: a 2D RGBA8 texture, row-major, width a power of two. Its
// first gridTexels() texels are the completion grid, then the nodes below the
// completion depth in breadth-first order (docs/apo-format.md).
struct ApoTexture {
  UnitCubeTransform transform;
  std::uint8_t coarseDepth = 0, maxDepth = 0;  // the bake's settings
  std::uint8_t completeDepth = 0;              // 0: a grid of one cell, the root
  NormalEncoding encoding = NormalEncoding::Oct24;
  std::uint32_t width = 0, height = 0;
  std::uint64_t leafNodes = 0, internalNodes = 0;  // encoded nodes (below the grid)
  std::vector<std::uint8_t> texels;                // width * height * 4 bytes
  // The scan's local frame (Scan::origin): the file's coordinates are origin
  // + the world coordinates `transform` maps. Zero for most scans; stored in
  // .apo version 2.
  std::array<double, 3> origin = {0.0, 0.0, 0.0};
  // Format version 3: a node whose normal bytes are the reserved code shows
  // m's own interpolated normal (OctreeNode::coarseNormal). Set by the
  // encoder when some leaf does, and by the reader for version 3 files.
  bool defersToCoarse = false;
  // Format version 4: leaves of two texels, one normal per side of m
  // (OctreeNode::twoSided); counted among leafNodes too.
  std::uint64_t twoSidedLeaves = 0;
  // Format version 4: internal nodes may hold the code of m's own normal
  // too. Set by the encoder when one does, and by the reader for version 4.
  bool coarseAtInternalNodes = false;

  std::uint64_t gridTexels() const { return std::uint64_t{1} << (3 * completeDepth); }
  std::uint64_t usedTexels() const;  // grid + nodes; the rest of the last row is zero
  // Whether a lookup needs m's normal at the point to answer everywhere.
  bool needsCoarseNormals() const { return defersToCoarse || twoSidedLeaves > 0; }
};

// Calls body(begin, end) over ranges covering [0, count), on the caller's
// threads as it sees fit (the bake's thread pool): the encoder's work that
// does not depend on order, its output the same whatever the threads.
using ParallelRanges =
    std::function<void(std::size_t count, const std::function<void(std::size_t begin, std::size_t end)>& body)>;

// Encodes the octree: levels above `completeDepth` are replaced by a dense
// grid of (2^completeDepth)^3 entries; Usage error when completeDepth exceeds
// 10 or a relative offset does not fit 24 bits. The nodes' normals are
// encoded through `parallel` (none: on this thread).
Result<ApoTexture> encodeApo(const Octree& octree, int completeDepth, NormalEncoding encoding,
                             std::uint8_t coarseDepth, std::uint8_t maxDepth, const ParallelRanges& parallel = {});
// The octree back from the texture (levels below the grid decoded; the grid's
// nodes become the children of complete internal levels with zero normals).
Result<Octree> decodeApo(const ApoTexture& texture);

// Where a lookup stopped.
struct Lookup {
  bool found = false;             // false: outside the cube or in an empty grid cell
  Vec3f normal = Vec3f::Zero();   // decoded normal of the node it stopped at
  std::uint32_t texel = 0;        // first texel of that node
  int depth = 0;                  // that node's depth in the octree
  bool coarse = false;            // that node shows m's own normal: `normal` is the caller's
  bool twoSided = false;          // a two-sided leaf: `normal` is the side the caller's m normal picks
};

// Walks the encoded texture exactly as the shader does: the grid cell of P,
// then the child index from the sign of P minus the cell centre and the offset
// from the masks, until a leaf, a missing child (the last node's normal), or
// `maxDepth`. `unitPoint` is in unit-cube coordinates.
// `coarseNormal` is m's interpolated normal at the point (what the shader
// has per fragment), answered where the node defers to m (version 3) and
// picking the side of a two-sided leaf (version 4); zero when the caller has
// no m (a two-sided leaf then shows sides[0]).
Lookup lookupTexture(const ApoTexture& texture, const Vec3f& unitPoint, int maxDepth = 255,
                     const Vec3f& coarseNormal = Vec3f::Zero());
// Paper 5.3, as the shader's filtering does it: the normals of the 8 cells
// around P at the depth of P's own cell, blended trilinearly; each is found by
// its own walk (to that depth at most); a neighbour outside the octree, or
// whose walk stops more than one level above P's cell, takes P's own normal.
// Not found when P itself is outside.
// A neighbour deferring to m contributes `coarseNormal`; a neighbour facing
// away from it (the other side of a thin part) does not enter the blend.
// Without m (zero), P's own cell's normal decides what faces away; the
// shader always has m.
Lookup lookupTextureFiltered(const ApoTexture& texture, const Vec3f& unitPoint,
                             const Vec3f& coarseNormal = Vec3f::Zero());
// The same walk in the in-memory octree, from the root (for tests).
Lookup lookupOctree(const Octree& octree, const Vec3f& unitPoint, int maxDepth = 255,
                    const Vec3f& coarseNormal = Vec3f::Zero());

// The .apo file (format versions 1 to 4: the writer picks the oldest that
// holds the texture). Reading validates every field and the
// payload checksum; a corrupt or truncated file is BadInput naming the field.
Status writeApoFile(const std::filesystem::path& path, const ApoTexture& texture);
Result<ApoTexture> readApoFile(const std::filesystem::path& path);
// The same reader over a file's bytes in memory (the fuzzer's entry point).
Result<ApoTexture> parseApoFile(std::string_view bytes);
// What byte `offset` of an .apo file holds, in words: a header field, or a
// texel's channel and whether the texel is in the grid, the nodes or the
// padding (from the header, when it parses). For reports of differing files.
std::string describeApoFileByte(std::string_view bytes, std::uint64_t offset);
// Bytes of the .apo file of a texture using `usedTexels` texels (the width
// the encoder picks, the last row padded, the header of the version the
// writer picks: with an origin or not). What a byte budget is counted in.
std::uint64_t apoFileBytes(std::uint64_t usedTexels, bool withOrigin);
// The texture as an RGBA PNG (the paper's figure 5).
Status writeApoPng(const std::filesystem::path& path, const ApoTexture& texture);

// ---- The N^3-tree (GPU Gems 2, chapter 37: Lefebvre, Hornus, Neyret) --------

// The same octree stored as the chapter stores it (docs/n3tree-format.md):
// an indirection pool, a 3D RGBA8 texture of indirection grids of N x N x N
// cells, one grid per node of the N^3-tree; each cell is empty, holds a
// leaf's data (the normal's three bytes) or points to a child grid by its
// (u, v, w) place in the pool. A node of the N^3-tree at level L is the
// octree's node at depth L log2(N); a leaf of the octree between two levels
// fills all the cells it covers. The LOD pool, one RGBA8 cell per grid,
// holds each node's average (the chapter's mip-mapping). Two-sided leaves
// (format version 4 of the APO) point into a third texture of side pairs.
struct N3Tree {
  // Cell kinds, in the alpha channel (the chapter's 0, 0.5 and 1, and the
  // two-sided leaves, whose axis is added to kTwoSided).
  static constexpr std::uint8_t kEmpty = 0, kPointer = 128, kTwoSided = 192, kData = 255;
  static constexpr int kSidesWidth = 1024;  // texels per row of the sides texture

  UnitCubeTransform transform;
  std::array<double, 3> origin = {0.0, 0.0, 0.0};  // the scan's local frame, as ApoTexture::origin
  int n = 2;                                       // 2 (an octree) or 4
  int levels = 0;                                  // deepest grid level + 1
  NormalEncoding encoding = NormalEncoding::Oct24;
  bool defersToCoarse = false;        // data cells may hold m's code (ApoTexture::defersToCoarse)
  bool coarseAtInternalNodes = false; // LOD cells may hold m's code
  std::array<std::uint32_t, 3> grids = {1, 1, 1};  // S_u, S_v, S_w: grids per axis of the pool, at most 256
  std::uint32_t usedGrids = 1;        // grids in breadth-first order, grid g at (g % S_u, g / S_u % S_v, g / S_u / S_v)
  std::uint32_t twoSidedLeaves = 0;
  std::vector<std::uint8_t> pool;     // (N S_u) x (N S_v) x (N S_w) cells, x fastest, 4 bytes each
  std::vector<std::uint8_t> lod;      // S_u x S_v x S_w cells
  std::vector<std::uint8_t> sides;    // kSidesWidth x rows texels: leaf i's sides at 2i (side 0) and 2i + 1

  int log2n() const { return n == 2 ? 1 : 2; }
  std::array<std::uint32_t, 3> poolSize() const { return {n * grids[0], n * grids[1], n * grids[2]}; }
  std::uint64_t poolCells() const;
  std::uint32_t sidesRows() const { return (2 * twoSidedLeaves + kSidesWidth - 1) / kSidesWidth; }
  std::uint64_t textureBytes() const { return pool.size() + lod.size() + sides.size(); }
  bool needsCoarseNormals() const { return defersToCoarse || coarseAtInternalNodes || twoSidedLeaves > 0; }
};

// How the octree is stored for the shader: the APO's texture (paper section
// 4) or GPU Gems 2's N^3-tree.
enum class TextureLayout : std::uint8_t { Apo = 0, N3Tree = 1 };
std::string textureLayoutName(TextureLayout layout);  // "apo", "n3tree"

// The octree as an N^3-tree of `n` (2 or 4) with the octree's own normals
// (its nodes' normals are the LOD pool); Usage error for another n or when
// the nodes need more than 256^3 grids or the pool more than `maxPoolSide`
// cells per axis.
Result<N3Tree> buildN3Tree(const Octree& octree, int n, NormalEncoding encoding, std::uint32_t maxPoolSide = 2048);

// Where a walk of the N^3-tree stopped.
struct N3Lookup {
  bool found = false;
  Vec3f normal = Vec3f::Zero();
  std::uint64_t place = 0;  // the pool cell it read last (x + X (y + Y z)), or poolCells() + grid for a node's average
  int depth = 0;            // octree depth of that cell (a node's average: the node's)
  bool coarse = false, twoSided = false, average = false;
  std::uint32_t reads = 0;  // texels read: one pool cell per level, plus the LOD or sides texel
};

// The chapter's tree lookup (section 1.2.2), as the shader does it: from
// the root grid down, the cell of P in each grid (lower side on ties, like
// childIndex), until a data cell; an empty cell, `maxDepth` (octree depth
// of the node) or the pixel test of mip-mapping stops at the node's
// average in the LOD pool. Not found outside the unit cube.
N3Lookup lookupN3Tree(const N3Tree& tree, const Vec3f& unitPoint, int maxDepth = 255,
                      const Vec3f& coarseNormal = Vec3f::Zero());
// Linear interpolation as the chapter does it (section 1.3.3): 8 lookups at
// the lattice of P's own cell, blended trilinearly; a sample outside the
// tree, stopped more than one octree level above, or facing away from m's
// normal takes P's own value (lookupTextureFiltered's rules).
N3Lookup lookupN3TreeFiltered(const N3Tree& tree, const Vec3f& unitPoint, const Vec3f& coarseNormal = Vec3f::Zero());

// The .n3t file (version 1, docs/n3tree-format.md): validated on read (every
// header field, the SHA-256 of the payload, every pointer and cell kind).
Status writeN3TreeFile(const std::filesystem::path& path, const N3Tree& tree);
Result<N3Tree> readN3TreeFile(const std::filesystem::path& path);
Result<N3Tree> parseN3TreeFile(std::string_view bytes);
// The structure: cell kinds, pointers to later grids only (so a walk ends),
// every grid but the root pointed to once, side indices in range.
Status validateN3Tree(const N3Tree& tree);

// ---- The layout for shaders -------------------------------------------------

// GLSL definitions of the layout's constants (the empty grid cell, the oct24
// bit split, the encodings' codes, the deepest walk), generated from the C++
// constants so that the shaders cannot drift from the encoder: every shader
// that walks the texture starts with them. Valid in GLSL 4.50 and GLSL ES 3.00.
std::string glslLayoutDefinitions();
// The N^3-tree's cell kinds and limits as GLSL (N3_*), for its walk.
std::string glslN3TreeDefinitions();

}  // namespace apo
