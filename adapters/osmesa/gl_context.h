// The OSMesa adapter (target apo_osmesa): a headless core-profile GL context,
// its offscreen target, and the table of GL functions that render/ calls GL
// through. Only gl_context.cpp sees OSMesa, which it loads at run time.
#pragma once

#include "core/error.h"

#include <GL/glcorearb.h>

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

struct osmesa_context;  // <GL/osmesa.h>'s OSMesaContext points to it

namespace apo::gl {

struct OsMesaLibrary;  // libOSMesa, loaded at run time, and its entry points

// The OSMesa library Context::create loads: $APO_OSMESA_LIBRARY when set,
// else Mesa's "libOSMesa.so.8" (Debian's libosmesa6).
std::string defaultOsMesaLibrary();

// Every GL function the render code uses: X(pointer type, name without "gl").
// To call a new function, add it here; Context::create loads the whole list.
#define APO_GL_FUNCTIONS(X)                                                   \
  /* state and queries */                                                     \
  X(PFNGLGETSTRINGPROC, GetString)                                            \
  X(PFNGLGETINTEGERVPROC, GetIntegerv)                                        \
  X(PFNGLGETERRORPROC, GetError)                                              \
  X(PFNGLFINISHPROC, Finish)                                                  \
  X(PFNGLVIEWPORTPROC, Viewport)                                              \
  X(PFNGLENABLEPROC, Enable)                                                  \
  X(PFNGLDISABLEPROC, Disable)                                                \
  X(PFNGLDEPTHFUNCPROC, DepthFunc)                                            \
  X(PFNGLCULLFACEPROC, CullFace)                                              \
  X(PFNGLPIXELSTOREIPROC, PixelStorei)                                        \
  /* framebuffers */                                                          \
  X(PFNGLGENFRAMEBUFFERSPROC, GenFramebuffers)                                \
  X(PFNGLDELETEFRAMEBUFFERSPROC, DeleteFramebuffers)                          \
  X(PFNGLBINDFRAMEBUFFERPROC, BindFramebuffer)                                \
  X(PFNGLFRAMEBUFFERRENDERBUFFERPROC, FramebufferRenderbuffer)                \
  X(PFNGLCHECKFRAMEBUFFERSTATUSPROC, CheckFramebufferStatus)                  \
  X(PFNGLGENRENDERBUFFERSPROC, GenRenderbuffers)                              \
  X(PFNGLDELETERENDERBUFFERSPROC, DeleteRenderbuffers)                        \
  X(PFNGLBINDRENDERBUFFERPROC, BindRenderbuffer)                              \
  X(PFNGLRENDERBUFFERSTORAGEPROC, RenderbufferStorage)                        \
  X(PFNGLDRAWBUFFERSPROC, DrawBuffers)                                        \
  X(PFNGLREADBUFFERPROC, ReadBuffer)                                          \
  X(PFNGLREADPIXELSPROC, ReadPixels)                                          \
  X(PFNGLCLEARBUFFERFVPROC, ClearBufferfv)                                    \
  /* textures */                                                              \
  X(PFNGLGENTEXTURESPROC, GenTextures)                                        \
  X(PFNGLDELETETEXTURESPROC, DeleteTextures)                                  \
  X(PFNGLBINDTEXTUREPROC, BindTexture)                                        \
  X(PFNGLACTIVETEXTUREPROC, ActiveTexture)                                    \
  X(PFNGLTEXIMAGE2DPROC, TexImage2D)                                          \
  X(PFNGLTEXIMAGE3DPROC, TexImage3D)                                          \
  X(PFNGLTEXPARAMETERIPROC, TexParameteri)                                    \
  /* shaders and programs */                                                  \
  X(PFNGLCREATESHADERPROC, CreateShader)                                      \
  X(PFNGLDELETESHADERPROC, DeleteShader)                                      \
  X(PFNGLSHADERSOURCEPROC, ShaderSource)                                      \
  X(PFNGLCOMPILESHADERPROC, CompileShader)                                    \
  X(PFNGLGETSHADERIVPROC, GetShaderiv)                                        \
  X(PFNGLGETSHADERINFOLOGPROC, GetShaderInfoLog)                              \
  X(PFNGLCREATEPROGRAMPROC, CreateProgram)                                    \
  X(PFNGLDELETEPROGRAMPROC, DeleteProgram)                                    \
  X(PFNGLATTACHSHADERPROC, AttachShader)                                      \
  X(PFNGLLINKPROGRAMPROC, LinkProgram)                                        \
  X(PFNGLGETPROGRAMIVPROC, GetProgramiv)                                      \
  X(PFNGLGETPROGRAMINFOLOGPROC, GetProgramInfoLog)                            \
  X(PFNGLUSEPROGRAMPROC, UseProgram)                                          \
  X(PFNGLGETUNIFORMLOCATIONPROC, GetUniformLocation)                          \
  X(PFNGLUNIFORM1IPROC, Uniform1i)                                            \
  X(PFNGLUNIFORM1UIPROC, Uniform1ui)                                          \
  X(PFNGLUNIFORM1FPROC, Uniform1f)                                            \
  X(PFNGLUNIFORM3FPROC, Uniform3f)                                            \
  X(PFNGLUNIFORM3UIPROC, Uniform3ui)                                          \
  X(PFNGLUNIFORM4FPROC, Uniform4f)                                            \
  X(PFNGLUNIFORMMATRIX3FVPROC, UniformMatrix3fv)                              \
  X(PFNGLUNIFORMMATRIX4FVPROC, UniformMatrix4fv)                              \
  /* vertex data and drawing */                                               \
  X(PFNGLGENBUFFERSPROC, GenBuffers)                                          \
  X(PFNGLDELETEBUFFERSPROC, DeleteBuffers)                                    \
  X(PFNGLBINDBUFFERPROC, BindBuffer)                                          \
  X(PFNGLBUFFERDATAPROC, BufferData)                                          \
  X(PFNGLGENVERTEXARRAYSPROC, GenVertexArrays)                                \
  X(PFNGLDELETEVERTEXARRAYSPROC, DeleteVertexArrays)                          \
  X(PFNGLBINDVERTEXARRAYPROC, BindVertexArray)                                \
  X(PFNGLENABLEVERTEXATTRIBARRAYPROC, EnableVertexAttribArray)                \
  X(PFNGLVERTEXATTRIBPOINTERPROC, VertexAttribPointer)                        \
  X(PFNGLVERTEXATTRIBIPOINTERPROC, VertexAttribIPointer)                      \
  X(PFNGLGENQUERIESPROC, GenQueries)                                          \
  X(PFNGLDELETEQUERIESPROC, DeleteQueries)                                    \
  X(PFNGLBEGINQUERYPROC, BeginQuery)                                          \
  X(PFNGLENDQUERYPROC, EndQuery)                                              \
  X(PFNGLGETQUERYOBJECTUI64VPROC, GetQueryObjectui64v)                        \
  X(PFNGLDRAWARRAYSPROC, DrawArrays)                                          \
  X(PFNGLDRAWELEMENTSPROC, DrawElements)

// The loaded functions, e.g. `api.DrawArrays(GL_TRIANGLES, 0, 3)`.
struct Api {
#define APO_GL_DECLARE(type, name) type name = nullptr;
  APO_GL_FUNCTIONS(APO_GL_DECLARE)
#undef APO_GL_DECLARE
};

struct Info {
  std::string requested;  // the profile asked and obtained, e.g. "core 4.5"
  std::string version, renderer, shadingLanguageVersion;  // glGetString
  int majorVersion = 0, minorVersion = 0;
  bool coreProfile = false;
  int maxTextureSize = 0;  // GL_MAX_TEXTURE_SIZE, texels per side
  int max3DTextureSize = 0;  // GL_MAX_3D_TEXTURE_SIZE, texels per side
};

// The offscreen target's colour attachments, as `layout(location = N)` of the
// fragment shader outputs.
inline constexpr int kShadedAttachment = 0;  // RGBA8: the shaded image
inline constexpr int kNormalAttachment = 1;  // RGBA32F: normal xyz, coverage

// One GL context with its offscreen target of width x height: RGBA8 +
// RGBA32F colour and 24-bit depth. Contexts may follow one another in a
// process; each belongs to one thread. GL objects made through api() must be
// released before their context is destroyed, while it is current.
class Context {
 public:
  // A core profile 4.5, or 3.3 if 4.5 is refused; made current on return.
  // Usage error for a size outside [1, GL_MAX_RENDERBUFFER_SIZE]; Internal
  // error when `osmesaLibrary` cannot be loaded, OSMesa refuses the context,
  // lacks a function, or the target is incomplete.
  static Result<std::unique_ptr<Context>> create(int width, int height,
                                                 const std::string& osmesaLibrary = defaultOsMesaLibrary());
  ~Context();
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;

