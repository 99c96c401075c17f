#include "render/gl_texture.h"

namespace apo::gl {

Result<Texture> uploadRgba8Texture(const Context& context, std::uint32_t width, std::uint32_t height, std::uint32_t depth,
                                   const std::vector<std::uint8_t>& texels, std::string_view what) {
  const bool volume = depth > 0;
  // Check the size first: the texels of a refused texture may not even exist.
  const auto maxSize = static_cast<std::uint32_t>(volume ? context.info().max3DTextureSize : context.info().maxTextureSize);
  const std::uint32_t largest = std::max({width, height, depth});
  if (width == 0 || height == 0 || largest > maxSize) {
    return badInput("{} is {} x {}{} texels; this renderer ({}) takes 1 to {} texels per side ({}) and does not split "
                    "textures",
                    what, width, height, volume ? fmt::format(" x {}", depth) : "", context.info().renderer, maxSize,
                    volume ? "GL_MAX_3D_TEXTURE_SIZE" : "GL_MAX_TEXTURE_SIZE");
  }
  const std::uint64_t bytes = std::uint64_t{width} * height * std::max(depth, 1u) * 4;
  if (texels.size() != bytes)
    return internalError("{} is {} x {} x {} texels ({} bytes) but holds {} bytes", what, width, height, depth, bytes,
                         texels.size());

  const Api& api = context.api();
  const GLenum target = volume ? GL_TEXTURE_3D : GL_TEXTURE_2D;
  Texture uploaded = makeTexture(api);
  api.BindTexture(target, uploaded.id());
  // Integer textures are incomplete (sample as zero) unless filtering is nearest.
  api.TexParameteri(target, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  api.TexParameteri(target, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  api.TexParameteri(target, GL_TEXTURE_MAX_LEVEL, 0);
  api.PixelStorei(GL_UNPACK_ALIGNMENT, 1);
  if (volume)
    api.TexImage3D(target, 0, GL_RGBA8UI, static_cast<GLsizei>(width), static_cast<GLsizei>(height),
                   static_cast<GLsizei>(depth), 0, GL_RGBA_INTEGER, GL_UNSIGNED_BYTE, texels.data());
  else
    api.TexImage2D(target, 0, GL_RGBA8UI, static_cast<GLsizei>(width), static_cast<GLsizei>(height), 0, GL_RGBA_INTEGER,
                   GL_UNSIGNED_BYTE, texels.data());
  APO_RETURN_IF_ERROR(checkGlErrors(api, fmt::format("uploading {} as GL_RGBA8UI", what)));
  return uploaded;
}

Result<Texture> uploadFloatTexture(const Context& context, std::uint32_t width, const std::vector<float>& values,
                                   std::string_view what) {
  const std::uint64_t texels = values.size() / 4;
  const std::uint64_t rows = std::max<std::uint64_t>(1, (texels + width - 1) / width);
  const auto maxSize = static_cast<std::uint64_t>(context.info().maxTextureSize);
  if (width == 0 || width > maxSize || rows > maxSize)
    return badInput("{} needs {} x {} texels; this renderer ({}) takes at most {} per side (GL_MAX_TEXTURE_SIZE)", what, width,
                    rows, context.info().renderer, maxSize);
  std::vector<float> padded = values;
  padded.resize(4 * width * rows, 0.0f);
  const Api& api = context.api();
  Texture uploaded = makeTexture(api);
  api.BindTexture(GL_TEXTURE_2D, uploaded.id());
  api.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  api.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  api.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, 0);
  api.PixelStorei(GL_UNPACK_ALIGNMENT, 4);
  api.TexImage2D(GL_TEXTURE_2D, 0, GL_RGBA32F, static_cast<GLsizei>(width), static_cast<GLsizei>(rows), 0, GL_RGBA, GL_FLOAT,
                 padded.data());
  APO_RETURN_IF_ERROR(checkGlErrors(api, fmt::format("uploading {} as GL_RGBA32F", what)));
  return uploaded;
}

Result<Texture> uploadApoTexture(const Context& context, const ApoTexture& texture) {
  return uploadRgba8Texture(context, texture.width, texture.height, 0, texture.texels, "the APO texture");
}

}  // namespace apo::gl
