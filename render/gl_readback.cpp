#include "render/gl_readback.h"

#include "core/timing.h"

#include <algorithm>
#include <vector>

namespace apo::gl {
namespace {

// One attachment as width x height RGBA values of type T, top row first.
template <class T>
Result<std::vector<T>> readAttachment(const Context& context, int attachment, GLenum type) {
  const Api& api = context.api();
  const auto rowValues = static_cast<std::size_t>(context.width()) * 4;
  const auto rows = static_cast<std::size_t>(context.height());
  std::vector<T> bottomUp(rowValues * rows);
  context.bindTarget();
  api.ReadBuffer(GL_COLOR_ATTACHMENT0 + attachment);
  api.PixelStorei(GL_PACK_ALIGNMENT, 1);
  api.ReadPixels(0, 0, context.width(), context.height(), GL_RGBA, type, bottomUp.data());
  APO_RETURN_IF_ERROR(checkGlErrors(api, fmt::format("reading colour attachment {}", attachment)));

  std::vector<T> topDown(bottomUp.size());
  for (std::size_t row = 0; row < rows; ++row) {
    const auto source = bottomUp.begin() + static_cast<std::ptrdiff_t>((rows - 1 - row) * rowValues);
    std::copy(source, source + static_cast<std::ptrdiff_t>(rowValues),
              topDown.begin() + static_cast<std::ptrdiff_t>(row * rowValues));
  }
  return topDown;
}

}  // namespace

Result<Image> readShadedImage(const Context& context) {
  auto pixels = readAttachment<std::uint8_t>(context, kShadedAttachment, GL_UNSIGNED_BYTE);
  if (!pixels) return pixels.error();
  return Image{context.width(), context.height(), std::move(*pixels)};
}

Result<NormalBuffer> readNormalBuffer(const Context& context) {
  auto values = readAttachment<float>(context, kNormalAttachment, GL_FLOAT);
  if (!values) return values.error();
  return NormalBuffer{context.width(), context.height(), std::move(*values)};
}

Result<double> medianFrameMilliseconds(const Api& api, int frames, const std::function<void()>& draw) {
  APO_CHECK_OP(frames, >=, 1);
  std::vector<double> milliseconds;
  for (int frame = 0; frame < frames; ++frame) {
    const Stopwatch stopwatch;
    draw();
    api.Finish();
    milliseconds.push_back(1000.0 * stopwatch.seconds());
  }
  APO_RETURN_IF_ERROR(checkGlErrors(api, "timing frames"));
  // Upper median for an even count: a frame that was really measured.
  const auto middle = milliseconds.begin() + frames / 2;
  std::nth_element(milliseconds.begin(), middle, milliseconds.end());
  return *middle;
}

}  // namespace apo::gl
