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
// indices) or a point cloud as splats (position, normal, disc radius).
struct GpuGeometry {
  gl::VertexArray vertexArray;
  gl::Buffer vertices, indices;
  GLsizei count = 0;  // indices of a mesh, points of a cloud
  bool points = false;
};

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
                  static_cast<GLsizei>(3 * mesh.triangles.size()), false};
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
  GpuGeometry gpu{gl::makeVertexArray(api), gl::makeBuffer(api), gl::Buffer(), static_cast<GLsizei>(points.size()), true};
  api.BindVertexArray(gpu.vertexArray.id());
  api.BindBuffer(GL_ARRAY_BUFFER, gpu.vertices.id());
  api.BufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(interleaved.size() * sizeof(float)), interleaved.data(),
                 GL_STATIC_DRAW);
  describeInterleaved(api, {3, 3, 1});
  api.BindVertexArray(0);
  return gpu;
}

enum class Walk { None, Plain, CountingFetches };

std::string fragmentSource(std::string_view body, Walk walk) {
  std::string source = "#version 450 core\n";
  if (walk == Walk::CountingFetches) source += "#define COUNT_FETCHES\n";
  source += shaders::kShading;
  if (walk != Walk::None) {
    source += glslLayoutDefinitions();
    source += shaders::kApoWalk;
  }
  source += body;
  return source;
}

// The programs of the passes, built once per context.
struct Programs {
  gl::Program vertexNormals, splats, apo, apoCountingFetches, exactness;
};

