// The passes of each view (reference M, baseline m, m with the APO) and the
// exactness pass, drawn into the OSMesa context's offscreen target.
#include "adapters/flann/flann_search.h"
#include "adapters/osmesa/gl_context.h"
#include "render/gl_program.h"
#include "render/gl_readback.h"
#include "render/gl_texture.h"
#include "render/render.h"
#include "render/shaders.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <initializer_list>
#include <bit>
#include <cmath>
#include <memory>
#include <numbers>
#include <functional>
#include <optional>
#include <string>

namespace apo {
namespace {

constexpr std::array<float, 4> kBackground = {1.0f, 1.0f, 1.0f, 1.0f};
// llvmpipe's GL_MAX_RENDERBUFFER_SIZE; the context refuses more on other drivers.
constexpr int kLargestImage = 16384;
// The 6 axis directions and the 8 cube diagonals (standardViews).
constexpr int kStandardViewCount = 14;
constexpr int kMostTimedFrames = 1000;

float radians(float degrees) { return degrees * std::numbers::pi_v<float> / 180.0f; }

Eigen::Matrix4f lookAt(const Camera& c) {
  const Vec3f forward = (c.target - c.eye).normalized();
  const Vec3f side = forward.cross(c.up).normalized();
  const Vec3f up = side.cross(forward);
  Eigen::Matrix4f view = Eigen::Matrix4f::Identity();
  view.block<1, 3>(0, 0) = side.transpose();
  view.block<1, 3>(1, 0) = up.transpose();
  view.block<1, 3>(2, 0) = -forward.transpose();
  view(0, 3) = -side.dot(c.eye);
  view(1, 3) = -up.dot(c.eye);
  view(2, 3) = forward.dot(c.eye);
  return view;
}

Eigen::Matrix4f perspective(const Camera& c) {
  const float f = 1.0f / std::tan(0.5f * radians(c.fovYDegrees));
  Eigen::Matrix4f p = Eigen::Matrix4f::Zero();
  p(0, 0) = f;
  p(1, 1) = f;
  p(2, 2) = (c.farPlane + c.nearPlane) / (c.nearPlane - c.farPlane);
  p(2, 3) = 2.0f * c.farPlane * c.nearPlane / (c.nearPlane - c.farPlane);
  p(3, 2) = -1.0f;
  return p;
}

// Geometry in GL buffers: a mesh (interleaved position and normal, then
// indices), a point cloud as splats (position, normal, disc radius), or the
// point LOD's patches (position, normal, radius, errors; then their place
// in the object texture, integers, in the second buffer).
enum class GeometryKind { Mesh, Splats, LodPatches };
struct GpuGeometry {
  gl::VertexArray vertexArray;
  gl::Buffer vertices, indices;
  GLsizei count = 0;  // indices of a mesh, points of a cloud, patches of a LOD
  GeometryKind kind = GeometryKind::Mesh;
  gl::Texture objectTexture;  // the LOD's finer levels
  std::uint64_t primitives() const { return kind == GeometryKind::Mesh ? static_cast<std::uint64_t>(count) / 3 : count; }
};

// The texels per row of the point LOD's object texture (2 per surfel).
constexpr std::uint32_t kObjectTextureWidthShift = 12;

// Binds float attributes 0, 1, ... of the given widths, interleaved.
void describeInterleaved(const gl::Api& api, std::initializer_list<GLint> widths) {
  GLint stride = 0;
  for (GLint width : widths) stride += width;
  GLuint attribute = 0;
  std::uintptr_t offset = 0;
  for (GLint width : widths) {
    api.EnableVertexAttribArray(attribute);
    api.VertexAttribPointer(attribute++, width, GL_FLOAT, GL_FALSE, stride * static_cast<GLsizei>(sizeof(float)),
                            reinterpret_cast<const void*>(offset));
    offset += static_cast<std::uintptr_t>(width) * sizeof(float);
  }
}

GpuGeometry uploadMesh(const gl::Api& api, const Scan& mesh) {
  const std::vector<Vec3f> normals = vertexNormalsAsDrawn(mesh);
  std::vector<float> interleaved;
  interleaved.reserve(6 * mesh.points.size());
  for (std::size_t i = 0; i < mesh.points.size(); ++i)
    for (const Vec3f* v : {&mesh.points.positions[i], &normals[i]}) interleaved.insert(interleaved.end(), v->data(), v->data() + 3);
  GpuGeometry gpu{gl::makeVertexArray(api), gl::makeBuffer(api), gl::makeBuffer(api),
                  static_cast<GLsizei>(3 * mesh.triangles.size()), GeometryKind::Mesh, {}};
  api.BindVertexArray(gpu.vertexArray.id());
  api.BindBuffer(GL_ARRAY_BUFFER, gpu.vertices.id());
  api.BufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(interleaved.size() * sizeof(float)), interleaved.data(),
                 GL_STATIC_DRAW);
  api.BindBuffer(GL_ELEMENT_ARRAY_BUFFER, gpu.indices.id());
  api.BufferData(GL_ELEMENT_ARRAY_BUFFER, static_cast<GLsizeiptr>(mesh.triangles.size() * sizeof(Triangle)),
                 mesh.triangles.data(), GL_STATIC_DRAW);
  describeInterleaved(api, {3, 3});
  api.BindVertexArray(0);
  return gpu;
}

// The points with their normals and disc radii (adapters/flann's discRadii:
// the same discs the bake's rays hit).
Result<GpuGeometry> uploadSplats(const gl::Api& api, const PointSet& points) {
  if (!points.hasNormals()) return badInput("render: M is a point cloud without normals (run apo ingest, which estimates them)");
  const Result<std::vector<float>> found = discRadii(points);
  if (!found) return found.error();
  const std::vector<float>& radii = *found;
  std::vector<float> interleaved;
  interleaved.reserve(7 * points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    for (const Vec3f* v : {&points.positions[i], &points.normals[i]}) interleaved.insert(interleaved.end(), v->data(), v->data() + 3);
    interleaved.push_back(radii[i]);
  }
  GpuGeometry gpu{gl::makeVertexArray(api), gl::makeBuffer(api), gl::Buffer(), static_cast<GLsizei>(points.size()),
                  GeometryKind::Splats, {}};
  api.BindVertexArray(gpu.vertexArray.id());
  api.BindBuffer(GL_ARRAY_BUFFER, gpu.vertices.id());
  api.BufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(interleaved.size() * sizeof(float)), interleaved.data(),
                 GL_STATIC_DRAW);
  describeInterleaved(api, {3, 3, 1});
  api.BindVertexArray(0);
  return gpu;
}

