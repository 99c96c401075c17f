// PNG through stb_image_write (Debian libstb-dev), encoded to memory and then
// written with writeFileAtomically, so a killed run never leaves half a PNG.
// stb's own deflate and its per-row filter choice are deterministic, and we
// never touch its global settings, so the bytes depend only on the image.
#include "core/image_io.h"

#include "core/file_io.h"

#include <climits>
#include <string>

#define STB_IMAGE_WRITE_IMPLEMENTATION
#define STB_IMAGE_WRITE_STATIC  // keep stb's symbols private to this file
#define STBI_WRITE_NO_STDIO     // only the to-memory writer is used
#include <stb_image_write.h>

namespace apo {
namespace {

void appendToString(void* context, void* data, int size) {
  static_cast<std::string*>(context)->append(static_cast<const char*>(data), static_cast<std::size_t>(size));
}

}  // namespace

Result<std::string> encodePng8(std::uint32_t width, std::uint32_t height, int channels,
                               const std::vector<std::uint8_t>& pixels) {
  // stb takes int sizes and an int row stride.
  if (channels < 1 || channels > 4 || width == 0 || height == 0 || width > INT_MAX / 4 || height > INT_MAX)
    return internalError("cannot encode a {} x {} PNG of {} channels", width, height, channels);
  const std::uint64_t expected = std::uint64_t{width} * height * static_cast<std::uint64_t>(channels);
  if (pixels.size() != expected)
    return internalError("{} bytes of pixels for a {} x {} image of {} channels (expected {})", pixels.size(), width,
                         height, channels, expected);
  std::string png;
  const int stride = static_cast<int>(width) * channels;
  if (stbi_write_png_to_func(appendToString, &png, static_cast<int>(width), static_cast<int>(height), channels,
                             pixels.data(), stride) == 0)
    return internalError("the PNG encoder failed on a {} x {} image", width, height);
  return png;
}

Status writePngRgba8(const std::filesystem::path& path, std::uint32_t width, std::uint32_t height,
                     const std::vector<std::uint8_t>& rgba) {
  auto png = encodePng8(width, height, 4, rgba);
  if (!png) return internalError("{}: {}", path.string(), png.error().message);
  return writeFileAtomically(path, *png);
}

}  // namespace apo
