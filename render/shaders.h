// GLSL sources of the passes (internal to render/), without their #version
// line: passes.cpp puts "#version 450 core" before them for OSMesa, and
// webglShaders() "#version 300 es" and precisions for WebGL2, so that the
// APO walk is one text for both (it avoids what GLSL ES 3.00 lacks), and so
// are the shading and the points' fragment stage (what differs, behind
// POINT_SPRITES, which webglShaders() defines). One vertex shader for
// every mesh; fragment shaders for M or m with their own normals, and for m
// with the APO, whose walk repeats format/'s lookupTexture operation for
// operation so that both land on the same node (see the exactness pass).
// The walk uses the layout's constants (APO_*) from glslLayoutDefinitions()
// (format/format.h), which passes.cpp puts before it.
#pragma once

#include <string>
#include <string_view>

namespace apo::shaders {

inline constexpr std::string_view kMeshVertex = R"(
layout(location = 0) in vec3 position;
layout(location = 1) in vec3 normal;
uniform mat4 viewProjection;
out vec3 worldPosition;
out vec3 worldNormal;
void main() {
  worldPosition = position;
  worldNormal = normal;
  gl_Position = viewProjection * vec4(position, 1.0);
}
)";

// M as points: each point a disc of its spacing's radius, flat-shaded with
// the point's normal. In the OSMesa passes the disc is oriented (a surfel):
// the geometry stage turns each point into a square in its tangent plane
// (kEmitSurfel). WebGL2 has no geometry stage: the report's viewer draws a
// round sprite facing the eye (kPointSpriteVertex, POINT_SPRITES defined).
// Either way kSplatFragment cuts the disc out.

// A point's attributes, as every points pass's vertex stage reads them.
inline constexpr std::string_view kPointAttributes = R"(
layout(location = 0) in vec3 position;
layout(location = 1) in vec3 normal;
layout(location = 2) in float radius;
)";

// After kPointAttributes: the point on to the geometry stage.
inline constexpr std::string_view kSplatVertex = R"(
out vec3 splatNormal;
out float splatRadius;
void main() {
  gl_Position = vec4(position, 1.0);
  splatNormal = normal;
  splatRadius = radius;
}
)";

// One surfel as a square in its tangent plane (the fragment stage cuts the
// disc), for both geometry shaders below; they declare its outputs.
inline constexpr std::string_view kEmitSurfel = R"(
void emitSurfel(vec3 centre, vec3 n, float r) {
  n = normalize(n);
  vec3 u = normalize(cross(n, abs(n.x) < 0.9 ? vec3(1.0, 0.0, 0.0) : vec3(0.0, 1.0, 0.0)));
  vec3 v = cross(n, u);
  for (int corner = 0; corner < 4; ++corner) {
    vec2 d = vec2((corner & 1) != 0 ? 1.0 : -1.0, (corner & 2) != 0 ? 1.0 : -1.0);
    worldPosition = centre + r * (d.x * u + d.y * v);
    worldNormal = n;
    discCoordinates = d;
    gl_Position = viewProjection * vec4(worldPosition, 1.0);
    EmitVertex();
  }
  EndPrimitive();
}
)";

// Every point as its surfel.
inline constexpr std::string_view kSplatGeometry = R"(
layout(points) in;
layout(triangle_strip, max_vertices = 4) out;
in vec3 splatNormal[];
in float splatRadius[];
uniform mat4 viewProjection;
out vec3 worldPosition;
out vec3 worldNormal;
out vec2 discCoordinates;
)";
inline constexpr std::string_view kSplatGeometryMain = R"(
void main() { emitSurfel(gl_in[0].gl_Position.xyz, splatNormal[0], splatRadius[0]); }
)";

// M as points through the point LOD (Maximo et al.): one vertex per patch
// (a sample of the coarsest level) with its error per level and where its
// finer samples lie in the object texture; the geometry shader projects the
// errors, picks the coarsest level within the threshold (render.h
// chooseLodLevel) and emits that level's surfels, read from the texture, as
// kSplatGeometry does. kSplatFragment cuts the discs. After kPointAttributes.
inline constexpr std::string_view kLodVertex = R"(
layout(location = 3) in vec4 errors;        // the patch's own, then the largest of levels 2, 1, 0
layout(location = 4) in uvec4 samples;      // first surfel, then the counts of levels 2, 1, 0
out vec3 patchNormal;
out float patchRadius;
out vec4 patchErrors;
flat out uvec4 patchSamples;
void main() {
  gl_Position = vec4(position, 1.0);
  patchNormal = normal;
  patchRadius = radius;
  patchErrors = errors;
  patchSamples = samples;
}
)";