// The point LOD: one vertex per patch, its finer levels in the object
// texture (per surfel: centre and radius, then normal).
Result<GpuGeometry> uploadPointLod(const gl::Context& context, const PointSet& points) {
  auto lod = buildPointLod(points);
  if (!lod) return lod.error();
  const gl::Api& api = context.api();
  std::vector<float> surfels;
  surfels.reserve(8 * lod->objectTexture.size());
  for (const Surfel& s : lod->objectTexture) {
    surfels.insert(surfels.end(), {s.position.x(), s.position.y(), s.position.z(), s.radius});
    surfels.insert(surfels.end(), {s.normal.x(), s.normal.y(), s.normal.z(), 0.0f});
  }
  auto texture = gl::uploadFloatTexture(context, 1u << kObjectTextureWidthShift, surfels, "the point LOD's object texture");
  if (!texture) return texture.error();
  std::vector<float> floats;
  std::vector<std::uint32_t> integers;
  const std::vector<Surfel>& patches = lod->levels[kLodLevels - 1];
  for (std::size_t i = 0; i < patches.size(); ++i) {
    const Surfel& p = patches[i];
    const LodPatch& finer = lod->patches[i];
    floats.insert(floats.end(), {p.position.x(), p.position.y(), p.position.z(), p.normal.x(), p.normal.y(), p.normal.z(),
                                 p.radius, lodError(p), finer.maxError[0], finer.maxError[1], finer.maxError[2]});
    integers.insert(integers.end(), {finer.first, finer.count[0], finer.count[1], finer.count[2]});
  }
  GpuGeometry gpu{gl::makeVertexArray(api), gl::makeBuffer(api), gl::makeBuffer(api), static_cast<GLsizei>(patches.size()),
                  GeometryKind::LodPatches, std::move(texture).value()};
  api.BindVertexArray(gpu.vertexArray.id());
  api.BindBuffer(GL_ARRAY_BUFFER, gpu.vertices.id());
  api.BufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(floats.size() * sizeof(float)), floats.data(), GL_STATIC_DRAW);
  describeInterleaved(api, {3, 3, 1, 4});
  api.BindBuffer(GL_ARRAY_BUFFER, gpu.indices.id());
  api.BufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(integers.size() * sizeof(std::uint32_t)), integers.data(),
                 GL_STATIC_DRAW);
  api.EnableVertexAttribArray(4);
  api.VertexAttribIPointer(4, 4, GL_UNSIGNED_INT, 0, nullptr);
  api.BindVertexArray(0);
  return gpu;
}

enum class Walk { None, Plain, CountingFetches };

// What the APO pass walks on m: the APO texture or the same octree as an
// N^3-tree. Its GLSL (the layout's walk: `walk`, `normalAt`, the `Walk`
// struct), its textures on units 0, 1, ... and its own uniforms; the
// fragment bodies are the same for both.
struct Layout {
  std::string_view walkSource;
  std::string definitions;
  std::vector<std::pair<GLenum, gl::Texture>> textures;
  std::function<void(const gl::Api&, GLuint)> setUniforms;
  UnitCubeTransform transform;
  NormalEncoding encoding = NormalEncoding::Oct24;
  bool defersToCoarse = false;
};

