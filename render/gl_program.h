// GL objects that release themselves (so an early error return leaks
// nothing), and GLSL programs built from source with their logs on failure.
#pragma once

#include "adapters/osmesa/gl_context.h"

#include <string_view>
#include <utility>

namespace apo::gl {

enum class ObjectKind { Shader, Program, Buffer, VertexArray, Texture, Query };

// Deletes one object of that kind (the context it was made in must be current).
void deleteObject(const Api& api, ObjectKind kind, GLuint id);

// Owns one GL object name; move-only. Holds the Api by pointer, so it must not
// outlive the Context (see Context).
template <ObjectKind Kind>
class Object {
 public:
  Object() = default;
  Object(const Api& api, GLuint id) : api_(&api), id_(id) {}
  Object(Object&& other) noexcept : api_(other.api_), id_(std::exchange(other.id_, 0)) {}
  Object& operator=(Object&& other) noexcept {
    if (this != &other) {
      reset();
      api_ = other.api_;
      id_ = std::exchange(other.id_, 0);
    }
    return *this;
  }
  Object(const Object&) = delete;
  Object& operator=(const Object&) = delete;
  ~Object() { reset(); }

  GLuint id() const { return id_; }

 private:
  void reset() {
    if (id_ != 0) deleteObject(*api_, Kind, id_);
    id_ = 0;
  }

  const Api* api_ = nullptr;
  GLuint id_ = 0;
};

using Shader = Object<ObjectKind::Shader>;
using Program = Object<ObjectKind::Program>;
using Buffer = Object<ObjectKind::Buffer>;
using VertexArray = Object<ObjectKind::VertexArray>;
using Texture = Object<ObjectKind::Texture>;
using Query = Object<ObjectKind::Query>;

// New, empty names (glGen*); nothing is bound.
Buffer makeBuffer(const Api& api);
VertexArray makeVertexArray(const Api& api);
Texture makeTexture(const Api& api);
Query makeQuery(const Api& api);

// Compiles the stages and links them; an empty geometry source means no
// geometry stage. Internal error naming the stage that failed ("vertex
// shader", "geometry shader", "fragment shader" or "link") with GL's full log.
Result<Program> buildProgram(const Api& api, std::string_view vertexSource, std::string_view fragmentSource,
                             std::string_view geometrySource = {});

}  // namespace apo::gl
