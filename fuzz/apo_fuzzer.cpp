// libFuzzer target: the .apo loader (format/apo_file.cpp) and what a loaded
// texture promises: a file it accepts decodes, and every lookup on it, plain
// or filtered, stays inside the texture and ends. A file it refuses is a
// BadInput; anything else (a crash, an exception, undefined behaviour, an
// accepted file that does not decode) is a bug.
#include "core/file_io.h"
#include "format/format.h"

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <string_view>
#include <vector>

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


// The bytes with the header's payload checksum (bytes 96 to 127) made right,
// so that mutations of the payload reach the structure's validation rather
// than stopping at the checksum.
std::string withValidChecksum(std::string bytes) {
  constexpr std::size_t kChecksumAt = 96, kHeaderBytes = 128;
  if (bytes.size() < kHeaderBytes) return bytes;
  const std::string hex = apo::sha256OfBytes(std::string_view(bytes).substr(kHeaderBytes));
  for (std::size_t i = 0; i < 32; ++i)
    bytes[kChecksumAt + i] = static_cast<char>(std::stoi(hex.substr(2 * i, 2), nullptr, 16));
  return bytes;
}

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
  const std::vector<apo::Vec3f> points = lookupPoints(data, size);
  loadAndWalk(bytes, points);
  loadAndWalk(withValidChecksum(bytes), points);
  return 0;
}