Result<Layout> apoLayout(const gl::Context& context, const ApoTexture& apo) {
  auto texture = gl::uploadApoTexture(context, apo);
  if (!texture) return texture.error();
  Layout layout{shaders::kApoWalk, {}, {}, {}, apo.transform, apo.encoding, apo.defersToCoarse};
  layout.textures.emplace_back(GL_TEXTURE_2D, std::move(texture).value());
  const std::uint32_t width = apo.width;
  const int completeDepth = apo.completeDepth;
  layout.setUniforms = [width, completeDepth](const gl::Api& api, GLuint program) {
    api.Uniform1i(api.GetUniformLocation(program, "apoTexture"), 0);
    api.Uniform1ui(api.GetUniformLocation(program, "widthMask"), width - 1);
    api.Uniform1i(api.GetUniformLocation(program, "widthShift"), std::countr_zero(width));
    api.Uniform1i(api.GetUniformLocation(program, "completeDepth"), completeDepth);
  };
  return layout;
}

Result<Layout> n3TreeLayout(const gl::Context& context, const N3Tree& tree) {
  const std::array<std::uint32_t, 3> pool = tree.poolSize();
  auto poolTexture = gl::uploadRgba8Texture(context, pool[0], pool[1], pool[2], tree.pool, "the N^3-tree's indirection pool");
  if (!poolTexture) return poolTexture.error();
  auto lodTexture = gl::uploadRgba8Texture(context, tree.grids[0], tree.grids[1], tree.grids[2], tree.lod, "the N^3-tree's LOD pool");
  if (!lodTexture) return lodTexture.error();
  // GL refuses a texture of no rows: a tree without two-sided leaves binds one row of zeros.
  const std::vector<std::uint8_t> noSides(4 * N3Tree::kSidesWidth, 0);
  const bool anySides = tree.sidesRows() > 0;
  auto sidesTexture = gl::uploadRgba8Texture(context, N3Tree::kSidesWidth, anySides ? tree.sidesRows() : 1, 0,
                                             anySides ? tree.sides : noSides, "the N^3-tree's sides");
  if (!sidesTexture) return sidesTexture.error();
  Layout layout{shaders::kN3Walk, glslN3TreeDefinitions(), {}, {}, tree.transform, tree.encoding, tree.defersToCoarse};
  layout.textures.emplace_back(GL_TEXTURE_3D, std::move(poolTexture).value());
  layout.textures.emplace_back(GL_TEXTURE_3D, std::move(lodTexture).value());
  layout.textures.emplace_back(GL_TEXTURE_2D, std::move(sidesTexture).value());
  const int n = tree.n, log2n = tree.log2n(), levels = tree.levels;
  const std::array<std::uint32_t, 3> grids = tree.grids;
  const bool coarseAtInternalNodes = tree.coarseAtInternalNodes;
  layout.setUniforms = [=](const gl::Api& api, GLuint program) {
    api.Uniform1i(api.GetUniformLocation(program, "n3Pool"), 0);
    api.Uniform1i(api.GetUniformLocation(program, "n3Lod"), 1);
    api.Uniform1i(api.GetUniformLocation(program, "n3Sides"), 2);
    api.Uniform1i(api.GetUniformLocation(program, "n3N"), n);
    api.Uniform1i(api.GetUniformLocation(program, "n3Log2N"), log2n);
    api.Uniform1i(api.GetUniformLocation(program, "n3Levels"), levels);
    api.Uniform3ui(api.GetUniformLocation(program, "n3PoolSize"), pool[0], pool[1], pool[2]);
    api.Uniform3ui(api.GetUniformLocation(program, "n3Grids"), grids[0], grids[1], grids[2]);
    api.Uniform1i(api.GetUniformLocation(program, "n3CoarseAtInternalNodes"), coarseAtInternalNodes ? 1 : 0);
  };
  return layout;
}

constexpr std::string_view kDesktopVersion = "#version 450 core\n";

std::string fragmentSource(std::string_view body, Walk walk, const Layout& layout) {
  std::string source(kDesktopVersion);
  if (walk == Walk::CountingFetches) source += "#define COUNT_FETCHES\n";
  source += shaders::kShading;
  if (walk != Walk::None) {
    source += glslLayoutDefinitions();
    source += layout.definitions;
    source += shaders::kWalkCommon;
    source += layout.walkSource;
    source += shaders::kFilter;
  }
  source += body;
  return source;
}

// The programs of the passes, built once per context.
struct Programs {
  gl::Program vertexNormals, splats, pointLod, apo, apoCountingFetches, exactness;
};