inline constexpr std::string_view kLodGeometry = R"(
layout(points) in;
layout(triangle_strip, max_vertices = 256) out;
in vec3 patchNormal[];
in float patchRadius[];
in vec4 patchErrors[];
flat in uvec4 patchSamples[];
uniform mat4 viewProjection;
uniform vec3 eye;
uniform float pixelsPerWorldUnitAtOne;
uniform float lodThreshold;        // pixels
uniform sampler2D objectTexture;   // RGBA32F: per surfel (centre, radius), (normal, 0)
uniform int objectWidthShift;
out vec3 worldPosition;
out vec3 worldNormal;
out vec2 discCoordinates;

)";
inline constexpr std::string_view kLodGeometryMain = R"(
vec4 objectTexel(uint index) {
  uint mask = (1u << uint(objectWidthShift)) - 1u;
  return texelFetch(objectTexture, ivec2(int(index & mask), int(index >> uint(objectWidthShift))), 0);
}

void main() {
  vec3 centre = gl_in[0].gl_Position.xyz;
  float pixelsPerUnit = pixelsPerWorldUnitAtOne / max(length(eye - centre), 1e-30);
  vec4 e = patchErrors[0] * pixelsPerUnit;
  int level = e.x <= lodThreshold ? 3 : e.y <= lodThreshold ? 2 : e.z <= lodThreshold ? 1 : 0;
  if (level == 3) {
    emitSurfel(centre, patchNormal[0], patchRadius[0]);
    return;
  }
  uvec4 s = patchSamples[0];
  uint first = s.x + (level <= 1 ? s.y : 0u) + (level == 0 ? s.z : 0u);
  uint count = level == 2 ? s.y : level == 1 ? s.z : s.w;
  for (uint i = 0u; i < count; ++i) {
    vec4 a = objectTexel(2u * (first + i));
    vec4 b = objectTexel(2u * (first + i) + 1u);
    emitSurfel(a.xyz, b.xyz, a.w);
  }
}
)";

// A surfel's or a sprite's disc: the point in the square it covers (from
// the geometry stage, or the sprite's own coordinate), and which side is
// seen: a surfel's facing, or, as a sprite has none, the normal's against
// the eye.
inline constexpr std::string_view kSplatFragment = R"(
in vec3 worldPosition;
in vec3 worldNormal;
#ifdef POINT_SPRITES
vec2 discPoint() { return 2.0 * gl_PointCoord - 1.0; }
bool seesFront(vec3 n) { return dot(n, eye - worldPosition) >= 0.0; }
#else
in vec2 discCoordinates;
vec2 discPoint() { return discCoordinates; }
bool seesFront(vec3 n) { return gl_FrontFacing; }
#endif
layout(location = 0) out vec4 shaded;
layout(location = 1) out vec4 normalAndCoverage;
void main() {
  vec2 d = discPoint();
  if (dot(d, d) > 1.0) discard;
  vec3 n = normalize(worldNormal);
  shaded = shadeFacing(n, worldPosition, seesFront(n));
  normalAndCoverage = vec4(n, 1.0);
}
)";

// Blinn-Phong, grey albedo, under a headlight (the light sits at the eye)
// unless `light` is set: the unit direction towards a distant light, which
// the report's viewer moves (the OSMesa passes leave it zero).
inline constexpr std::string_view kShading = R"(
uniform vec3 eye;
uniform vec3 light;
vec4 shade(vec3 n, vec3 p) {
  vec3 toEye = normalize(eye - p);
  float diffuse, specular;
  if (light == vec3(0.0)) {
    diffuse = max(dot(n, toEye), 0.0);
    specular = pow(diffuse, 32.0);  // the half vector of a headlight is the view direction
  } else {
    diffuse = max(dot(n, light), 0.0);
    specular = diffuse > 0.0 ? pow(max(dot(n, normalize(light + toEye)), 0.0), 32.0) : 0.0;
  }
  vec3 colour = vec3(0.08) + 0.72 * diffuse * vec3(0.85, 0.82, 0.78) + 0.25 * specular * vec3(1.0);
  return vec4(clamp(colour, 0.0, 1.0), 1.0);
}
// A back face (seen from the side its normals turn away from: the unscanned
// side of a one-sided scan) is lit through that side and tinted, so that it
// reads as a back face rather than as black surface. Only the shaded image
// changes; the normal buffers keep the surface's normal.
const vec3 BACK_FACE_TINT = vec3(1.0, 0.62, 0.5);
vec4 shadeFacing(vec3 n, vec3 p, bool front) { return front ? shade(n, p) : vec4(shade(-n, p).rgb * BACK_FACE_TINT, 1.0); }
vec4 shadeSide(vec3 n, vec3 p) { return shadeFacing(n, p, gl_FrontFacing); }
)";