Result<Programs> buildPrograms(const gl::Api& api) {
  Programs programs;
  const auto build = [&](gl::Program& program, std::string_view body, Walk walk,
                         std::string_view vertex = shaders::kMeshVertex, std::string_view geometry = {}) -> Status {
    auto built = gl::buildProgram(api, vertex, fragmentSource(body, walk), geometry);
    if (!built) return built.error();
    program = std::move(built).value();
    return okStatus();
  };
  APO_RETURN_IF_ERROR(build(programs.vertexNormals, shaders::kVertexNormalFragment, Walk::None));
  APO_RETURN_IF_ERROR(build(programs.splats, shaders::kSplatFragment, Walk::None, shaders::kSplatVertex, shaders::kSplatGeometry));
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

void setApoUniforms(const gl::Api& api, GLuint program, const ApoTexture& apo, const Camera& camera, int size,
                    bool mipmapping) {
  api.Uniform1i(api.GetUniformLocation(program, "apoTexture"), 0);
  api.Uniform1ui(api.GetUniformLocation(program, "widthMask"), apo.width - 1);
  api.Uniform1i(api.GetUniformLocation(program, "widthShift"), std::countr_zero(apo.width));
  api.Uniform1i(api.GetUniformLocation(program, "completeDepth"), apo.completeDepth);
  api.Uniform1ui(api.GetUniformLocation(program, "normalEncoding"), static_cast<GLuint>(apo.encoding));
  api.Uniform1i(api.GetUniformLocation(program, "defersToCoarse"), apo.defersToCoarse ? 1 : 0);
  api.Uniform1f(api.GetUniformLocation(program, "unitScale"), static_cast<float>(apo.transform.scale));
  api.Uniform3f(api.GetUniformLocation(program, "unitOffset"), static_cast<float>(apo.transform.offset[0]),
                static_cast<float>(apo.transform.offset[1]), static_cast<float>(apo.transform.offset[2]));
  api.Uniform1i(api.GetUniformLocation(program, "mipmapping"), mipmapping ? 1 : 0);
  api.Uniform1f(api.GetUniformLocation(program, "pixelsPerWorldUnitAtOne"),
                static_cast<float>(size) / (2.0f * std::tan(0.5f * radians(camera.fovYDegrees))));
}

void draw(const gl::Api& api, const GpuGeometry& geometry) {
  api.BindVertexArray(geometry.vertexArray.id());
  if (geometry.points)
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
  Programs programs;
  gl::Texture texture;
  GpuGeometry coarse;
};

Result<ApoScene> makeApoScene(const Scan& coarse, const ApoTexture& apo, int size) {
  if (!coarse.isMesh()) return badInput("render: m has no triangles");
  auto context = gl::Context::create(size, size);
  if (!context) return context.error();
  const gl::Api& api = (*context)->api();
  auto programs = buildPrograms(api);
  if (!programs) return programs.error();
  auto texture = gl::uploadApoTexture(**context, apo);
  if (!texture) return texture.error();
  GpuGeometry mesh = uploadMesh(api, coarse);
  return ApoScene{std::move(context).value(), std::move(programs).value(), std::move(texture).value(), std::move(mesh)};
}

// Makes `program` (one of the APO variants) current with its uniforms and
// the APO texture bound.
void useApoProgram(const ApoScene& scene, GLuint program, const ApoTexture& apo, const Camera& camera, bool mipmapping,
                   bool filtering) {
  const gl::Api& api = scene.context->api();
  api.UseProgram(program);
  setApoUniforms(api, program, apo, camera, scene.context->width(), mipmapping);
  api.Uniform1i(api.GetUniformLocation(program, "filtering"), filtering ? 1 : 0);
  api.ActiveTexture(GL_TEXTURE0);
  api.BindTexture(GL_TEXTURE_2D, scene.texture.id());
}

Result<GpuGeometry> uploadDetail(const gl::Api& api, const Scan& detail) {
  if (detail.isMesh()) return uploadMesh(api, detail);
  return uploadSplats(api, detail.points);
}

// The reference pass: M with its normals, and its frame time.
Status renderReference(const ApoScene& scene, const GpuGeometry& detail, const Camera& camera, int frames, ViewImages& view) {
  const GLuint program = detail.points ? scene.programs.splats.id() : scene.programs.vertexNormals.id();
  auto pass = renderPass(*scene.context, program, detail, camera);
  if (!pass) return pass.error();
  view.reference = std::move(pass).value();
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
Status renderApo(const ApoScene& scene, const ApoTexture& apo, const Camera& camera, const RenderOptions& options,
                 ViewImages& view) {
  const GLuint program = scene.programs.apo.id();
  useApoProgram(scene, program, apo, camera, options.mipmapping, options.filtering);
  auto pass = renderPass(*scene.context, program, scene.coarse, camera);
  if (!pass) return pass.error();
  view.apo = std::move(pass).value();
  auto milliseconds = timePass(*scene.context, program, scene.coarse, camera, options.timedFrames);
  if (!milliseconds) return milliseconds.error();
  view.cost.apoMilliseconds = *milliseconds;

  const GLuint counting = scene.programs.apoCountingFetches.id();
  useApoProgram(scene, counting, apo, camera, options.mipmapping, options.filtering);
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

std::vector<Camera> standardViews(const Aabb& box, int count) {
  std::vector<Vec3f> directions = {Vec3f::UnitX(), -Vec3f::UnitX(), Vec3f::UnitY(), -Vec3f::UnitY(), Vec3f::UnitZ(), -Vec3f::UnitZ()};
  for (const float x : {1.0f, -1.0f})
    for (const float y : {1.0f, -1.0f})
      for (const float z : {1.0f, -1.0f}) directions.push_back(Vec3f(x, y, z).normalized());
  const Vec3f centre = 0.5f * (box.min + box.max);
  const float radius = 0.5f * box.diagonal();
  std::vector<Camera> cameras;
  for (int i = 0; i < count && i < static_cast<int>(directions.size()); ++i) {
    Camera c;
    const float distance = radius / std::sin(0.5f * radians(c.fovYDegrees)) * 1.02f;
    c.target = centre;
    c.eye = centre + distance * directions[i];
    // Looking along y, "up" cannot be y.
    c.up = std::abs(directions[i].y()) > 0.9f ? Vec3f::UnitZ() : Vec3f::UnitY();
    c.nearPlane = std::max(distance - 1.05f * radius, 1e-4f * distance);
    c.farPlane = distance + 1.05f * radius;
    cameras.push_back(c);
  }
  return cameras;
}

Status validateRenderOptions(const RenderOptions& options) {
  if (options.size < 1 || options.size > kLargestImage)
    return usageError("--size must be in [1, {}], got {}", kLargestImage, options.size);
  if (options.views < 1 || options.views > kStandardViewCount)
    return usageError("--views must be in [1, {}], got {}", kStandardViewCount, options.views);
  if (options.timedFrames < 0 || options.timedFrames > kMostTimedFrames)
    return usageError("--frames must be in [0, {}], got {}", kMostTimedFrames, options.timedFrames);
  return okStatus();
}

Result<std::vector<ViewImages>> renderViews(const Scan* detail, const Scan& coarse, const ApoTexture& apo,
                                            const RenderOptions& options, const std::function<void(int, int)>& onViewDone) {
  APO_RETURN_IF_ERROR(validateRenderOptions(options));
  auto scene = makeApoScene(coarse, apo, options.size);
  if (!scene) return scene.error();
  std::optional<GpuGeometry> detailGeometry;
  if (detail) {
    auto uploaded = uploadDetail(scene->context->api(), *detail);
    if (!uploaded) return uploaded.error();
    detailGeometry = std::move(uploaded).value();
  }

  std::vector<ViewImages> views;
  const std::vector<Camera> cameras = standardViews(sceneBox(detail, coarse), options.views);
  for (const Camera& camera : cameras) {
    ViewImages view;
    view.camera = camera;
    if (detailGeometry) APO_RETURN_IF_ERROR(renderReference(*scene, *detailGeometry, camera, options.timedFrames, view));
    APO_RETURN_IF_ERROR(renderBaseline(*scene, camera, options.timedFrames, view));
    APO_RETURN_IF_ERROR(renderApo(*scene, apo, camera, options, view));
    views.push_back(std::move(view));
    if (onViewDone) onViewDone(static_cast<int>(views.size()), static_cast<int>(cameras.size()));
  }
  return views;
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

// What the exactness shader writes where its walk found no node: the empty
// grid cell's value (glslLayoutDefinitions' APO_EMPTY_CELL).
constexpr std::uint32_t kNoNodeMarker = 0xFFFFFFFFu;

Result<WalkAgreement> compareWalkWithCpu(const Scan& coarse, const ApoTexture& apo, int size, int views) {
  auto scene = makeApoScene(coarse, apo, size);
  if (!scene) return scene.error();
  const GLuint exactness = scene->programs.exactness.id();
  const GLuint counting = scene->programs.apoCountingFetches.id();
  WalkAgreement agreement;
  for (const Camera& camera : standardViews(boundingBox(coarse.points.positions), views)) {
    useApoProgram(*scene, exactness, apo, camera, false, false);
    auto pass = renderPass(*scene->context, exactness, scene->coarse, camera);
    if (!pass) return pass.error();
    // The same fragments again, counting texel reads (no mip-mapping, no filtering).
    useApoProgram(*scene, counting, apo, camera, false, false);
    auto counts = renderPass(*scene->context, counting, scene->coarse, camera);
    if (!counts) return counts.error();
    // The normals the shader decodes, as they are and filtered (paper 5.3),
    // without mip-mapping.
    const GLuint apoProgram = scene->programs.apo.id();
    useApoProgram(*scene, apoProgram, apo, camera, false, false);
    auto decoded = renderPass(*scene->context, apoProgram, scene->coarse, camera);
    if (!decoded) return decoded.error();
    useApoProgram(*scene, apoProgram, apo, camera, false, true);
    auto filtered = renderPass(*scene->context, apoProgram, scene->coarse, camera);
    if (!filtered) return filtered.error();
    // m's own normals: what leaves of a version 3 file show.
    auto bare = renderPass(*scene->context, scene->programs.vertexNormals.id(), scene->coarse, camera);
    if (!bare) return bare.error();
    const std::size_t pixels = static_cast<std::size_t>(size) * static_cast<std::size_t>(size);
    for (std::size_t i = 0; i < pixels; ++i) {
      if (!pass->normals.covered(i)) continue;
      const Vec3f coarseNormal = bare->normals.covered(i) ? bare->normals.normal(i) : Vec3f(Vec3f::Zero());
      const Lookup cpuFiltered = lookupTextureFiltered(apo, pass->normals.normal(i), coarseNormal);
      if (cpuFiltered.found && filtered->normals.covered(i))
        agreement.maxFilteredDegrees =
            std::max(agreement.maxFilteredDegrees, angleDegrees(cpuFiltered.normal, filtered->normals.normal(i)));
      const std::uint8_t* b = &pass->shaded.rgba[4 * i];
      const std::uint32_t gpuNode = b[0] | (b[1] << 8) | (b[2] << 16) | (static_cast<std::uint32_t>(b[3]) << 24);
      const Lookup cpu = lookupTexture(apo, pass->normals.normal(i), 255, coarseNormal);
      const std::uint32_t cpuNode = cpu.found ? cpu.texel : kNoNodeMarker;
      if (cpu.found && decoded->normals.covered(i))
        agreement.maxNormalDegrees = std::max(agreement.maxNormalDegrees, angleDegrees(cpu.normal, decoded->normals.normal(i)));
      ++agreement.pixels;
      agreement.mismatches += gpuNode == cpuNode ? 0 : 1;
      const bool counted = counts->normals.covered(i);
      agreement.fetchMismatches +=
          counted && static_cast<std::uint32_t>(counts->normals.data[4 * i]) == expectedFetches(cpu, apo.completeDepth) ? 0 : 1;
    }
  }
  return agreement;
}

}  // namespace apo