Result<Programs> buildPrograms(const gl::Api& api, const Layout& layout) {
  Programs programs;
  const auto build = [&](gl::Program& program, std::string_view body, Walk walk,
                         std::string_view vertex = shaders::kMeshVertex, std::string_view geometry = {}) -> Status {
    auto built = gl::buildProgram(api, std::string(kDesktopVersion) + std::string(vertex), fragmentSource(body, walk, layout),
                                  geometry.empty() ? std::string() : std::string(kDesktopVersion) + std::string(geometry));
    if (!built) return built.error();
    program = std::move(built).value();
    return okStatus();
  };
  APO_RETURN_IF_ERROR(build(programs.vertexNormals, shaders::kVertexNormalFragment, Walk::None));
  const std::string splatGeometry = std::string(shaders::kSplatGeometry) + std::string(shaders::kEmitSurfel) +
                                    std::string(shaders::kSplatGeometryMain);
  const std::string lodGeometry = std::string(shaders::kLodGeometry) + std::string(shaders::kEmitSurfel) +
                                  std::string(shaders::kLodGeometryMain);
  const std::string splatVertex = std::string(shaders::kPointAttributes) + std::string(shaders::kSplatVertex);
  const std::string lodVertex = std::string(shaders::kPointAttributes) + std::string(shaders::kLodVertex);
  APO_RETURN_IF_ERROR(build(programs.splats, shaders::kSplatFragment, Walk::None, splatVertex, splatGeometry));
  APO_RETURN_IF_ERROR(build(programs.pointLod, shaders::kSplatFragment, Walk::None, lodVertex, lodGeometry));
  APO_RETURN_IF_ERROR(build(programs.apo, shaders::kApoFragment, Walk::Plain));
  APO_RETURN_IF_ERROR(build(programs.apoCountingFetches, shaders::kApoFragment, Walk::CountingFetches));
  APO_RETURN_IF_ERROR(build(programs.exactness, shaders::kApoExactnessFragment, Walk::Plain));
  return programs;
}

void setCameraUniforms(const gl::Api& api, GLuint program, const Camera& camera) {
  const Eigen::Matrix4f viewProjection = perspective(camera) * lookAt(camera);
  api.UniformMatrix4fv(api.GetUniformLocation(program, "viewProjection"), 1, GL_FALSE, viewProjection.data());
  api.Uniform3f(api.GetUniformLocation(program, "eye"), camera.eye.x(), camera.eye.y(), camera.eye.z());
}

// Screen pixels one world unit covers at distance 1 from the eye.
float pixelsPerWorldUnitAtOne(const Camera& camera, int size) {
  return static_cast<float>(size) / (2.0f * std::tan(0.5f * radians(camera.fovYDegrees)));
}

void setWalkUniforms(const gl::Api& api, GLuint program, const Layout& layout, const Camera& camera, int size,
                     bool mipmapping) {
  layout.setUniforms(api, program);
  api.Uniform1ui(api.GetUniformLocation(program, "normalEncoding"), static_cast<GLuint>(layout.encoding));
  api.Uniform1i(api.GetUniformLocation(program, "defersToCoarse"), layout.defersToCoarse ? 1 : 0);
  api.Uniform1f(api.GetUniformLocation(program, "unitScale"), static_cast<float>(layout.transform.scale));
  api.Uniform3f(api.GetUniformLocation(program, "unitOffset"), static_cast<float>(layout.transform.offset[0]),
                static_cast<float>(layout.transform.offset[1]), static_cast<float>(layout.transform.offset[2]));
  api.Uniform1i(api.GetUniformLocation(program, "mipmapping"), mipmapping ? 1 : 0);
  api.Uniform1f(api.GetUniformLocation(program, "pixelsPerWorldUnitAtOne"), pixelsPerWorldUnitAtOne(camera, size));
}

void draw(const gl::Api& api, const GpuGeometry& geometry) {
  api.BindVertexArray(geometry.vertexArray.id());
  if (geometry.kind != GeometryKind::Mesh)
    api.DrawArrays(GL_POINTS, 0, geometry.count);
  else
    api.DrawElements(GL_TRIANGLES, geometry.count, GL_UNSIGNED_INT, nullptr);
  api.BindVertexArray(0);
}

Result<PassImages> readPass(const gl::Context& context) {
  auto shaded = gl::readShadedImage(context);
  if (!shaded) return shaded.error();
  auto normals = gl::readNormalBuffer(context);
  if (!normals) return normals.error();
  return PassImages{std::move(shaded).value(), std::move(normals).value()};
}

// One frame of a pass, its uniforms other than the camera's already set.
void drawFrame(const gl::Context& context, GLuint program, const GpuGeometry& geometry, const Camera& camera) {
  const gl::Api& api = context.api();
  context.clearTarget(kBackground);
  api.Enable(GL_DEPTH_TEST);
  api.UseProgram(program);
  setCameraUniforms(api, program, camera);
  draw(api, geometry);
}

Result<PassImages> renderPass(const gl::Context& context, GLuint program, const GpuGeometry& geometry, const Camera& camera) {
  drawFrame(context, program, geometry, camera);
  APO_RETURN_IF_ERROR(gl::checkGlErrors(context.api(), "drawing a pass"));
  return readPass(context);
}

// The median time of `frames` frames of the pass; 0 for no frames.
Result<double> timePass(const gl::Context& context, GLuint program, const GpuGeometry& geometry, const Camera& camera,
                        int frames) {
  if (frames <= 0) return 0.0;
  return gl::medianFrameMilliseconds(context.api(), frames, [&] { drawFrame(context, program, geometry, camera); });
}

// Texel reads per covered pixel, as the counting variant wrote them.
FetchCounts countFetches(const NormalBuffer& counts) {
  FetchCounts result;
  double sum = 0.0;
  for (std::size_t i = 0; i < counts.data.size() / 4; ++i) {
    if (!counts.covered(i)) continue;
    const auto fetches = static_cast<std::uint32_t>(counts.data[4 * i]);
    ++result.fragments;
    sum += fetches;
    result.max = std::max(result.max, fetches);
  }
  result.mean = result.fragments > 0 ? sum / static_cast<double>(result.fragments) : 0.0;
  return result;
}

