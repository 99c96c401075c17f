// The only file that includes OSMesa. libOSMesa itself is loaded at run time
// (dlopen), so that a machine without it gets a clear error from the render
// stage while every other command works, rather than a loader failure before
// main. GL functions are loaded through OSMesaGetProcAddress rather than
// linked: that works whatever the link order (a libGL linked ahead of OSMesa
// would otherwise take the calls, see ../shared/STACK.md), and keeps every
// pointer in the context that owns it.
#include "adapters/osmesa/gl_context.h"

#include <GL/osmesa.h>
#include <dlfcn.h>

#include <cstdlib>
#include <type_traits>

namespace apo::gl {

struct OsMesaLibrary {
  void* handle = nullptr;
  decltype(&OSMesaCreateContextAttribs) createContextAttribs = nullptr;
  decltype(&OSMesaMakeCurrent) makeCurrent = nullptr;
  decltype(&OSMesaDestroyContext) destroyContext = nullptr;
  decltype(&OSMesaGetProcAddress) getProcAddress = nullptr;

  // RTLD_NODELETE: llvmpipe's threads outlive a context, so the library is
  // never unmapped; dlclose only drops the reference.
  ~OsMesaLibrary() {
    if (handle) dlclose(handle);
  }
};

std::string defaultOsMesaLibrary() {
  const char* chosen = std::getenv("APO_OSMESA_LIBRARY");
  return chosen && *chosen ? chosen : "libOSMesa.so.8";
}

namespace {

OSMesaContext createCoreContext(const OsMesaLibrary& osmesa, int major, int minor) {
  // Depth 0: the default buffer is a dummy; the target has its own depth.
  const int attributes[] = {OSMESA_FORMAT, OSMESA_RGBA, OSMESA_DEPTH_BITS, 0,
                            OSMESA_PROFILE, OSMESA_CORE_PROFILE,
                            OSMESA_CONTEXT_MAJOR_VERSION, major,
                            OSMESA_CONTEXT_MINOR_VERSION, minor, 0};
  return osmesa.createContextAttribs(attributes, nullptr);
}

const char* glErrorName(GLenum error) {
  switch (error) {
    case GL_INVALID_ENUM: return "GL_INVALID_ENUM";
    case GL_INVALID_VALUE: return "GL_INVALID_VALUE";
    case GL_INVALID_OPERATION: return "GL_INVALID_OPERATION";
    case GL_INVALID_FRAMEBUFFER_OPERATION: return "GL_INVALID_FRAMEBUFFER_OPERATION";
    case GL_OUT_OF_MEMORY: return "GL_OUT_OF_MEMORY";
    default: return "an unknown GL error";
  }
}

std::string glString(const Api& api, GLenum name) {
  const GLubyte* text = api.GetString(name);
  return text ? reinterpret_cast<const char*>(text) : "";
}

}  // namespace

Context::Context(int width, int height) : width_(width), height_(height) {}

Result<std::unique_ptr<Context>> Context::create(int width, int height, const std::string& osmesaLibrary) {
  if (width < 1 || height < 1) return usageError("render target {} x {}: both sides must be at least 1", width, height);
  std::unique_ptr<Context> context(new Context(width, height));
  // On any failure the destructor releases whatever was made.
  APO_RETURN_IF_ERROR(context->loadOsMesa(osmesaLibrary));
  APO_RETURN_IF_ERROR(context->createOsMesaContext());
  APO_RETURN_IF_ERROR(context->loadApi());
  APO_RETURN_IF_ERROR(context->queryInfo());
  APO_RETURN_IF_ERROR(context->createTarget());
  return context;
}

Context::~Context() {
  if (osmesa_ == nullptr) return;
  // Another context may have been made current since; the objects are ours.
  if (makeCurrent().ok() && api_.DeleteFramebuffers && api_.DeleteRenderbuffers) {
    api_.DeleteFramebuffers(1, &framebuffer_);
    api_.DeleteRenderbuffers(static_cast<GLsizei>(renderbuffers_.size()), renderbuffers_.data());
  }
  library_->destroyContext(osmesa_);
}

Status Context::loadOsMesa(const std::string& library) {
  library_ = std::make_unique<OsMesaLibrary>();
  library_->handle = dlopen(library.c_str(), RTLD_NOW | RTLD_LOCAL | RTLD_NODELETE);
  if (library_->handle == nullptr) {
    return internalError("cannot load the OSMesa library {} ({}): the render stage draws with Mesa's off-screen GL "
                         "(Debian package libosmesa6; setup.sh installs it)", library, dlerror());
  }
  const auto load = [&](auto& function, const char* name) -> Status {
    function = reinterpret_cast<std::remove_reference_t<decltype(function)>>(dlsym(library_->handle, name));
    if (function == nullptr) return internalError("the OSMesa library {} has no {}", library, name);
    return okStatus();
  };
  APO_RETURN_IF_ERROR(load(library_->createContextAttribs, "OSMesaCreateContextAttribs"));
  APO_RETURN_IF_ERROR(load(library_->makeCurrent, "OSMesaMakeCurrent"));
  APO_RETURN_IF_ERROR(load(library_->destroyContext, "OSMesaDestroyContext"));
  return load(library_->getProcAddress, "OSMesaGetProcAddress");
}

Status Context::createOsMesaContext() {
  // 4.5 is what llvmpipe gives; 3.3 is the least the shaders need.
  osmesa_ = createCoreContext(*library_, 4, 5);
  info_.requested = "core 4.5";
  if (osmesa_ == nullptr) {
    osmesa_ = createCoreContext(*library_, 3, 3);
    info_.requested = "core 3.3 (core 4.5 was refused)";
  }
  if (osmesa_ == nullptr) {
    return internalError("OSMesa refused a core-profile GL context (asked 4.5, then 3.3); "
                         "the render stage needs Mesa's OSMesa with llvmpipe (libosmesa6)");
  }
  return makeCurrent();
}

Status Context::makeCurrent() {
  if (!library_->makeCurrent(osmesa_, dummyBuffer_.data(), GL_UNSIGNED_BYTE, 1, 1)) {
    return internalError("OSMesaMakeCurrent failed for a {} context on a 1 x 1 RGBA buffer", info_.requested);
  }
  return okStatus();
}

// Mesa's OSMesaGetProcAddress returns a dispatch stub even for names it does
// not know, so the null check below only catches a broken OSMesa; queryInfo's
// version check is the real guarantee.
Status Context::loadApi() {
#define APO_GL_LOAD(type, name)                                                        \
  api_.name = reinterpret_cast<type>(library_->getProcAddress("gl" #name));             \
  if (api_.name == nullptr) {                                                          \
    return internalError("OSMesa does not provide gl" #name " (in a {} context)", info_.requested); \
  }
  APO_GL_FUNCTIONS(APO_GL_LOAD)
#undef APO_GL_LOAD
  return okStatus();
}

Status Context::queryInfo() {
  info_.version = glString(api_, GL_VERSION);
  if (info_.version.empty()) {
    return internalError("glGetString(GL_VERSION) returned NULL in a fresh {} OSMesa context "
                         "(is libGL linked ahead of libOSMesa?)", info_.requested);
  }
  info_.renderer = glString(api_, GL_RENDERER);
  info_.shadingLanguageVersion = glString(api_, GL_SHADING_LANGUAGE_VERSION);
  GLint profileMask = 0;
  api_.GetIntegerv(GL_MAJOR_VERSION, &info_.majorVersion);
  api_.GetIntegerv(GL_MINOR_VERSION, &info_.minorVersion);
  api_.GetIntegerv(GL_CONTEXT_PROFILE_MASK, &profileMask);
  api_.GetIntegerv(GL_MAX_TEXTURE_SIZE, &info_.maxTextureSize);
  api_.GetIntegerv(GL_MAX_3D_TEXTURE_SIZE, &info_.max3DTextureSize);
  info_.coreProfile = (profileMask & GL_CONTEXT_CORE_PROFILE_BIT) != 0;
  // Every function of APO_GL_FUNCTIONS is core in 3.3; this check, not the
  // loader's, is what proves them present (see loadApi).
  if (!info_.coreProfile || info_.majorVersion * 10 + info_.minorVersion < 33) {
    return internalError("asked OSMesa for a {} context, got \"{}\" ({}a core profile)", info_.requested,
                         info_.version, info_.coreProfile ? "" : "not ");
  }
  return checkGlErrors(api_, "querying the context's version and limits");
}

Status Context::createTarget() {
  GLint maxSize = 0;
  api_.GetIntegerv(GL_MAX_RENDERBUFFER_SIZE, &maxSize);
  if (width_ > maxSize || height_ > maxSize) {
    return usageError("render target {} x {} exceeds GL_MAX_RENDERBUFFER_SIZE {} of {}", width_, height_, maxSize,
                      info_.renderer);
  }
  api_.GenFramebuffers(1, &framebuffer_);
  api_.BindFramebuffer(GL_FRAMEBUFFER, framebuffer_);
  api_.GenRenderbuffers(static_cast<GLsizei>(renderbuffers_.size()), renderbuffers_.data());
  const GLenum formats[] = {GL_RGBA8, GL_RGBA32F, GL_DEPTH_COMPONENT24};
  const GLenum attachments[] = {GL_COLOR_ATTACHMENT0 + kShadedAttachment, GL_COLOR_ATTACHMENT0 + kNormalAttachment,
                                GL_DEPTH_ATTACHMENT};
  for (std::size_t i = 0; i < renderbuffers_.size(); ++i) {
    api_.BindRenderbuffer(GL_RENDERBUFFER, renderbuffers_[i]);
    api_.RenderbufferStorage(GL_RENDERBUFFER, formats[i], width_, height_);
    api_.FramebufferRenderbuffer(GL_FRAMEBUFFER, attachments[i], GL_RENDERBUFFER, renderbuffers_[i]);
  }
  // Draw-buffer state belongs to the framebuffer: set once, kept by every bind.
  api_.DrawBuffers(2, attachments);
  const GLenum status = api_.CheckFramebufferStatus(GL_FRAMEBUFFER);
  if (status != GL_FRAMEBUFFER_COMPLETE) {
    return internalError("the {} x {} offscreen target (RGBA8 + RGBA32F colour, 24-bit depth) is incomplete: "
                         "glCheckFramebufferStatus gave 0x{:04X} on {}", width_, height_, status, info_.renderer);
  }
  return checkGlErrors(api_, fmt::format("creating the {} x {} offscreen target", width_, height_));
}

void Context::bindTarget() const {
  api_.BindFramebuffer(GL_FRAMEBUFFER, framebuffer_);
  api_.Viewport(0, 0, width_, height_);
}

void Context::clearTarget(const std::array<float, 4>& background) const {
  bindTarget();
  const float zero[4] = {0.0f, 0.0f, 0.0f, 0.0f};
  const float farDepth = 1.0f;
  api_.ClearBufferfv(GL_COLOR, kShadedAttachment, background.data());
  api_.ClearBufferfv(GL_COLOR, kNormalAttachment, zero);
  api_.ClearBufferfv(GL_DEPTH, 0, &farDepth);
}

Status checkGlErrors(const Api& api, std::string_view during) {
  std::string errors;
  // Bounded: GL keeps one flag per error kind, so a handful at most.
  for (int i = 0; i < 8; ++i) {
    const GLenum error = api.GetError();
    if (error == GL_NO_ERROR) break;
    errors += fmt::format("{}{} (0x{:04X})", errors.empty() ? "" : ", ", glErrorName(error), error);
  }
  if (errors.empty()) return okStatus();
  return internalError("GL error while {}: {}", during, errors);
}

}  // namespace apo::gl
