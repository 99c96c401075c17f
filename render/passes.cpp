// The passes of each view (reference M, baseline m, m with the APO) and the
// exactness pass, drawn into the OSMesa context's offscreen target.
#include "render/gl_context.h"
#include "render/gl_program.h"
#include "render/gl_readback.h"
#include "render/gl_texture.h"
#include "render/render.h"
#include "render/shaders.h"

#include <Eigen/Geometry>

#include <array>
#include <bit>
#include <cmath>
#include <memory>
#include <numbers>
#include <optional>
#include <string>

namespace apo {
namespace {

constexpr std::array<float, 4> kBackground = {1.0f, 1.0f, 1.0f, 1.0f};

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

// A mesh in GL buffers: interleaved position and normal, then indices.
struct GpuMesh {
  gl::VertexArray vertexArray;
  gl::Buffer vertices, indices;
  GLsizei indexCount = 0;
};

GpuMesh upload(const gl::Api& api, const Scan& mesh) {
  const std::vector<Vec3f> normals =
      mesh.points.normals.size() == mesh.points.size() ? mesh.points.normals : areaWeightedVertexNormals(mesh);
  std::vector<float> interleaved;
  interleaved.reserve(6 * mesh.points.size());
  for (std::size_t i = 0; i < mesh.points.size(); ++i)
    for (const Vec3f* v : {&mesh.points.positions[i], &normals[i]}) interleaved.insert(interleaved.end(), v->data(), v->data() + 3);
  GpuMesh gpu{gl::makeVertexArray(api), gl::makeBuffer(api), gl::makeBuffer(api),
              static_cast<GLsizei>(3 * mesh.triangles.size())};
  api.BindVertexArray(gpu.vertexArray.id());
  api.BindBuffer(GL_ARRAY_BUFFER, gpu.vertices.id());
  api.BufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(interleaved.size() * sizeof(float)), interleaved.data(),
                 GL_STATIC_DRAW);
  api.BindBuffer(GL_ELEMENT_ARRAY_BUFFER, gpu.indices.id());
  api.BufferData(GL_ELEMENT_ARRAY_BUFFER, static_cast<GLsizeiptr>(mesh.triangles.size() * sizeof(Triangle)),
                 mesh.triangles.data(), GL_STATIC_DRAW);
  for (GLuint attribute : {0u, 1u}) {
    api.EnableVertexAttribArray(attribute);
    api.VertexAttribPointer(attribute, 3, GL_FLOAT, GL_FALSE, 6 * sizeof(float),
                            reinterpret_cast<const void*>(static_cast<std::uintptr_t>(attribute * 3 * sizeof(float))));
  }
  api.BindVertexArray(0);
  return gpu;
}

std::string fragmentSource(std::string_view body, bool apo) {
  std::string source = "#version 450 core\n";
  source += shaders::kShading;
  if (apo) source += shaders::kApoWalk;
  source += body;
  return source;
}

// The programs of the passes, built once per context.
struct Programs {
  gl::Program vertexNormals, apo, exactness;
};

Result<Programs> buildPrograms(const gl::Api& api) {
  auto plain = gl::buildProgram(api, shaders::kMeshVertex, fragmentSource(shaders::kVertexNormalFragment, false));
  if (!plain) return plain.error();
  auto apo = gl::buildProgram(api, shaders::kMeshVertex, fragmentSource(shaders::kApoFragment, true));
  if (!apo) return apo.error();
  auto exact = gl::buildProgram(api, shaders::kMeshVertex, fragmentSource(shaders::kApoExactnessFragment, true));
  if (!exact) return exact.error();
  return Programs{std::move(plain).value(), std::move(apo).value(), std::move(exact).value()};
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
  api.Uniform1f(api.GetUniformLocation(program, "unitScale"), static_cast<float>(apo.transform.scale));
  api.Uniform3f(api.GetUniformLocation(program, "unitOffset"), static_cast<float>(apo.transform.offset[0]),
                static_cast<float>(apo.transform.offset[1]), static_cast<float>(apo.transform.offset[2]));
  api.Uniform1i(api.GetUniformLocation(program, "mipmapping"), mipmapping ? 1 : 0);
  api.Uniform1f(api.GetUniformLocation(program, "pixelsPerWorldUnitAtOne"),
                static_cast<float>(size) / (2.0f * std::tan(0.5f * radians(camera.fovYDegrees))));
}

void draw(const gl::Api& api, const GpuMesh& mesh) {
  api.BindVertexArray(mesh.vertexArray.id());
  api.DrawElements(GL_TRIANGLES, mesh.indexCount, GL_UNSIGNED_INT, nullptr);
  api.BindVertexArray(0);
}

Result<PassImages> readPass(const gl::Context& context) {
  auto shaded = gl::readShadedImage(context);
  if (!shaded) return shaded.error();
  auto normals = gl::readNormalBuffer(context);
  if (!normals) return normals.error();
  return PassImages{std::move(shaded).value(), std::move(normals).value()};
}

Result<PassImages> renderPass(const gl::Context& context, GLuint program, const GpuMesh& mesh, const Camera& camera) {
  const gl::Api& api = context.api();
  context.clearTarget(kBackground);
  api.Enable(GL_DEPTH_TEST);
  api.UseProgram(program);
  setCameraUniforms(api, program, camera);
  draw(api, mesh);
  APO_RETURN_IF_ERROR(gl::checkGlErrors(api, "drawing a pass"));
  return readPass(context);
}

// What every rendering of m with the APO needs, made once. The context is
// declared first so that the GL objects are released before it.
struct ApoScene {
  std::unique_ptr<gl::Context> context;
  Programs programs;
  gl::Texture texture;
  GpuMesh coarse;
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
  GpuMesh mesh = upload(api, coarse);
  return ApoScene{std::move(context).value(), std::move(programs).value(), std::move(texture).value(), std::move(mesh)};
}

// Makes `program` (one of the APO variants) current with its uniforms and
// the APO texture bound.
void useApoProgram(const ApoScene& scene, GLuint program, const ApoTexture& apo, const Camera& camera, bool mipmapping) {
  const gl::Api& api = scene.context->api();
  api.UseProgram(program);
  setApoUniforms(api, program, apo, camera, scene.context->width(), mipmapping);
  api.ActiveTexture(GL_TEXTURE0);
  api.BindTexture(GL_TEXTURE_2D, scene.texture.id());
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

Result<std::vector<ViewImages>> renderViews(const Scan* detail, const Scan& coarse, const ApoTexture& apo,
                                            const RenderOptions& options) {
  if (detail && !detail->isMesh()) return badInput("render: M as points (splats) is not supported yet; give M as a mesh");
  auto scene = makeApoScene(coarse, apo, options.size);
  if (!scene) return scene.error();
  const gl::Context& context = *scene->context;
  const gl::Api& api = context.api();
  const Programs& programs = scene->programs;
  std::optional<GpuMesh> detailMesh;
  if (detail) detailMesh = upload(api, *detail);

  std::vector<ViewImages> views;
  for (const Camera& camera : standardViews(sceneBox(detail, coarse), options.views)) {
    ViewImages view;
    view.camera = camera;
    if (detailMesh) {
      auto reference = renderPass(context, programs.vertexNormals.id(), *detailMesh, camera);
      if (!reference) return reference.error();
      view.reference = std::move(reference).value();
    }
    auto baseline = renderPass(context, programs.vertexNormals.id(), scene->coarse, camera);
    if (!baseline) return baseline.error();
    view.baseline = std::move(baseline).value();
    useApoProgram(*scene, programs.apo.id(), apo, camera, options.mipmapping);
    api.Uniform1i(api.GetUniformLocation(programs.apo.id(), "filtering"), options.filtering ? 1 : 0);
    auto apoPass = renderPass(context, programs.apo.id(), scene->coarse, camera);
    if (!apoPass) return apoPass.error();
    view.apo = std::move(apoPass).value();
    views.push_back(std::move(view));
  }
  return views;
}

Result<WalkAgreement> compareWalkWithCpu(const Scan& coarse, const ApoTexture& apo, int size, int views) {
  auto scene = makeApoScene(coarse, apo, size);
  if (!scene) return scene.error();
  const GLuint program = scene->programs.exactness.id();
  WalkAgreement agreement;
  for (const Camera& camera : standardViews(boundingBox(coarse.points.positions), views)) {
    useApoProgram(*scene, program, apo, camera, false);
    auto pass = renderPass(*scene->context, program, scene->coarse, camera);
    if (!pass) return pass.error();
    const std::size_t pixels = static_cast<std::size_t>(size) * static_cast<std::size_t>(size);
    for (std::size_t i = 0; i < pixels; ++i) {
      if (!pass->normals.covered(i)) continue;
      const std::uint8_t* b = &pass->shaded.rgba[4 * i];
      const std::uint32_t gpuNode = b[0] | (b[1] << 8) | (b[2] << 16) | (static_cast<std::uint32_t>(b[3]) << 24);
      const Lookup cpu = lookupTexture(apo, pass->normals.normal(i));
      const std::uint32_t cpuNode = cpu.found ? cpu.texel : 0xFFFFFFFFu;
      ++agreement.pixels;
      agreement.mismatches += gpuNode == cpuNode ? 0 : 1;
    }
  }
  return agreement;
}

}  // namespace apo