// What every rendering of m with the APO needs, made once. The context is
// declared first so that the GL objects are released before it.
struct ApoScene {
  std::unique_ptr<gl::Context> context;
  Layout layout;
  Programs programs;
  GpuGeometry coarse;
};

using MakeLayout = std::function<Result<Layout>(const gl::Context&)>;

Result<ApoScene> makeApoScene(const Scan& coarse, const MakeLayout& makeLayout, int size) {
  if (!coarse.isMesh()) return badInput("render: m has no triangles");
  auto context = gl::Context::create(size, size);
  if (!context) return context.error();
  const gl::Api& api = (*context)->api();
  auto layout = makeLayout(**context);
  if (!layout) return layout.error();
  auto programs = buildPrograms(api, *layout);
  if (!programs) return programs.error();
  GpuGeometry mesh = uploadMesh(api, coarse);
  return ApoScene{std::move(context).value(), std::move(layout).value(), std::move(programs).value(), std::move(mesh)};
}

// Makes `program` (one of the APO variants) current with its uniforms and
// the layout's textures bound.
void useApoProgram(const ApoScene& scene, GLuint program, const Camera& camera, bool mipmapping, bool filtering) {
  const gl::Api& api = scene.context->api();
  api.UseProgram(program);
  setWalkUniforms(api, program, scene.layout, camera, scene.context->width(), mipmapping);
  api.Uniform1i(api.GetUniformLocation(program, "filtering"), filtering ? 1 : 0);
  for (std::size_t unit = 0; unit < scene.layout.textures.size(); ++unit) {
    api.ActiveTexture(GL_TEXTURE0 + static_cast<GLenum>(unit));
    api.BindTexture(scene.layout.textures[unit].first, scene.layout.textures[unit].second.id());
  }
  api.ActiveTexture(GL_TEXTURE0);
}

Result<GpuGeometry> uploadDetail(const gl::Context& context, const Scan& detail, bool pointLod) {
  if (detail.isMesh()) return uploadMesh(context.api(), detail);
  if (pointLod) return uploadPointLod(context, detail.points);
  return uploadSplats(context.api(), detail.points);
}

GLuint referenceProgram(const ApoScene& scene, const GpuGeometry& detail) {
  switch (detail.kind) {
    case GeometryKind::Mesh: return scene.programs.vertexNormals.id();
    case GeometryKind::Splats: return scene.programs.splats.id();
    case GeometryKind::LodPatches: return scene.programs.pointLod.id();
  }
  return 0;
}

// The point LOD's uniforms and object texture (the camera's are set per frame).
void useLodProgram(const ApoScene& scene, const GpuGeometry& detail, const Camera& camera, float threshold) {
  const gl::Api& api = scene.context->api();
  const GLuint program = scene.programs.pointLod.id();
  api.UseProgram(program);
  api.Uniform1f(api.GetUniformLocation(program, "pixelsPerWorldUnitAtOne"), pixelsPerWorldUnitAtOne(camera, scene.context->width()));
  api.Uniform1f(api.GetUniformLocation(program, "lodThreshold"), threshold);
  api.Uniform1i(api.GetUniformLocation(program, "objectTexture"), 0);
  api.Uniform1i(api.GetUniformLocation(program, "objectWidthShift"), static_cast<GLint>(kObjectTextureWidthShift));
  api.ActiveTexture(GL_TEXTURE0);
  api.BindTexture(GL_TEXTURE_2D, detail.objectTexture.id());
}

// The reference pass: M with its normals, its frame time, and its
// primitives sent and drawn (surfels: two triangles each).
Status renderReference(const ApoScene& scene, const GpuGeometry& detail, const Camera& camera, const RenderOptions& options,
                       ViewImages& view) {
  const GLuint program = referenceProgram(scene, detail);
  if (detail.kind == GeometryKind::LodPatches) useLodProgram(scene, detail, camera, options.lodThreshold);
  const gl::Api& api = scene.context->api();
  const gl::Query generated = gl::makeQuery(api);
  api.BeginQuery(GL_PRIMITIVES_GENERATED, generated.id());
  auto pass = renderPass(*scene.context, program, detail, camera);
  api.EndQuery(GL_PRIMITIVES_GENERATED);
  if (!pass) return pass.error();
  GLuint64 primitives = 0;
  api.GetQueryObjectui64v(generated.id(), GL_QUERY_RESULT, &primitives);
  view.cost.referenceSent = detail.primitives();
  view.cost.referenceDrawn = detail.kind == GeometryKind::Mesh ? primitives : primitives / 2;
  view.reference = std::move(pass).value();
  const int frames = options.timedFrames;
  auto milliseconds = timePass(*scene.context, program, detail, camera, frames);
  if (!milliseconds) return milliseconds.error();
  view.cost.referenceMilliseconds = *milliseconds;
  return okStatus();
}

