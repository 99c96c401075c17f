// bake: the Appearance Preserving Octree-texture (APO) of a dense surface M's
// normal field around a coarse mesh m (Lacoste et al. 2007, sections 3, 4 and
// the completion of section 6). docs/bake.md describes the algorithm,
// docs/apo-format.md the .apo file byte by byte.
//
// The algorithm reaches the libraries through two seams, RayCaster
// (core/ray_caster.h; Embree in production) and ClosestPointFinder (FLANN),
// so tests can run it against brute-force versions.
#pragma once

#include "core/error.h"
#include "core/geometry.h"
#include "core/ray_caster.h"
#include "core/timing.h"

#include <array>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
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

// m's bounding box grown by kCubeMargin of its largest side on every side
// (so no triangle touches a face of the cube), centred in the unit cube.
inline constexpr double kCubeMargin = 0.01;
UnitCubeTransform unitCubeAround(const Aabb& box);

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

  bool isLeaf() const { return childMask == 0; }
};

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

  std::uint64_t gridTexels() const { return std::uint64_t{1} << (3 * completeDepth); }
  std::uint64_t usedTexels() const;  // grid + nodes; the rest of the last row is zero
};

// Encodes the octree: levels above `completeDepth` are replaced by a dense
// grid of (2^completeDepth)^3 entries; Usage error when completeDepth exceeds
// 10 or a relative offset does not fit 24 bits.
Result<ApoTexture> encodeApo(const Octree& octree, int completeDepth, NormalEncoding encoding,
                             std::uint8_t coarseDepth, std::uint8_t maxDepth);
// The octree back from the texture (levels below the grid decoded; the grid's
// nodes become the children of complete internal levels with zero normals).
Result<Octree> decodeApo(const ApoTexture& texture);

// Where a lookup stopped.
struct Lookup {
  bool found = false;             // false: outside the cube or in an empty grid cell
  Vec3f normal = Vec3f::Zero();   // decoded normal of the node it stopped at
  std::uint32_t texel = 0;        // first texel of that node
  int depth = 0;                  // that node's depth in the octree
};

// Walks the encoded texture exactly as the shader does: the grid cell of P,
// then the child index from the sign of P minus the cell centre and the offset
// from the masks, until a leaf, a missing child (the last node's normal), or
// `maxDepth`. `unitPoint` is in unit-cube coordinates.
Lookup lookupTexture(const ApoTexture& texture, const Vec3f& unitPoint, int maxDepth = 255);
// Paper 5.3, as the shader's filtering does it: the normals of the 8 cells
// around P at the depth of P's own cell, blended trilinearly; each is found by
// its own walk (to that depth at most); a neighbour outside the octree, or
// whose walk stops more than one level above P's cell, takes P's own normal.
// Not found when P itself is outside.
Lookup lookupTextureFiltered(const ApoTexture& texture, const Vec3f& unitPoint);
// The same walk in the in-memory octree, from the root (for tests).
Lookup lookupOctree(const Octree& octree, const Vec3f& unitPoint, int maxDepth = 255);

// The .apo file (format version 1). Reading validates every field and the
// payload checksum; a corrupt or truncated file is BadInput naming the field.
Status writeApoFile(const std::filesystem::path& path, const ApoTexture& texture);
Result<ApoTexture> readApoFile(const std::filesystem::path& path);
// The texture as an RGBA PNG (the paper's figure 5).
Status writeApoPng(const std::filesystem::path& path, const ApoTexture& texture);

// ---- Baking (paper section 3) ---------------------------------------------

// The nearest point of M to a query, with M's normal there.
struct SurfacePoint {
  Vec3f position = Vec3f::Zero();
  Vec3f normal = Vec3f::Zero();
};

class ClosestPointFinder {
 public:
  virtual ~ClosestPointFinder() = default;
  virtual SurfacePoint closest(const Vec3f& query) const = 0;  // thread-safe
};

struct BakeOptions {
  int coarseDepth = 5;   // the initial octree is complete to this depth (around m)
  int maxDepth = 13;
  double error = 0.05;   // L2,1 threshold, in units of M's mean primitive area (docs/bake.md)
  // Rays reach max(maxDistance x m's bbox diagonal, the cell's diagonal).
  double maxDistance = 0.01;
  int samples = 1;           // ray origins per (leaf, triangle of m): 1, the paper's closest point to the centre; K > 1 stratified
  int completeDepth = -1;    // -1: coarseDepth
  NormalEncoding encoding = NormalEncoding::Oct24;
};

struct BakePhaseSeconds {
  double setup = 0, build = 0, sample = 0, encode = 0;
};

struct BakeReport {
  std::string detailKind;  // "mesh" or "points"
  std::uint64_t detailPrimitives = 0, coarseTriangles = 0;
  std::vector<std::uint64_t> nodesPerDepth;
  std::uint64_t leaves = 0, internalNodes = 0;
  std::uint64_t rays = 0, hits = 0, fallbacks = 0;  // fallbacks: samples taken by the closest point
  std::uint32_t textureWidth = 0, textureHeight = 0;
  std::uint64_t textureBytes = 0;
  BakePhaseSeconds seconds;
  double totalSeconds = 0;
  std::uint64_t peakMemoryBytes = 0;
};

struct Bake {
  Octree octree;
  ApoTexture texture;
  BakeReport report;
};

// M as the sampler sees it: `detail` is a mesh with unit vertex normals or
// points with unit normals; `caster` hits its triangles (hit.primitive = the
// triangle) or its points' discs (hit.primitive = the point).
struct DetailSurface {
  const Scan* detail = nullptr;
  const RayCaster* caster = nullptr;
  const ClosestPointFinder* closest = nullptr;
  std::vector<float> pointAreas;  // points only: each point's share of the surface
};

// The algorithm against given seams (tests use brute-force ones).
Result<Bake> bakeWith(const DetailSurface& detail, const Scan& coarse, const BakeOptions& options,
                      const ProgressCallback& onProgress = {});
// The product: Embree and FLANN seams built for `detail`, then bakeWith.
Result<Bake> bakeApo(const Scan& detail, const Scan& coarse, const BakeOptions& options,
                     const ProgressCallback& onProgress = {});

// Production seams, one adapter file each.
Result<std::unique_ptr<ClosestPointFinder>> makeFlannClosestPoint(const Scan& detail);
// Radius of each point's disc: its local spacing (k-nearest distances, FLANN).
std::vector<float> discRadii(const PointSet& points);

std::string bakeReportJson(const BakeReport& report);  // bake.json, format_version 1

}  // namespace apo
