// The walked textures on the GPU: RGBA8 texels as unsigned integers, for
// `usampler2D`/`usampler3D` + `texelFetch` (the traversals need the exact
// bytes, never a filtered or normalised value).
#pragma once

#include "format/format.h"
#include "adapters/osmesa/gl_context.h"
#include "render/gl_program.h"

#include <string_view>

namespace apo::gl {

// Uploads `texture` as a GL_RGBA8UI 2D texture, nearest filtering, one level,
// texel (x, y) = texture.texels[4 * (y * width + x) ...]; leaves it bound to
// GL_TEXTURE_2D on the active unit. BadInput error when a side exceeds
// GL_MAX_TEXTURE_SIZE (checked before the texels are touched); Internal error
// when the texel count does not match the size or GL fails (out of memory).
Result<Texture> uploadApoTexture(const Context& context, const ApoTexture& texture);

// The same for any RGBA8 texels, 2D (depth 0) or 3D (texel (x, y, z) at
// x + width (y + height z)), `what` naming them in errors.
Result<Texture> uploadRgba8Texture(const Context& context, std::uint32_t width, std::uint32_t height, std::uint32_t depth,
                                   const std::vector<std::uint8_t>& texels, std::string_view what);

// Floats, four per texel (GL_RGBA32F), `width` texels per row: the point
// LOD's object texture, read with texelFetch.
Result<Texture> uploadFloatTexture(const Context& context, std::uint32_t width, const std::vector<float>& values,
                                   std::string_view what);

}  // namespace apo::gl