Status renderBaseline(const ApoScene& scene, const Camera& camera, int frames, ViewImages& view) {
  const GLuint program = scene.programs.vertexNormals.id();
  auto pass = renderPass(*scene.context, program, scene.coarse, camera);
  if (!pass) return pass.error();
  view.baseline = std::move(pass).value();
  auto milliseconds = timePass(*scene.context, program, scene.coarse, camera, frames);
  if (!milliseconds) return milliseconds.error();
  view.cost.baselineMilliseconds = *milliseconds;
  return okStatus();
}

// The APO pass, its frame time, and its texel reads by the counting variant.
Status renderApo(const ApoScene& scene, const Camera& camera, const RenderOptions& options, ViewImages& view) {
  const GLuint program = scene.programs.apo.id();
  useApoProgram(scene, program, camera, options.mipmapping, options.filtering);
  auto pass = renderPass(*scene.context, program, scene.coarse, camera);
  if (!pass) return pass.error();
  view.apo = std::move(pass).value();
  auto milliseconds = timePass(*scene.context, program, scene.coarse, camera, options.timedFrames);
  if (!milliseconds) return milliseconds.error();
  view.cost.apoMilliseconds = *milliseconds;

  const GLuint counting = scene.programs.apoCountingFetches.id();
  useApoProgram(scene, counting, camera, options.mipmapping, options.filtering);
  auto counted = renderPass(*scene.context, counting, scene.coarse, camera);
  if (!counted) return counted.error();
  view.cost.apoFetches = countFetches(counted->normals);
  return okStatus();
}

Aabb sceneBox(const Scan* detail, const Scan& coarse) {
  Aabb box = boundingBox(coarse.points.positions);
  if (detail)
    for (const Vec3f& p : detail->points.positions) box.extend(p);
  return box;
}

}  // namespace

Vec3f scannedSide(const Scan& coarse) {
  Vec3f sum = Vec3f::Zero();
  double area = 0.0;
  for (const Triangle& t : coarse.triangles) {
    const Vec3f& a = coarse.points.positions[t[0]];
    const Vec3f cross = (coarse.points.positions[t[1]] - a).cross(coarse.points.positions[t[2]] - a);
    sum += cross;  // twice the area, along the face normal
    area += cross.norm();
  }
  if (!(area > 0.0) || sum.norm() < kOneSidedShare * static_cast<float>(area)) return Vec3f::Zero();
  return sum.normalized();
}

namespace {

// "+x", "-y", "+x-y+z": the signs of a direction's non-zero coordinates.
std::string directionLabel(const Vec3f& direction) {
  std::string label;
  for (int axis = 0; axis < 3; ++axis)
    if (direction[axis] != 0.0f) label += std::string(direction[axis] > 0.0f ? "+" : "-") + "xyz"[axis];
  return label;
}

// Of the image's half-width, the most the box's widest projected corner
// takes: a margin of 2.5% of the image on each side.
constexpr float kFramedShare = 0.95f;

struct Framing {
  float distance, nearPlane, farPlane;
};

// The eye's distance from the box's centre along `direction` (a unit
// vector), looking at the centre with `up` through a square image of
// `fovYDegrees`, at which the box's 8 corners fit with kFramedShare of the
// half-width at most; and near and far planes that hold the box.
Framing frameBox(const Aabb& box, const Vec3f& direction, const Vec3f& up, float fovYDegrees) {
  const Vec3f centre = 0.5f * (box.min + box.max);
  const Vec3f side = (-direction).cross(up).normalized();  // as lookAt's
  const Vec3f imageUp = side.cross(-direction);
  const float slope = std::tan(0.5f * radians(fovYDegrees)) * kFramedShare;
  float distance = 0.0f, nearest = 0.0f, farthest = 0.0f;  // towards the eye
  for (int corner = 0; corner < 8; ++corner) {
    const Vec3f p = Vec3f((corner & 1) != 0 ? box.max.x() : box.min.x(), (corner & 2) != 0 ? box.max.y() : box.min.y(),
                          (corner & 4) != 0 ? box.max.z() : box.min.z()) -
                    centre;
    const float towardsEye = p.dot(direction);
    const float across = std::max(std::abs(p.dot(side)), std::abs(p.dot(imageUp)));
    // Seen at depth distance - towardsEye, the corner takes across / depth of the slope
    distance = std::max(distance, towardsEye + across / slope);
    nearest = std::max(nearest, towardsEye);
    farthest = std::min(farthest, towardsEye);
  }
  // A box with no width across the view (a segment along it) still has its eye outside.
  distance = std::max(distance, nearest + 0.05f * (nearest - farthest) + 1e-6f);
  return {distance, std::max(0.95f * (distance - nearest), 1e-4f * distance), 1.05f * (distance - farthest)};
}

}  // namespace

