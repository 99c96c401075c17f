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

Status writePngRgba8(const std::filesystem::path& path, std::uint32_t width, std::uint32_t height,
                     const std::vector<std::uint8_t>& rgba) {
  constexpr std::uint64_t kChannels = 4;
  // stb takes int sizes and an int row stride.
  if (width == 0 || height == 0 || width > INT_MAX / kChannels || height > INT_MAX)
    return internalError("{}: cannot write a {} x {} PNG", path.string(), width, height);
  if (rgba.size() != std::uint64_t{width} * height * kChannels)
    return internalError("{}: {} bytes of pixels for a {} x {} RGBA image (expected {})", path.string(), rgba.size(),
                         width, height, std::uint64_t{width} * height * kChannels);
  std::string png;
  const int stride = static_cast<int>(width * kChannels);
  if (stbi_write_png_to_func(appendToString, &png, static_cast<int>(width), static_cast<int>(height),
                             static_cast<int>(kChannels), rgba.data(), stride) == 0)
    return internalError("{}: the PNG encoder failed on a {} x {} image", path.string(), width, height);
  return writeFileAtomically(path, png);
}

}  // namespace apo
