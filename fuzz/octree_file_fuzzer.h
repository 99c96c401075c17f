// What the .apo and .n3t fuzzers share: lookup points steered by the input,
// and the input with its payload checksum made right, so that mutations of
// the payload reach the structure's validation rather than stopping at the
// checksum.
#pragma once

#include "core/file_io.h"
#include "core/geometry.h"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>
#include <vector>

namespace apo::fuzz {

// The cube's corners and centre, and points taken from the input's last bytes.
inline std::vector<Vec3f> lookupPoints(const std::uint8_t* data, std::size_t size) {
  std::vector<Vec3f> points = {{0.5f, 0.5f, 0.5f}, {0, 0, 0}, {1, 1, 1}, {0.25f, 0.75f, 0.5f}, {-0.1f, 0.5f, 0.5f}};
  for (std::size_t at = 0; at + 12 <= std::min<std::size_t>(size, 96); at += 12) {
    float xyz[3];
    std::memcpy(xyz, data + size - at - 12, sizeof xyz);
    points.emplace_back(xyz[0], xyz[1], xyz[2]);
  }
  return points;
}

// The SHA-256 of the bytes after `headerBytes`, written at `checksumAt`.
inline std::string withValidChecksum(std::string bytes, std::size_t checksumAt, std::size_t headerBytes) {
  if (bytes.size() < headerBytes) return bytes;
  const std::string hex = sha256OfBytes(std::string_view(bytes).substr(headerBytes));
  for (std::size_t i = 0; i < 32; ++i)
    bytes[checksumAt + i] = static_cast<char>(std::stoi(hex.substr(2 * i, 2), nullptr, 16));
  return bytes;
}

}  // namespace apo::fuzz
