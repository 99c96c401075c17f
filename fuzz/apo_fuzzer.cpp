// libFuzzer target: the .apo loader (format/apo_file.cpp) and what a loaded
// texture promises: a file it accepts decodes, and every lookup on it, plain
// or filtered, stays inside the texture and ends. A file it refuses is a
// BadInput; anything else (a crash, an exception, undefined behaviour, an
// accepted file that does not decode) is a bug.
#include "format/format.h"

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string_view>

namespace {

// Lookup points: the cube's corners and centre, and points taken from the
// input's last bytes, so that the fuzzer steers them.
std::vector<apo::Vec3f> lookupPoints(const std::uint8_t* data, std::size_t size) {
  std::vector<apo::Vec3f> points = {{0.5f, 0.5f, 0.5f}, {0, 0, 0}, {1, 1, 1}, {0.25f, 0.75f, 0.5f}, {-0.1f, 0.5f, 0.5f}};
  for (std::size_t at = 0; at + 12 <= std::min<std::size_t>(size, 96); at += 12) {
    float xyz[3];
    std::memcpy(xyz, data + size - at - 12, sizeof xyz);
    points.emplace_back(xyz[0], xyz[1], xyz[2]);
  }
  return points;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const auto texture = apo::parseApoFile(std::string_view(reinterpret_cast<const char*>(data), size));
  if (!texture.ok()) {
    if (texture.error().kind != apo::ErrorKind::BadInput) {
      std::fprintf(stderr, "refused with a non-BadInput error: %s\n", texture.error().message.c_str());
      std::abort();
    }
    return 0;
  }
  if (!apo::decodeApo(*texture).ok()) {
    std::fprintf(stderr, "an accepted texture does not decode\n");
    std::abort();
  }
  for (const apo::Vec3f& p : lookupPoints(data, size)) {
    (void)apo::lookupTexture(*texture, p);
    (void)apo::lookupTextureFiltered(*texture, p);
  }
  return 0;
}