// M (reference) or m (baseline) with their interpolated vertex normals.
inline constexpr std::string_view kVertexNormalFragment = R"(
in vec3 worldPosition;
in vec3 worldNormal;
layout(location = 0) out vec4 shaded;
layout(location = 1) out vec4 normalAndCoverage;
void main() {
  vec3 n = normalize(worldNormal);
  shaded = shadeSide(n, worldPosition);
  normalAndCoverage = vec4(n, 1.0);
}
)";

// What both layouts' walks share: the unit cube, the normal decoding, the
// mip-mapping's pixel test, and the texel-read counter of the
// fetch-counting variant (COUNT_FETCHES defined).
inline constexpr std::string_view kWalkCommon = R"(
uniform uint normalEncoding; // APO_ENCODING_XYZ8 or APO_ENCODING_OCT24
uniform bool defersToCoarse; // the reserved code shows m's own normal
uniform float unitScale;     // unit = world * unitScale + unitOffset
uniform vec3 unitOffset;
uniform bool mipmapping;
uniform float pixelsPerWorldUnitAtOne;  // screen pixels covered by one world unit at distance 1

uint fetchCount = 0u;
void countFetch() {
#ifdef COUNT_FETCHES
  ++fetchCount;
#endif
}

vec2 signNotZero(vec2 v) { return vec2(v.x >= 0.0 ? 1.0 : -1.0, v.y >= 0.0 ? 1.0 : -1.0); }

vec3 decodeNormal(uvec3 rgb) {
  if (normalEncoding == APO_ENCODING_XYZ8) return normalize(vec3(rgb) / APO_XYZ_MAX_LEVEL * 2.0 - 1.0);
  uint bits = rgb.r | (rgb.g << 8) | (rgb.b << 16);
  vec2 uv = vec2(float(bits & APO_OCT_MASK), float(bits >> APO_OCT_BITS)) / APO_OCT_MAX_LEVEL * 2.0 - 1.0;
  vec3 p = vec3(uv, 1.0 - abs(uv.x) - abs(uv.y));
  if (p.z < 0.0) p.xy = (1.0 - abs(p.yx)) * signNotZero(p.xy);
  return normalize(p);
}

bool isCoarseCode(uvec3 rgb) {
  uint code = normalEncoding == APO_ENCODING_XYZ8 ? APO_COARSE_XYZ8 : APO_COARSE_OCT24;
  return (rgb.r | (rgb.g << 8) | (rgb.b << 16)) == code;
}

// Screen pixels a cell of width 1 (unit cube) covers at `distance`, by its diagonal.
float pixelsPerUnitCellAt(float distance) { return sqrt(3.0) / unitScale * pixelsPerWorldUnitAtOne / distance; }

vec3 unitPointOf(vec3 world) { return world * unitScale + unitOffset; }
)";

// The APO walk (paper 5.1 with the completion grid of section 6).
inline constexpr std::string_view kApoWalk = R"(
uniform usampler2D apoTexture;
uniform uint widthMask;      // texture width - 1 (a power of two)
uniform int widthShift;      // log2(texture width)
uniform int completeDepth;

uvec4 texel(uint index) {
  countFetch();
  return texelFetch(apoTexture, ivec2(int(index & widthMask), int(index >> widthShift)), 0);
}

// The set bits of a mask of 8 (bitCount is not in GLSL ES 3.00).
uint countBits8(uint m) {
  m = m - ((m >> 1) & 0x55u);
  m = (m & 0x33u) + ((m >> 2) & 0x33u);
  return (m + (m >> 4)) & 0x0Fu;
}

struct Walk {
  bool found;
  uint node;         // first texel of the node the walk stopped at
  uint normalTexel;  // the texel holding its normal (side 0 of a two-sided leaf)
  int depth;
  bool twoSided;     // a leaf of two texels (format version 4): normalAt picks the side
};

