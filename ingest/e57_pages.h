// Internal to ingest: the physical layer of E57 files (ASTM E2807 section
// 9.3), shared by the reader, the writer and the fuzz target.
//
// An E57 file is a sequence of 1024-byte pages. Each page holds 1020 bytes
// of the file's logical content followed by the CRC-32C (Castagnoli) of
// those bytes, stored big-endian (the reference library's choice; every
// other integer of the format is little-endian):
//
//   physical:  | 1020 data | crc | 1020 data | crc | ... | 1020 data | crc |
//   logical:   | 1020 data       | 1020 data       | ... | 1020 data       |
//
// Offsets stored in the file (the XML section's, a section's fileOffset,
// a section's data offset) are physical; lengths are logical. Logical
// content runs on from one page into the next as if the CRCs were not there.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <string_view>

namespace apo::e57 {

inline constexpr std::uint64_t kPageSize = 1024;
inline constexpr std::uint64_t kCrcSize = 4;
inline constexpr std::uint64_t kPageDataSize = kPageSize - kCrcSize;

// CRC-32C (Castagnoli, reflected polynomial 0x82F63B78, initial value and
// final xor 0xFFFFFFFF) of `bytes`: 0xE3069283 for "123456789".
std::uint32_t crc32c(std::string_view bytes);

// Checks that the file is whole pages and that every page's stored CRC
// matches its data; fails "byte N: page K's CRC-32C ..." at the first that
// does not. `progress`, if given, hears the bytes checked every 16 MiB (a
// mapped file's reader gives them back).
void checkPages(std::string_view file, const std::function<void(std::uint64_t checked)>& progress = {});

// Rewrites the CRC of every whole page of `file` (a trailing partial page
// is left as it is). The writer seals its output with it; the fuzz target
// seals mutated inputs so that they reach the layers behind the CRCs.
void sealPages(std::string& file);

// The physical offset of logical offset `logical`.
inline std::uint64_t physicalFromLogical(std::uint64_t logical) {
  return logical / kPageDataSize * kPageSize + logical % kPageDataSize;
}

// The logical content of a checked paged file, read without copying it out:
// reads that cross a page boundary skip the CRC between.
class PagedFile {
 public:
  explicit PagedFile(std::string_view file) : file_(file), logicalSize_(file.size() / kPageSize * kPageDataSize) {}

  std::uint64_t logicalSize() const { return logicalSize_; }

  // The logical offset of physical offset `physical`; fails naming `what`
  // when it lies beyond the file or on a page's CRC.
  std::uint64_t logicalFromPhysical(std::uint64_t physical, std::string_view what) const;

  // Copies logical bytes [logical, logical + count) to `out`; fails naming
  // `what` and the physical offset when they run past the file's end.
  void read(std::uint64_t logical, std::uint64_t count, char* out, std::string_view what) const;
  // The same, appended to `out`.
  void append(std::uint64_t logical, std::uint64_t count, std::string& out, std::string_view what) const;

 private:
  void checkInside(std::uint64_t logical, std::uint64_t count, std::string_view what) const;

  std::string_view file_;
  std::uint64_t logicalSize_;
};

}  // namespace apo::e57
