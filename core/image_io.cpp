// PNG through stb_image_write (Debian libstb-dev), encoded to memory and then
// written with writeFileAtomically, so a killed run never leaves half a PNG.
// stb lays out the rows (its per-row filter choice) and libdeflate
// compresses them: stb's own deflate took 0.21 s of the 1.2M bunny's bake
// for its 1024 x 767 texture, 2.76 MB; libdeflate at level 6 takes 0.09 s
// for 2.36 MB (docs/bake.md, "A faster build"). Both are
// deterministic and we never touch stb's global settings, so the bytes
// depend only on the image.
#include "core/image_io.h"

#include "core/file_io.h"

#include <libdeflate.h>

#include <climits>
#include <cstdlib>
#include <string>

namespace apo {
namespace {

// libdeflate's default level: level 9 gained 0.001% on the bunny's texture
// for 5% more time, level 1 lost 1.2% for 20% less.
constexpr int kDeflateLevel = 6;

// stb's compressor hook: a zlib stream of the filtered rows in a buffer
// stb frees with free(), or null (stb then fails the encoding).
unsigned char* zlibCompress(unsigned char* data, int length, int* compressedLength, int /*stbQuality*/) {
  libdeflate_compressor* compressor = libdeflate_alloc_compressor(kDeflateLevel);
  if (!compressor) return nullptr;
  const std::size_t bound = libdeflate_zlib_compress_bound(compressor, static_cast<std::size_t>(length));
  auto* out = static_cast<unsigned char*>(std::malloc(bound));
  const std::size_t size = out ? libdeflate_zlib_compress(compressor, data, static_cast<std::size_t>(length), out, bound) : 0;
  libdeflate_free_compressor(compressor);
  if (size == 0 || size > INT_MAX) {
    std::free(out);
    return nullptr;
  }
  *compressedLength = static_cast<int>(size);
  return out;
}

}  // namespace
}  // namespace apo

#define STB_IMAGE_WRITE_IMPLEMENTATION
#define STB_IMAGE_WRITE_STATIC  // keep stb's symbols private to this file
#define STBI_WRITE_NO_STDIO     // only the to-memory writer is used
#define STBIW_ZLIB_COMPRESS apo::zlibCompress
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
