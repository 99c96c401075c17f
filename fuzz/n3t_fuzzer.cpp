// libFuzzer target: the .n3t loader (format/n3tree_file.cpp) and what a
// loaded N^3-tree promises: it validates, and every walk on it, plain or
// filtered, stays inside its textures and ends. A file it refuses is a
// BadInput; anything else (a crash, an exception, undefined behaviour, an
// accepted tree that does not validate) is a bug.
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

std::vector<apo::Vec3f> lookupPoints(const std::uint8_t* data, std::size_t size) {
  std::vector<apo::Vec3f> points = {{0.5f, 0.5f, 0.5f}, {0, 0, 0}, {1, 1, 1}, {0.25f, 0.75f, 0.5f}, {-0.1f, 0.5f, 0.5f}};
  for (std::size_t at = 0; at + 12 <= std::min<std::size_t>(size, 96); at += 12) {
    float xyz[3];
    std::memcpy(xyz, data + size - at - 12, sizeof xyz);
    points.emplace_back(xyz[0], xyz[1], xyz[2]);
  }
  return points;
}

// The header's checksum (bytes 104 to 135) made right, so that mutations of
// the payload reach the structure's validation.
std::string withValidChecksum(std::string bytes) {
  constexpr std::size_t kChecksumAt = 104, kHeaderBytes = 136;
  if (bytes.size() < kHeaderBytes) return bytes;
  const std::string hex = apo::sha256OfBytes(std::string_view(bytes).substr(kHeaderBytes));
  for (std::size_t i = 0; i < 32; ++i)
    bytes[kChecksumAt + i] = static_cast<char>(std::stoi(hex.substr(2 * i, 2), nullptr, 16));
  return bytes;
}

void loadAndWalk(std::string_view bytes, const std::vector<apo::Vec3f>& points) {
  const auto tree = apo::parseN3TreeFile(bytes);
  if (!tree.ok()) {
    if (tree.error().kind != apo::ErrorKind::BadInput) {
      std::fprintf(stderr, "refused with a non-BadInput error: %s\n", tree.error().message.c_str());
      std::abort();
    }
    return;
  }
  if (!apo::validateN3Tree(*tree).ok()) {
    std::fprintf(stderr, "an accepted tree does not validate\n");
    std::abort();
  }
  for (const apo::Vec3f& p : points) {
    (void)apo::lookupN3Tree(*tree, p);
    (void)apo::lookupN3TreeFiltered(*tree, p, apo::Vec3f(0.0f, 0.0f, -1.0f));
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
