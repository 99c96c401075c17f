#include "render/gl_program.h"

#include <cctype>
#include <optional>
#include <string>

namespace apo::gl {
namespace {

template <class GetIv, class GetLog>
std::string infoLog(GLuint id, GetIv getIv, GetLog getLog) {
  GLint length = 0;
  getIv(id, GL_INFO_LOG_LENGTH, &length);
  if (length <= 1) return "(GL gave no log)";
  std::string log(static_cast<std::size_t>(length), '\0');
  GLsizei written = 0;
  getLog(id, length, &written, log.data());
  log.resize(static_cast<std::size_t>(written));
  while (!log.empty() && std::isspace(static_cast<unsigned char>(log.back()))) log.pop_back();
  return log;
}

Result<Shader> compileShader(const Api& api, GLenum stage, const char* stageName, std::string_view source) {
  Shader shader(api, api.CreateShader(stage));
  if (shader.id() == 0) return internalError("glCreateShader failed for the {}", stageName);
  const GLchar* text = source.data();
  const GLint length = static_cast<GLint>(source.size());
  api.ShaderSource(shader.id(), 1, &text, &length);
  api.CompileShader(shader.id());
  GLint compiled = GL_FALSE;
  api.GetShaderiv(shader.id(), GL_COMPILE_STATUS, &compiled);
  if (compiled != GL_TRUE) {
    return internalError("the {} failed to compile:\n{}", stageName,
                         infoLog(shader.id(), api.GetShaderiv, api.GetShaderInfoLog));
  }
  return shader;
}

}  // namespace

void deleteObject(const Api& api, ObjectKind kind, GLuint id) {
  switch (kind) {
    case ObjectKind::Shader: api.DeleteShader(id); break;
    case ObjectKind::Program: api.DeleteProgram(id); break;
    case ObjectKind::Buffer: api.DeleteBuffers(1, &id); break;
    case ObjectKind::VertexArray: api.DeleteVertexArrays(1, &id); break;
    case ObjectKind::Texture: api.DeleteTextures(1, &id); break;
    case ObjectKind::Query: api.DeleteQueries(1, &id); break;
  }
}

Buffer makeBuffer(const Api& api) {
  GLuint id = 0;
  api.GenBuffers(1, &id);
  return Buffer(api, id);
}

VertexArray makeVertexArray(const Api& api) {
  GLuint id = 0;
  api.GenVertexArrays(1, &id);
  return VertexArray(api, id);
}

Texture makeTexture(const Api& api) {
  GLuint id = 0;
  api.GenTextures(1, &id);
  return Texture(api, id);
}

Query makeQuery(const Api& api) {
  GLuint id = 0;
  api.GenQueries(1, &id);
  return Query(api, id);
}

Result<Program> buildProgram(const Api& api, std::string_view vertexSource, std::string_view fragmentSource,
                             std::string_view geometrySource) {
  auto vertex = compileShader(api, GL_VERTEX_SHADER, "vertex shader", vertexSource);
  if (!vertex) return vertex.error();
  std::optional<Shader> geometry;
  if (!geometrySource.empty()) {
    auto compiled = compileShader(api, GL_GEOMETRY_SHADER, "geometry shader", geometrySource);
    if (!compiled) return compiled.error();
    geometry = std::move(compiled).value();
  }
  auto fragment = compileShader(api, GL_FRAGMENT_SHADER, "fragment shader", fragmentSource);
  if (!fragment) return fragment.error();

  // The shaders are deleted on return: a linked program keeps what it needs.
  Program program(api, api.CreateProgram());
  if (program.id() == 0) return internalError("glCreateProgram failed");
  api.AttachShader(program.id(), vertex->id());
  if (geometry) api.AttachShader(program.id(), geometry->id());
  api.AttachShader(program.id(), fragment->id());
  api.LinkProgram(program.id());
  GLint linked = GL_FALSE;
  api.GetProgramiv(program.id(), GL_LINK_STATUS, &linked);
  if (linked != GL_TRUE) {
    return internalError("the GLSL program failed to link:\n{}",
                         infoLog(program.id(), api.GetProgramiv, api.GetProgramInfoLog));
  }
  APO_RETURN_IF_ERROR(checkGlErrors(api, "building a GLSL program"));
  return program;
}

}  // namespace apo::gl