// The grid cell of P, then down the tree: child from the sign of P minus
// the cell centre (lower side on ties), offset from the masks. Stops at a
// leaf, at a missing child, at `maxDepth`, or (mip-mapping) where the cell's
// diagonal covers less than a pixel at `distance`.
Walk walk(vec3 P, int maxDepth, float distance) {
  Walk w = Walk(false, 0u, 0u, 0, false);
  if (any(lessThan(P, vec3(0.0))) || any(greaterThan(P, vec3(1.0)))) return w;
  uint n = 1u << uint(completeDepth);
  float fn = float(n);
  ivec3 cell = clamp(ivec3(ceil(P * fn)) - 1, ivec3(0), ivec3(int(n) - 1));
  uvec4 g = texel((uint(cell.x) * n + uint(cell.y)) * n + uint(cell.z));
  uint node = g.r | (g.g << 8) | (g.b << 16) | (g.a << 24);
  if (node == APO_EMPTY_CELL) return w;
  float width = 1.0 / fn;
  vec3 centre = (vec3(cell) + 0.5) * width;
  int depth = completeDepth;
  float pixelsPerUnitCell = pixelsPerUnitCellAt(distance);
  bool twoTexels = false;  // the parent's kind bit (grid nodes have none)
  for (int step = 0; step < APO_MAX_WALK_STEPS; ++step) {
    uvec4 first = texel(node);
    uint childMask = first.a;
    if (childMask == 0u) return Walk(true, node, node, depth, twoTexels);
    if (depth >= maxDepth || (mipmapping && width * pixelsPerUnitCell < 1.0)) return Walk(true, node, node + 1u, depth, false);
    uint child = (P.x <= centre.x ? 4u : 0u) | (P.y <= centre.y ? 2u : 0u) | (P.z <= centre.z ? 1u : 0u);
    if ((childMask & (1u << child)) == 0u) return Walk(true, node, node + 1u, depth, false);
    uint kindMask = texel(node + 1u).a;
    twoTexels = (kindMask & (1u << child)) != 0u;
    uint before = childMask & ((1u << child) - 1u);
    node += (first.r | (first.g << 8) | (first.b << 16)) + countBits8(before) + countBits8(before & kindMask);
    float quarter = width * 0.25;
    centre += vec3((child & 4u) != 0u ? -quarter : quarter, (child & 2u) != 0u ? -quarter : quarter,
                   (child & 1u) != 0u ? -quarter : quarter);
    width *= 0.5;
    ++depth;
  }
  return Walk(true, node, node, depth, false);
}

// The node's normal, or m's own (`coarseNormal`, the fragment's) where a
// leaf holds the reserved code; of a two-sided leaf, the side m's normal
// picks (format/'s leafSide: side 0 where its coordinate on the leaf's axis
// is not negative).
vec3 normalAt(Walk w, vec3 coarseNormal) {
  uint normalTexel = w.normalTexel;
  if (w.twoSided && coarseNormal[texel(w.node + 1u).a] < 0.0) normalTexel = w.node + 1u;
  uvec3 rgb = texel(normalTexel).rgb;
  if (defersToCoarse && isCoarseCode(rgb)) return coarseNormal;
  return decodeNormal(rgb);
}
)";

// The N^3-tree walk (GPU Gems 2, chapter 37, section 1.2.2): from the root
// grid at (0, 0, 0) of the indirection pool, the cell of P in each grid
// (P N^(L+1), exact in float, ceil - 1 so that ties go to the lower cell
// as in the APO's walk) read by texelFetch, which replaces the chapter's
// normalised coordinates (I + frac(P N^L)) / S and their rounding; a
// pointer cell gives the next grid, a data cell ends the walk, an empty
// cell, `maxDepth` or the pixel test ends it at the node's average in the
// LOD pool (section 1.3.3, MIP-mapping). format/'s lookupN3Tree does the same.
inline constexpr std::string_view kN3Walk = R"(
uniform usampler3D n3Pool;
uniform usampler3D n3Lod;
uniform usampler2D n3Sides;
uniform int n3N;             // 2 or 4
uniform int n3Log2N;
uniform int n3Levels;
uniform uvec3 n3PoolSize;    // cells per axis of the pool
uniform uvec3 n3Grids;       // grids per axis (the LOD pool's size)
uniform bool n3CoarseAtInternalNodes;

uvec4 poolCell(ivec3 at) {
  countFetch();
  return texelFetch(n3Pool, at, 0);
}

struct Walk {
  bool found;
  uint node;     // where it stopped: the pool cell's index, or the pool's cells + the grid's (a node's average)
  int depth;     // octree depth of that cell or node
  uvec4 value;   // the cell's bytes, or the LOD pool's
  bool average;
};

