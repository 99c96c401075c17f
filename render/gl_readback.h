// What a pass gives back: the target's attachments read into CPU images with
// row 0 at the top (GL's rows run bottom-up), and its time per frame.
#pragma once

#include "adapters/osmesa/gl_context.h"
#include "render/render.h"

#include <functional>

namespace apo::gl {

// The shaded RGBA8 attachment of the context's target.
Result<Image> readShadedImage(const Context& context);
// The RGBA32F attachment: normal xyz and coverage, as the shaders wrote them.
Result<NormalBuffer> readNormalBuffer(const Context& context);

// Runs `draw` `frames` times (frames >= 1), each followed by glFinish so that
// a frame's time covers the rasteriser's work and not only its submission;
// returns the median wall time of one frame in milliseconds. The first frame
// also pays llvmpipe's shader compilation: use 3 or more frames.
Result<double> medianFrameMilliseconds(const Api& api, int frames, const std::function<void()>& draw);

}  // namespace apo::gl
