// What the report's viewer needs from render/: the passes' shaders as GLSL
// ES 3.00 for WebGL2 (the same texts as the OSMesa passes, so the viewer
// walks the APO as the renders do), the APO's uniforms, and the geometry
// as the passes draw it (docs/report.md, "The viewer").
#include "render/render.h"

#include "core/text.h"
#include "render/shaders.h"

#include <fmt/format.h>

#include <bit>

namespace apo {
namespace {

constexpr std::string_view kEsPrelude =
    "#version 300 es\nprecision highp float;\nprecision highp int;\nprecision highp usampler2D;\n";

// Points are sprites facing the eye: WebGL2 has no geometry stage for surfels.
constexpr std::string_view kPointSprites = "#define POINT_SPRITES\n";

std::string es(std::initializer_list<std::string_view> parts) {
  std::string source(kEsPrelude);
  for (std::string_view part : parts) source += part;
  return source;
}

void appendVec3(std::vector<float>& out, const Vec3f& v) { out.insert(out.end(), v.data(), v.data() + 3); }

}  // namespace

ViewerShaders webglShaders() {
  ViewerShaders s;
  s.meshVertex = es({shaders::kMeshVertex});
  s.meshFragment = es({shaders::kShading, shaders::kVertexNormalFragment});
  s.apoFragment = es({shaders::kShading, glslLayoutDefinitions(), shaders::kWalkCommon, shaders::kApoWalk, shaders::kFilter,
                      shaders::kApoFragment});
  s.pointVertex = es({shaders::kPointAttributes, shaders::kPointSpriteVertex});
  s.pointFragment = es({kPointSprites, shaders::kShading, shaders::kSplatFragment});
  s.screenVertex = es({shaders::kScreenVertex});
  s.heatFragment = es({shaders::glslViridis(), shaders::kHeatFragment});
  return s;
}

// The uniforms passes.cpp sets for the APO layout (apoLayout) and its walk
// (setWalkUniforms), but for the camera's, the filter's and the mip-mapping
// switch, which the viewer sets per frame.
void setWebglApo(const ApoTexture& apo, ViewerScene& scene) {
  scene.apoUniforms = {
      {"widthMask", "1ui", {static_cast<double>(apo.width - 1)}},
      {"widthShift", "1i", {static_cast<double>(std::countr_zero(apo.width))}},
      {"completeDepth", "1i", {static_cast<double>(apo.completeDepth)}},
      {"normalEncoding", "1ui", {static_cast<double>(apo.encoding)}},
      {"defersToCoarse", "1i", {apo.defersToCoarse ? 1.0 : 0.0}},
      {"unitScale", "1f", {static_cast<double>(static_cast<float>(apo.transform.scale))}},
      {"unitOffset", "3f", {static_cast<double>(static_cast<float>(apo.transform.offset[0])),
                            static_cast<double>(static_cast<float>(apo.transform.offset[1])),
                            static_cast<double>(static_cast<float>(apo.transform.offset[2]))}},
  };
  scene.textureWidth = apo.width;
  scene.textureHeight = apo.height;
  scene.texture = apo.texels;
}

ViewerGeometry webglMesh(const Scan& mesh) {
  ViewerGeometry g;
  const std::vector<Vec3f> normals = vertexNormalsAsDrawn(mesh);
  g.positions.reserve(3 * mesh.points.size());
  g.normals.reserve(3 * mesh.points.size());
  for (std::size_t i = 0; i < mesh.points.size(); ++i) {
    appendVec3(g.positions, mesh.points.positions[i]);
    appendVec3(g.normals, normals[i]);
  }
  g.indices.reserve(3 * mesh.triangles.size());
  for (const Triangle& t : mesh.triangles) g.indices.insert(g.indices.end(), t.begin(), t.end());
  return g;
}

Result<ViewerGeometry> webglPoints(const PointSet& points, std::size_t maxPoints) {
  auto lod = buildPointLod(points);
  if (!lod) return lod.error();
  int level = 0;
  while (level + 1 < kLodLevels && lod->levels[level].size() > maxPoints) ++level;
  ViewerGeometry g;
  for (const Surfel& s : lod->levels[level]) {
    appendVec3(g.positions, s.position);
    appendVec3(g.normals, s.normal);
    g.radii.push_back(s.radius);
  }
  g.description = level == 0 ? fmt::format("M as its {} points", groupedDigits(points.size()))
                             : fmt::format("M as points: level {} of the point LOD, {} discs for {} points", level,
                                           groupedDigits(lod->levels[level].size()), groupedDigits(points.size()));
  return g;
}

}  // namespace apo
