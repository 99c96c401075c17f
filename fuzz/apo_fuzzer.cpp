// libFuzzer target: the .apo loader (format/apo_file.cpp) and what a loaded
// texture promises: a file it accepts decodes, and every lookup on it, plain
// or filtered, stays inside the texture and ends. A file it refuses is a
// BadInput; anything else (a crash, an exception, undefined behaviour, an
// accepted file that does not decode) is a bug.
#include "format/format.h"
#include "fuzz/octree_file_fuzzer.h"

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <string_view>
#include <vector>

namespace {

void loadAndWalk(std::string_view bytes, const std::vector<apo::Vec3f>& points) {
  const auto texture = apo::parseApoFile(bytes);
  if (!texture.ok()) {
    if (texture.error().kind != apo::ErrorKind::BadInput) {
      std::fprintf(stderr, "refused with a non-BadInput error: %s\n", texture.error().message.c_str());
      std::abort();
    }
    return;
  }
  if (!apo::decodeApo(*texture).ok()) {
    std::fprintf(stderr, "an accepted texture does not decode\n");
    std::abort();
  }
  for (const apo::Vec3f& p : points) {
    (void)apo::lookupTexture(*texture, p);
    (void)apo::lookupTextureFiltered(*texture, p);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  const std::vector<apo::Vec3f> points = apo::fuzz::lookupPoints(data, size);
  loadAndWalk(bytes, points);
  loadAndWalk(apo::fuzz::withValidChecksum(bytes, 96, 128), points);  // the header's checksum bytes, its size
  return 0;
}
