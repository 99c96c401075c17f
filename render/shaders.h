// GLSL sources of the passes (internal to render/). One vertex shader for
// every mesh; fragment shaders for M or m with their own normals, and for m
// with the APO, whose walk repeats format/'s lookupTexture operation for
// operation so that both land on the same node (see the exactness pass).
// The walk uses the layout's constants (APO_*) from glslLayoutDefinitions()
// (format/format.h), which passes.cpp puts before it.
#pragma once

#include <string_view>

namespace apo::shaders {

inline constexpr std::string_view kMeshVertex = R"(#version 450 core
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

// M as points: each point an oriented disc (surfel) of its spacing's radius,
// flat-shaded with the point's normal. The geometry stage turns each point
// into a square in its tangent plane; the fragment stage cuts the disc out.
inline constexpr std::string_view kSplatVertex = R"(#version 450 core
layout(location = 0) in vec3 position;
layout(location = 1) in vec3 normal;
layout(location = 2) in float radius;
out vec3 splatNormal;
out float splatRadius;
void main() {
  gl_Position = vec4(position, 1.0);
  splatNormal = normal;
  splatRadius = radius;
}
)";

inline constexpr std::string_view kSplatGeometry = R"(#version 450 core
layout(points) in;
layout(triangle_strip, max_vertices = 4) out;
in vec3 splatNormal[];
in float splatRadius[];
uniform mat4 viewProjection;
out vec3 worldPosition;
out vec3 worldNormal;
out vec2 discCoordinates;
void main() {
  vec3 centre = gl_in[0].gl_Position.xyz;
  vec3 n = normalize(splatNormal[0]);
  vec3 u = normalize(cross(n, abs(n.x) < 0.9 ? vec3(1.0, 0.0, 0.0) : vec3(0.0, 1.0, 0.0)));
  vec3 v = cross(n, u);
  for (int corner = 0; corner < 4; ++corner) {
    vec2 d = vec2((corner & 1) != 0 ? 1.0 : -1.0, (corner & 2) != 0 ? 1.0 : -1.0);
    worldPosition = centre + splatRadius[0] * (d.x * u + d.y * v);
    worldNormal = n;
    discCoordinates = d;
    gl_Position = viewProjection * vec4(worldPosition, 1.0);
    EmitVertex();
  }
  EndPrimitive();
}
)";

inline constexpr std::string_view kSplatFragment = R"(
in vec3 worldPosition;
in vec3 worldNormal;
in vec2 discCoordinates;
layout(location = 0) out vec4 shaded;
layout(location = 1) out vec4 normalAndCoverage;
void main() {
  if (dot(discCoordinates, discCoordinates) > 1.0) discard;
  vec3 n = normalize(worldNormal);
  shaded = shade(n, worldPosition);
  normalAndCoverage = vec4(n, 1.0);
}
)";

// Blinn-Phong under a headlight (the light sits at the eye), grey albedo.
inline constexpr std::string_view kShading = R"(
uniform vec3 eye;
vec4 shade(vec3 n, vec3 p) {
  vec3 toEye = normalize(eye - p);
  float diffuse = max(dot(n, toEye), 0.0);
  float specular = pow(diffuse, 32.0);  // the half vector of a headlight is the view direction
  vec3 colour = vec3(0.08) + 0.72 * diffuse * vec3(0.85, 0.82, 0.78) + 0.25 * specular * vec3(1.0);
  return vec4(clamp(colour, 0.0, 1.0), 1.0);
}
)";

// M (reference) or m (baseline) with their interpolated vertex normals.
inline constexpr std::string_view kVertexNormalFragment = R"(
in vec3 worldPosition;
in vec3 worldNormal;
layout(location = 0) out vec4 shaded;
layout(location = 1) out vec4 normalAndCoverage;
void main() {
  vec3 n = normalize(worldNormal);
  shaded = shade(n, worldPosition);
  normalAndCoverage = vec4(n, 1.0);
}
)";

// The APO walk (paper 5.1 with the completion grid of section 6).
inline constexpr std::string_view kApoWalk = R"(
uniform usampler2D apoTexture;
uniform uint widthMask;      // texture width - 1 (a power of two)
uniform int widthShift;      // log2(texture width)
uniform int completeDepth;
uniform uint normalEncoding; // APO_ENCODING_XYZ8 or APO_ENCODING_OCT24
uniform bool defersToCoarse; // format versions 3 and 4: the reserved code shows m's own normal
uniform float unitScale;     // unit = world * unitScale + unitOffset
uniform vec3 unitOffset;
uniform bool mipmapping;
uniform float pixelsPerWorldUnitAtOne;  // screen pixels covered by one world unit at distance 1

// The fetch-counting variant (COUNT_FETCHES defined) counts every texel read.
uint fetchCount = 0u;
uvec4 texel(uint index) {
#ifdef COUNT_FETCHES
  ++fetchCount;
#endif
  return texelFetch(apoTexture, ivec2(int(index & widthMask), int(index >> widthShift)), 0);
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
  float pixelsPerUnitCell = sqrt(3.0) / unitScale * pixelsPerWorldUnitAtOne / distance;
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
    node += (first.r | (first.g << 8) | (first.b << 16)) + uint(bitCount(before)) + uint(bitCount(before & kindMask));
    float quarter = width * 0.25;
    centre += vec3((child & 4u) != 0u ? -quarter : quarter, (child & 2u) != 0u ? -quarter : quarter,
                   (child & 1u) != 0u ? -quarter : quarter);
    width *= 0.5;
    ++depth;
  }
  return Walk(true, node, node, depth, false);
}

vec3 unitPointOf(vec3 world) { return world * unitScale + unitOffset; }

// The node's normal, or m's own (`coarseNormal`, the fragment's) where a
// leaf holds the reserved code; of a two-sided leaf, the side m's normal
// picks (format/'s leafSide: side 0 where its coordinate on the leaf's axis
// is not negative).
vec3 normalAt(Walk w, vec3 coarseNormal) {
  uint normalTexel = w.normalTexel;
  if (w.twoSided && coarseNormal[texel(w.node + 1u).a] < 0.0) normalTexel = w.node + 1u;
  uvec3 rgb = texel(normalTexel).rgb;
  uint code = normalEncoding == APO_ENCODING_XYZ8 ? APO_COARSE_XYZ8 : APO_COARSE_OCT24;
  if (defersToCoarse && (rgb.r | (rgb.g << 8) | (rgb.b << 16)) == code) return coarseNormal;
  return decodeNormal(rgb);
}

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
  shaded = shade(n, worldPosition);
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

}  // namespace apo::shaders