Walk averageOf(ivec3 grid, int level) {
  countFetch();
  uint index = n3PoolSize.x * n3PoolSize.y * n3PoolSize.z + uint(grid.x) + n3Grids.x * (uint(grid.y) + n3Grids.y * uint(grid.z));
  return Walk(true, index, level * n3Log2N, texelFetch(n3Lod, grid, 0), true);
}

Walk walk(vec3 P, int maxDepth, float distance) {
  Walk w = Walk(false, 0u, 0, uvec4(0u), false);
  if (any(lessThan(P, vec3(0.0))) || any(greaterThan(P, vec3(1.0)))) return w;
  float pixelsPerUnitCell = pixelsPerUnitCellAt(distance);
  float fn = float(n3N);
  float width = 1.0;
  ivec3 grid = ivec3(0);
  vec3 scaled = P;
  for (int level = 0; level < N3_MAX_LEVELS && level < n3Levels; ++level) {
    if ((level + 1) * n3Log2N > maxDepth || (mipmapping && width * pixelsPerUnitCell < 1.0)) return averageOf(grid, level);
    scaled *= fn;
    ivec3 cell = grid * n3N + (max(ivec3(ceil(scaled)) - 1, ivec3(0)) & ivec3(n3N - 1));
    uvec4 value = poolCell(cell);
    if (value.a == N3_POINTER) {
      grid = ivec3(value.rgb);
      width /= fn;
      continue;
    }
    if (value.a == N3_EMPTY) return averageOf(grid, level);
    return Walk(true, uint(cell.x) + n3PoolSize.x * (uint(cell.y) + n3PoolSize.y * uint(cell.z)), (level + 1) * n3Log2N,
                value, false);
  }
  return w;
}

// The cell's normal, or m's own where it holds the reserved code; of a
// two-sided leaf, the side m's normal picks from the sides texture.
vec3 normalAt(Walk w, vec3 coarseNormal) {
  uvec4 v = w.value;
  if (!w.average && v.a >= N3_TWO_SIDED && v.a < N3_DATA) {
    uint leaf = v.r | (v.g << 8) | (v.b << 16);
    uint index = 2u * leaf + (coarseNormal[int(v.a - N3_TWO_SIDED)] < 0.0 ? 1u : 0u);
    countFetch();
    return decodeNormal(texelFetch(n3Sides, ivec2(int(index & ((1u << N3_SIDES_WIDTH_SHIFT) - 1u)), int(index >> N3_SIDES_WIDTH_SHIFT)), 0).rgb);
  }
  if ((w.average ? n3CoarseAtInternalNodes : defersToCoarse) && isCoarseCode(v.rgb)) return coarseNormal;
  return decodeNormal(v.rgb);
}
)";

// Paper 5.3 (and the chapter's linear interpolation, 8 samples at the
// lattice of P's own cell), over either walk.
inline constexpr std::string_view kFilter = R"(

// Paper 5.3: the normal blended trilinearly from the 8 cells around P at the
// depth of P's own cell, each reached by its own walk; a neighbour that is
// missing, stops more than one level higher, or faces away from m's normal
// at P (the other side of a thin part) gives P's own normal (format/'s
// lookupTextureFiltered does the same).
vec3 filteredNormal(vec3 P, Walk own, float distance, vec3 coarseNormal) {
  vec3 ownNormal = normalAt(own, coarseNormal);
  float width = 1.0 / float(1u << uint(own.depth));
  vec3 lattice = P / width - 0.5;
  vec3 base = floor(lattice);
  vec3 t = lattice - base;
  vec3 sum = vec3(0.0);
  for (int corner = 0; corner < 8; ++corner) {
    vec3 c = vec3(float((corner >> 2) & 1), float((corner >> 1) & 1), float(corner & 1));
    vec3 weight3 = mix(1.0 - t, t, c);
    float weight = weight3.x * weight3.y * weight3.z;
    Walk w = walk((base + c + 0.5) * width, own.depth, distance);
    vec3 neighbour = w.found ? normalAt(w, coarseNormal) : ownNormal;
    sum += weight * (w.found && w.depth + 1 >= own.depth && dot(neighbour, coarseNormal) > 0.0 ? neighbour : ownNormal);
  }
  return normalize(sum);
}
)";

