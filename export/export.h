// Standard delivery (docs/export.md): m as a glTF 2.0 binary (GLB) with a
// tangent-space normal map made without any UV unwrap: every triangle of m
// gets its own patch of the map (the packed per-triangle normal patches of
// ../shared/papers/texture-based-shading-packed-normal-patches.txt), filled
// from a normal field (the APO's filtered lookup) in exactly the tangent
// frame a glTF viewer rebuilds from the file.
#pragma once

#include "core/checked.h"
#include "core/error.h"
#include "core/geometry.h"
#include "format/format.h"

#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

namespace apo {

using Vec2f = Eigen::Vector2f;

// Where each triangle of m lies in the map, in texel units (x right, y down,
// texel (i, j) covers [i, i+1) x [j, j+1)). Each patch is its triangle laid
// flat without shearing (a similarity: lengths scaled by texelsPerUnit times
// the triangle's scale), its longest edge along x; patches and their gutters
// do not overlap.
struct PatchAtlas {
  std::uint32_t width = 0, height = 0;
  float texelsPerUnit = 0.0f;
  std::vector<float> scales;                 // per triangle of m: its patch's density over texelsPerUnit
  int gutter = 0;                            // texels kept free round each patch
  std::vector<std::array<Vec2f, 3>> corners;  // per triangle of m, in its corner order
  double usedShare = 0.0;                    // texels inside a triangle / all texels
};

// Packs every triangle of `coarse` into a width x height map at the largest
// texel density that fits (shelves of patches sorted by height, a binary
// search on the density), `gutter` texels apart and from the border; each
// triangle's patch `scales[f]` times that density (empty: all 1).
// BadInput when m has no triangle of positive area; Usage when the sizes are
// outside [16, 16384] or the gutter outside [1, 8].
Result<PatchAtlas> packTrianglePatches(const Scan& coarse, std::uint32_t width, std::uint32_t height, int gutter = 2,
                                       const std::vector<float>& scales = {});

// m as a glTF primitive: three vertices per triangle (a patch each), m's
// area-weighted vertex normals, a tangent per vertex (the direction of +u in
// the triangle's plane, made orthogonal to the vertex normal; w = +1) and the
// patch's UVs (u = x / width, v = y / height: glTF's origin at the image's
// top-left).
struct GltfMesh {
  std::vector<Vec3f> positions, normals;
  std::vector<Eigen::Vector4f> tangents;
  std::vector<Vec2f> uvs;
  std::vector<std::uint32_t> indices;
};
GltfMesh patchMesh(const Scan& coarse, const PatchAtlas& atlas);

// The normal to show at a point of m, given m's interpolated normal there
// (unit); a zero vector means "no answer" (the map then keeps m's normal).
using NormalField = std::function<Vec3f(const Vec3f& point, const Vec3f& coarseNormal)>;

// Patch scales from the detail each triangle covers (the paper's patches
// sized from the fine surface under them): the field's normal on a lattice
// of points of the triangle, its mean turn per unit length g between
// neighbouring points, and scale (g / median g)^(1/3) clamped to
// [kMinPatchScale, kMaxPatchScale] (the cube root spreads a fixed number of
// texels where a linear texel's error, g times its size, falls most).
inline constexpr float kMinPatchScale = 0.5f, kMaxPatchScale = 2.0f;
std::vector<float> detailPatchScales(const Scan& coarse, const NormalField& field);

// The tangent-space normal map: RGB8, row-major, top row first. Each texel
// whose centre lies within the gutter of a patch takes the field at the
// closest point of that triangle, expressed in the frame glTF 2.0 defines
// (n = normalize(T x + B y + N z), N and T interpolated, T made orthogonal
// to N, B = cross(N, T) w), so that a viewer decodes the field's normal up
// to 8-bit rounding. Texels outside every patch are filled by push-pull (the
// mean of the filled texels nearby, coarse to fine), so that mip-maps do not
// bleed m's flat blue into the patches' edges.
struct NormalMap {
  std::uint32_t width = 0, height = 0;
  std::vector<std::uint8_t> rgb;
  std::uint64_t texelsFilled = 0, texelsWithoutAnswer = 0;  // from the field; of those, left at m's normal
};
NormalMap bakeTangentNormalMap(const GltfMesh& mesh, const PatchAtlas& atlas, const NormalField& field);

// The scan's colour at points of m, all at once (the search behind it runs
// on every core); one answer per point.
using ColorField = std::function<Result<std::vector<Rgb8>>(const std::vector<Vec3f>& points)>;

// The base colour map on the same patches: RGB8 (the scan's bytes, which
// glTF reads as sRGB), each texel within the gutter of a patch the field's
// colour at the closest point of that triangle, the others push-pull.
struct ColorMap {
  std::uint32_t width = 0, height = 0;
  std::vector<std::uint8_t> rgb;
};
Result<ColorMap> bakeColorMap(const GltfMesh& mesh, const PatchAtlas& atlas, const ColorField& field);

// ---- The export stage: a finished run's m and APO as a GLB ----------------

struct ExportOptions {
  bool enabled = true;           // apo run / apo batch: --no-export skips the stage
  std::uint32_t mapSize = 1024;  // the normal map's texels per side (square)
  int gutter = 2;                // texels kept free round each patch
  bool draco = false;            // the mesh compressed with Draco (KHR_draco_mesh_compression)
  bool color = true;             // the scan's colours as the base colour map, when it has colours (--no-color: never)
  bool detailSizing = true;      // patches sized by detailPatchScales (--patch-size detail), or all at one density (uniform)
};
// Usage error naming the option: map size in [16, 16384], gutter in [1, 8].
template <>
Result<Checked<ExportOptions>> check(const ExportOptions& options);

struct ExportReport {
  std::string source;  // "apo" or "detail"
  std::uint32_t mapWidth = 0, mapHeight = 0;
  int gutter = 0;
  float texelsPerUnit = 0.0f;
  bool detailSizing = false;
  float smallestScale = 1.0f, largestScale = 1.0f;  // of the patches' scales
  double usedShare = 0.0;
  std::uint64_t triangles = 0, texelsFilled = 0, texelsWithoutAnswer = 0, pngBytes = 0, glbBytes = 0;
  std::uint64_t colorPngBytes = 0;  // the base colour map's PNG; 0 without one
  bool draco = false;
  double seconds = 0.0;
};

struct ExportedAsset {
  std::string glb;
  ExportReport report;
};

// The APO's filtered lookup as a field (m's interpolated normal choosing
// the side of two-sided leaves and answering where nodes show m, as in the
// shader); no answer outside the octree.
NormalField apoNormalField(const ApoTexture& apo);

// m (in the field's frame) with a normal map filled from `field`; `source`
// names it in the report and the asset ("apo", or "detail" for M itself);
// `origin`: the scan's local frame origin, in the asset's extras (file
// coordinates = origin + glTF coordinates); `color`, when given, fills the
// material's base colour map on the same patches.
Result<ExportedAsset> exportGlb(const Scan& coarse, const NormalField& field, const std::string& source,
                                const Checked<ExportOptions>& options, const std::array<double, 3>& origin,
                                const std::string& generator, const ColorField* color = nullptr);
// The manifest's results.export (docs/export.md).
std::string exportReportJson(const ExportReport& report);

// A primitive compressed with Draco (KHR_draco_mesh_compression): the bytes,
// each attribute's Draco unique id, the decoded counts and position bounds.
struct DracoPrimitive {
  std::string bytes;
  int position = -1, normal = -1, tangent = -1, texcoord = -1;
  std::uint32_t points = 0, faces = 0;
  std::array<float, 3> low{}, high{};
};
// Positions to 14 bits, normals and tangents to 12, texture coordinates to
// 16 (a 65,536th of the map: a 64th of a texel at 1024^2).
Result<DracoPrimitive> dracoCompress(const GltfMesh& mesh);

// The GLB (glTF 2.0 binary): one mesh, one node, a metallic-roughness
// material whose normalTexture is `normalPng` (TEXCOORD_0, linear filtering
// with mip-maps, clamped) and, when `colorPng` is not empty, whose
// baseColorTexture is that (else a grey base colour), and `extras` (a JSON
// object's text, may be empty) on the asset. Bytes depend only on the
// arguments. With `draco`, the primitive is that compressed one (its
// accessors without buffer views, the extension used and required).
struct GlbImages {
  std::string normalPng, colorPng;
};
std::string glbBytes(const GltfMesh& mesh, const GlbImages& images, const std::string& generator,
                     const std::string& extras, const DracoPrimitive* draco = nullptr);

}  // namespace apo
