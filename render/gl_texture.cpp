#include "render/gl_texture.h"

namespace apo::gl {

Result<Texture> uploadApoTexture(const Context& context, const ApoTexture& texture) {
  // Check the size first: the texels of a refused texture may not even exist.
  const auto maxSize = static_cast<std::uint32_t>(context.info().maxTextureSize);
  if (texture.width == 0 || texture.height == 0 || texture.width > maxSize || texture.height > maxSize) {
    return badInput("the APO texture is {} x {} texels; this renderer ({}) takes 1 to {} texels per side "
                    "(GL_MAX_TEXTURE_SIZE) and does not split textures",
                    texture.width, texture.height, context.info().renderer, maxSize);
  }
  const std::uint64_t bytes = std::uint64_t{texture.width} * texture.height * 4;
  if (texture.texels.size() != bytes) {
    return internalError("the APO texture is {} x {} texels ({} bytes) but holds {} bytes", texture.width,
                         texture.height, bytes, texture.texels.size());
  }

  const Api& api = context.api();
  Texture uploaded = makeTexture(api);
  api.BindTexture(GL_TEXTURE_2D, uploaded.id());
  // Integer textures are incomplete (sample as zero) unless filtering is nearest.
  api.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
  api.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
  api.TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAX_LEVEL, 0);
  api.PixelStorei(GL_UNPACK_ALIGNMENT, 1);
  api.TexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8UI, static_cast<GLsizei>(texture.width),
                 static_cast<GLsizei>(texture.height), 0, GL_RGBA_INTEGER, GL_UNSIGNED_BYTE, texture.texels.data());
  APO_RETURN_IF_ERROR(checkGlErrors(
      api, fmt::format("uploading the {} x {} APO texture as GL_RGBA8UI", texture.width, texture.height)));
  return uploaded;
}

}  // namespace apo::gl
