// The APO texture on the GPU: its RGBA8 texels as unsigned integers, for
// `usampler2D` + `texelFetch` (the traversal needs the exact bytes, never a
// filtered or normalised value).
#pragma once

#include "format/format.h"
#include "adapters/osmesa/gl_context.h"
#include "render/gl_program.h"

namespace apo::gl {

// Uploads `texture` as a GL_RGBA8UI 2D texture, nearest filtering, one level,
// texel (x, y) = texture.texels[4 * (y * width + x) ...]; leaves it bound to
// GL_TEXTURE_2D on the active unit. BadInput error when a side exceeds
// GL_MAX_TEXTURE_SIZE (checked before the texels are touched); Internal error
// when the texel count does not match the size or GL fails (out of memory).
Result<Texture> uploadApoTexture(const Context& context, const ApoTexture& texture);

}  // namespace apo::gl