// m shaded with the APO's normal; outside the octree, m's own normal. The
// fetch-counting variant writes the fragment's texel reads instead of its
// normal.
inline constexpr std::string_view kApoFragment = R"(
in vec3 worldPosition;
in vec3 worldNormal;
layout(location = 0) out vec4 shaded;
layout(location = 1) out vec4 normalAndCoverage;
uniform bool filtering;
void main() {
  vec3 P = unitPointOf(worldPosition);
  float distance = length(eye - worldPosition);
  Walk w = walk(P, 255, distance);
  vec3 coarseNormal = normalize(worldNormal);
  vec3 n = !w.found ? coarseNormal : normalAt(w, coarseNormal);
  // A leaf showing m's normal shows it unblended (lookupTextureFiltered).
  if (w.found && filtering && n != coarseNormal) n = filteredNormal(P, w, distance, coarseNormal);
  shaded = shadeSide(n, worldPosition);
#ifdef COUNT_FETCHES
  normalAndCoverage = vec4(float(fetchCount), 0.0, 0.0, 1.0);
#else
  normalAndCoverage = vec4(n, 1.0);
#endif
}
)";

// The exactness pass: the unit-cube point the walk used (exact floats) and
// the node it stopped at (four bytes), for comparison with the CPU walk.
inline constexpr std::string_view kApoExactnessFragment = R"(
in vec3 worldPosition;
in vec3 worldNormal;
layout(location = 0) out vec4 nodeBytes;
layout(location = 1) out vec4 unitPointAndCoverage;
void main() {
  vec3 P = unitPointOf(worldPosition);
  Walk w = walk(P, 255, 1.0);
  uint node = w.found ? w.node : APO_EMPTY_CELL;
  nodeBytes = vec4(float(node & 0xFFu), float((node >> 8) & 0xFFu), float((node >> 16) & 0xFFu), float(node >> 24)) / 255.0;
  unitPointAndCoverage = vec4(P, 1.0);
}
)";

// ---- The report's viewer only (WebGL2, no geometry stage) ------------------

// M as points in WebGL2, after kPointAttributes: each point a round sprite
// of its disc's projected diameter, facing the eye (the OSMesa passes' discs
// lie in the tangent plane). kSplatFragment with POINT_SPRITES defined.
inline constexpr std::string_view kPointSpriteVertex = R"(
uniform mat4 viewProjection;
uniform float pixelsPerWorldUnitAtOne;
out vec3 worldPosition;
out vec3 worldNormal;
void main() {
  worldPosition = position;
  worldNormal = normal;
  gl_Position = viewProjection * vec4(position, 1.0);
  gl_PointSize = clamp(2.0 * radius * pixelsPerWorldUnitAtOne / max(gl_Position.w, 1e-6), 1.0, 1023.0);
}
)";

// One triangle covering the viewport.
inline constexpr std::string_view kScreenVertex = R"(
void main() {
  vec2 corner = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
  gl_Position = vec4(2.0 * corner - 1.0, 0.0, 1.0);
}
)";
// The heat map of the current view: the angle between two normal buffers
// (as render/metrics.cpp's angleDegrees, by atan2), coloured by the same
// viridis scale as the report's images (glslViridis); grey where only one
// buffer covers the pixel, white (the background) where neither does.
inline constexpr std::string_view kHeatFragment = R"(
uniform highp sampler2D apoNormals;
uniform highp sampler2D referenceNormals;
uniform float heatMapDegrees;
out vec4 colour;
vec3 viridis(float t) {
  float scaled = clamp(t, 0.0, 1.0) * float(VIRIDIS.length() - 1);
  int i = min(int(scaled), VIRIDIS.length() - 2);
  return mix(VIRIDIS[i], VIRIDIS[i + 1], scaled - float(i));
}
void main() {
  ivec2 pixel = ivec2(gl_FragCoord.xy);
  vec4 a = texelFetch(apoNormals, pixel, 0);
  vec4 r = texelFetch(referenceNormals, pixel, 0);
  if (a.w < 0.5 || r.w < 0.5) {
    colour = vec4(a.w >= 0.5 || r.w >= 0.5 ? vec3(0.75) : vec3(1.0), 1.0);
    return;
  }
  float degrees = degrees(atan(length(cross(a.xyz, r.xyz)), dot(a.xyz, r.xyz)));
  colour = vec4(viridis(degrees / heatMapDegrees), 1.0);
}
)";

// "const vec3 VIRIDIS[33] = ...;": the heat maps' colour table (metrics.cpp).
std::string glslViridis();

}  // namespace apo::shaders