std::vector<Camera> standardViews(const Aabb& box, int count, const Vec3f& scannedSide) {
  std::vector<Vec3f> directions = {Vec3f::UnitX(), -Vec3f::UnitX(), Vec3f::UnitY(), -Vec3f::UnitY(), Vec3f::UnitZ(), -Vec3f::UnitZ()};
  for (const float x : {1.0f, -1.0f})
    for (const float y : {1.0f, -1.0f})
      for (const float z : {1.0f, -1.0f}) directions.push_back(Vec3f(x, y, z).normalized());
  const bool oneSided = scannedSide.squaredNorm() > 0.0f;
  if (oneSided)
    std::stable_sort(directions.begin(), directions.end(),
                     [&](const Vec3f& a, const Vec3f& b) { return a.dot(scannedSide) > b.dot(scannedSide); });
  const Vec3f centre = 0.5f * (box.min + box.max);
  std::vector<Camera> cameras;
  for (int i = 0; i < count && i < static_cast<int>(directions.size()); ++i) {
    Camera c;
    // Looking along y, "up" cannot be y.
    c.up = std::abs(directions[i].y()) > 0.9f ? Vec3f::UnitZ() : Vec3f::UnitY();
    const Framing framing = frameBox(box, directions[i], c.up, c.fovYDegrees);
    c.target = centre;
    c.eye = centre + framing.distance * directions[i];
    c.nearPlane = framing.nearPlane;
    c.farPlane = framing.farPlane;
    c.label = directionLabel(directions[i]);
    if (oneSided) c.seesScannedSide = directions[i].dot(scannedSide) > 0.0f;
    cameras.push_back(c);
  }
  return cameras;
}

template <>
Result<Checked<RenderOptions>> check(const RenderOptions& options) {
  if (options.size < 1 || options.size > kLargestImage)
    return usageError("--size must be in [1, {}], got {}", kLargestImage, options.size);
  if (options.views < 1 || options.views > kStandardViewCount)
    return usageError("--views must be in [1, {}], got {}", kStandardViewCount, options.views);
  if (options.timedFrames < 0 || options.timedFrames > kMostTimedFrames)
    return usageError("--frames must be in [0, {}], got {}", kMostTimedFrames, options.timedFrames);
  if (!(options.lodThreshold > 0.0f) || options.lodThreshold > 1000.0f)
    return usageError("--lod-threshold must be in (0, 1000] pixels, got {}", options.lodThreshold);
  return Checked<RenderOptions>(options);
}

namespace {

Result<std::vector<ViewImages>> renderViewsWith(const Scan* detail, const Scan& coarse, const MakeLayout& makeLayout,
                                                const RenderOptions& options, const std::function<void(int, int)>& onViewDone) {
  auto scene = makeApoScene(coarse, makeLayout, options.size);
  if (!scene) return scene.error();
  std::optional<GpuGeometry> detailGeometry;
  if (detail) {
    auto uploaded = uploadDetail(*scene->context, *detail, options.pointLod);
    if (!uploaded) return uploaded.error();
    detailGeometry = std::move(uploaded).value();
  }

  std::vector<ViewImages> views;
  const std::vector<Camera> cameras = standardViews(sceneBox(detail, coarse), options.views, scannedSide(coarse));
  for (const Camera& camera : cameras) {
    ViewImages view;
    view.camera = camera;
    if (detailGeometry) APO_RETURN_IF_ERROR(renderReference(*scene, *detailGeometry, camera, options, view));
    APO_RETURN_IF_ERROR(renderBaseline(*scene, camera, options.timedFrames, view));
    APO_RETURN_IF_ERROR(renderApo(*scene, camera, options, view));
    views.push_back(std::move(view));
    if (onViewDone) onViewDone(static_cast<int>(views.size()), static_cast<int>(cameras.size()));
  }
  return views;
}

// What the CPU walk of a layout says at a point: the place it stopped (the
// id the exactness shader writes), the normal, the texel reads the shader
// should have counted, and the filtered normal (none where not found).
struct CpuWalk {
  bool found = false;
  std::uint32_t place = 0;
  Vec3f normal = Vec3f::Zero();
  std::uint32_t fetches = 0;
  std::optional<Vec3f> filtered;
};
using CpuWalker = std::function<CpuWalk(const Vec3f& unitPoint, const Vec3f& coarseNormal)>;

// What the exactness shader writes where its walk found no node: the empty
// grid cell's value (glslLayoutDefinitions' APO_EMPTY_CELL).
constexpr std::uint32_t kNoNodeMarker = 0xFFFFFFFFu;

Result<WalkAgreement> compareWalkWith(const Scan& coarse, const MakeLayout& makeLayout, const CpuWalker& cpuWalk, int size,
                                      int views) {
  auto scene = makeApoScene(coarse, makeLayout, size);
  if (!scene) return scene.error();
  const GLuint exactness = scene->programs.exactness.id();
  const GLuint counting = scene->programs.apoCountingFetches.id();
  WalkAgreement agreement;
  for (const Camera& camera : standardViews(boundingBox(coarse.points.positions), views)) {
    useApoProgram(*scene, exactness, camera, false, false);
    auto pass = renderPass(*scene->context, exactness, scene->coarse, camera);
    if (!pass) return pass.error();
    // The same fragments again, counting texel reads (no mip-mapping, no filtering).
    useApoProgram(*scene, counting, camera, false, false);
    auto counts = renderPass(*scene->context, counting, scene->coarse, camera);
    if (!counts) return counts.error();
    // The normals the shader decodes, as they are and filtered (paper 5.3),
    // without mip-mapping.
    const GLuint apoProgram = scene->programs.apo.id();
    useApoProgram(*scene, apoProgram, camera, false, false);
    auto decoded = renderPass(*scene->context, apoProgram, scene->coarse, camera);
    if (!decoded) return decoded.error();
    useApoProgram(*scene, apoProgram, camera, false, true);
    auto filtered = renderPass(*scene->context, apoProgram, scene->coarse, camera);
    if (!filtered) return filtered.error();
    // m's own normals: what leaves of a version 3 file show.
    auto bare = renderPass(*scene->context, scene->programs.vertexNormals.id(), scene->coarse, camera);
    if (!bare) return bare.error();
    const std::size_t pixels = static_cast<std::size_t>(size) * static_cast<std::size_t>(size);
    for (std::size_t i = 0; i < pixels; ++i) {
      if (!pass->normals.covered(i)) continue;
      const Vec3f coarseNormal = bare->normals.covered(i) ? bare->normals.normal(i) : Vec3f(Vec3f::Zero());
      const CpuWalk cpu = cpuWalk(pass->normals.normal(i), coarseNormal);
      if (cpu.filtered && filtered->normals.covered(i))
        agreement.maxFilteredDegrees = std::max(agreement.maxFilteredDegrees, angleDegrees(*cpu.filtered, filtered->normals.normal(i)));
      const std::uint8_t* b = &pass->shaded.rgba[4 * i];
      const std::uint32_t gpuNode = b[0] | (b[1] << 8) | (b[2] << 16) | (static_cast<std::uint32_t>(b[3]) << 24);
      const std::uint32_t cpuNode = cpu.found ? cpu.place : kNoNodeMarker;
      if (cpu.found && decoded->normals.covered(i))
        agreement.maxNormalDegrees = std::max(agreement.maxNormalDegrees, angleDegrees(cpu.normal, decoded->normals.normal(i)));
      ++agreement.pixels;
      agreement.mismatches += gpuNode == cpuNode ? 0 : 1;
      const bool counted = counts->normals.covered(i);
      agreement.fetchMismatches += counted && static_cast<std::uint32_t>(counts->normals.data[4 * i]) == cpu.fetches ? 0 : 1;
    }
  }
  return agreement;
}

// The texel reads of a walk that lookupTexture describes: the grid entry,
// then two per level descended (the node's first texel and its kind mask),
// the first texel of the node it stops at, and the one holding its normal
// (a two-sided leaf: its axis too); only the grid entry when the walk finds
// nothing.
std::uint32_t expectedFetches(const Lookup& lookup, int completeDepth) {
  if (!lookup.found) return 1u;
  return 2u * static_cast<std::uint32_t>(lookup.depth - completeDepth) + 3u + (lookup.twoSided ? 1u : 0u);
}

}  // namespace