  const Api& api() const { return api_; }
  const Info& info() const { return info_; }
  int width() const { return width_; }
  int height() const { return height_; }

  // Needed only after another context was made current on this thread.
  Status makeCurrent();
  // Binds the target for drawing and reading, the viewport covering it.
  void bindTarget() const;
  // Binds the target and clears it: shaded image to `background`, normal and
  // coverage to 0, depth to 1 (glClearBuffer obeys the colour and depth
  // write masks, so leave them on).
  void clearTarget(const std::array<float, 4>& background) const;

 private:
  Context(int width, int height);
  Status loadOsMesa(const std::string& library);
  Status createOsMesaContext();
  Status loadApi();
  Status queryInfo();
  Status createTarget();

  int width_ = 0, height_ = 0;
  std::unique_ptr<OsMesaLibrary> library_;
  osmesa_context* osmesa_ = nullptr;
  // OSMesa needs a colour buffer to make a context current; nothing draws to it.
  std::vector<std::uint8_t> dummyBuffer_ = std::vector<std::uint8_t>(4);
  Api api_;
  Info info_;
  GLuint framebuffer_ = 0;
  std::array<GLuint, 3> renderbuffers_{};  // shaded, normal, depth
};

// Internal error naming `during` and every pending GL error, else ok.
Status checkGlErrors(const Api& api, std::string_view during);

}  // namespace apo::gl