Result<std::vector<ViewImages>> renderViews(const Scan* detail, const Scan& coarse, const ApoTexture& apo,
                                            const Checked<RenderOptions>& options, const std::function<void(int, int)>& onViewDone) {
  return renderViewsWith(detail, coarse, [&](const gl::Context& context) { return apoLayout(context, apo); }, *options, onViewDone);
}

Result<std::vector<ViewImages>> renderViews(const Scan* detail, const Scan& coarse, const N3Tree& tree,
                                            const Checked<RenderOptions>& options, const std::function<void(int, int)>& onViewDone) {
  return renderViewsWith(detail, coarse, [&](const gl::Context& context) { return n3TreeLayout(context, tree); },
                         *options, onViewDone);
}

Result<WalkAgreement> compareWalkWithCpu(const Scan& coarse, const ApoTexture& apo, int size, int views) {
  const CpuWalker cpuWalk = [&](const Vec3f& p, const Vec3f& coarseNormal) {
    const Lookup plain = lookupTexture(apo, p, 255, coarseNormal);
    const Lookup filtered = lookupTextureFiltered(apo, p, coarseNormal);
    return CpuWalk{plain.found, plain.texel, plain.normal, expectedFetches(plain, apo.completeDepth),
                   filtered.found ? std::optional<Vec3f>(filtered.normal) : std::nullopt};
  };
  return compareWalkWith(coarse, [&](const gl::Context& context) { return apoLayout(context, apo); }, cpuWalk, size, views);
}

Result<WalkAgreement> compareWalkWithCpu(const Scan& coarse, const N3Tree& tree, int size, int views) {
  const CpuWalker cpuWalk = [&](const Vec3f& p, const Vec3f& coarseNormal) {
    const N3Lookup plain = lookupN3Tree(tree, p, 255, coarseNormal);
    const N3Lookup filtered = lookupN3TreeFiltered(tree, p, coarseNormal);
    // Not found: the shader read nothing.
    return CpuWalk{plain.found, static_cast<std::uint32_t>(plain.place), plain.normal, plain.reads,
                   filtered.found ? std::optional<Vec3f>(filtered.normal) : std::nullopt};
  };
  return compareWalkWith(coarse, [&](const gl::Context& context) { return n3TreeLayout(context, tree); }, cpuWalk, size, views);
}

}  // namespace apo
