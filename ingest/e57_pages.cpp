#include "ingest/e57_pages.h"

#include "ingest/parse_util.h"

#include <algorithm>
#include <array>
#include <cstring>

namespace apo::e57 {
namespace {

using parse::fail;

// Slicing-by-8 tables (Intel's "slicing-by-8" CRC, 2005): table 0 is the
// classic byte-at-a-time table; table k advances a byte's CRC through k more
// zero bytes, so that eight bytes are folded per step. Eight bytes a step
// keep the check of every page (all of a file's bytes) well under the
// decoding's cost.
using CrcTables = std::array<std::array<std::uint32_t, 256>, 8>;

constexpr CrcTables makeCrcTables() {
  constexpr std::uint32_t kPolynomial = 0x82F63B78;  // Castagnoli, reflected
  CrcTables tables{};
  for (std::uint32_t byte = 0; byte < 256; ++byte) {
    std::uint32_t crc = byte;
    for (int bit = 0; bit < 8; ++bit) crc = (crc >> 1) ^ ((crc & 1) ? kPolynomial : 0);
    tables[0][byte] = crc;
  }
  for (std::size_t k = 1; k < 8; ++k)
    for (std::size_t byte = 0; byte < 256; ++byte)
      tables[k][byte] = (tables[k - 1][byte] >> 8) ^ tables[0][tables[k - 1][byte] & 0xFF];
  return tables;
}

constexpr CrcTables kCrcTables = makeCrcTables();

std::uint32_t storedCrc(std::string_view file, std::uint64_t page) {
  const auto* at = reinterpret_cast<const unsigned char*>(file.data() + page * kPageSize + kPageDataSize);
  return std::uint32_t{at[0]} << 24 | std::uint32_t{at[1]} << 16 | std::uint32_t{at[2]} << 8 | at[3];
}

std::uint32_t pageCrc(std::string_view file, std::uint64_t page) {
  return crc32c(file.substr(page * kPageSize, kPageDataSize));
}

}  // namespace

std::uint32_t crc32c(std::string_view bytes) {
  const auto& t = kCrcTables;
  std::uint32_t crc = 0xFFFFFFFF;
  const auto* p = reinterpret_cast<const unsigned char*>(bytes.data());
  std::size_t n = bytes.size();
  for (; n >= 8; n -= 8, p += 8) {
    std::uint32_t low;
    std::memcpy(&low, p, 4);  // little-endian machines: the next four bytes, first in the low bits
    low ^= crc;
    crc = t[7][low & 0xFF] ^ t[6][(low >> 8) & 0xFF] ^ t[5][(low >> 16) & 0xFF] ^ t[4][low >> 24] ^ t[3][p[4]] ^
          t[2][p[5]] ^ t[1][p[6]] ^ t[0][p[7]];
  }
  for (; n > 0; --n, ++p) crc = (crc >> 8) ^ t[0][(crc ^ *p) & 0xFF];
  return crc ^ 0xFFFFFFFF;
}

void checkPages(std::string_view file, const std::function<void(std::uint64_t checked)>& progress) {
  if (file.size() % kPageSize != 0)
    fail("byte {}: the file's size is not a whole number of {}-byte E57 pages (truncated?)", file.size(), kPageSize);
  constexpr std::uint64_t kProgressPages = 16384;  // 16 MiB
  for (std::uint64_t page = 0; page < file.size() / kPageSize; ++page) {
    if (progress && page > 0 && page % kProgressPages == 0) progress(page * kPageSize);
    const std::uint32_t stored = storedCrc(file, page), computed = pageCrc(file, page);
    if (stored != computed)
      fail(
          "byte {}: page {}'s CRC-32C {:#010x} (stored at byte {}) does not match its data's {:#010x}: the file is "
          "damaged",
          page * kPageSize, page, stored, page * kPageSize + kPageDataSize, computed);
  }
}

void sealPages(std::string& file) {
  for (std::uint64_t page = 0; page < file.size() / kPageSize; ++page) {
    const std::uint32_t crc = pageCrc(file, page);
    char* at = file.data() + page * kPageSize + kPageDataSize;
    for (int i = 0; i < 4; ++i) at[i] = static_cast<char>(crc >> (24 - 8 * i));
  }
}

std::uint64_t PagedFile::logicalFromPhysical(std::uint64_t physical, std::string_view what) const {
  if (physical >= file_.size()) fail("byte {}: {} lies beyond the file's {} bytes", physical, what, file_.size());
  if (physical % kPageSize >= kPageDataSize)
    fail("byte {}: {} points into page {}'s CRC, not at data", physical, what, physical / kPageSize);
  return physical / kPageSize * kPageDataSize + physical % kPageSize;
}

void PagedFile::checkInside(std::uint64_t logical, std::uint64_t count, std::string_view what) const {
  if (logical > logicalSize_ || count > logicalSize_ - logical)
    fail("byte {}: {} ({} bytes) runs past the file's end at byte {}",
         physicalFromLogical(std::min(logical, logicalSize_)), what, count, file_.size());
}

void PagedFile::read(std::uint64_t logical, std::uint64_t count, char* out, std::string_view what) const {
  checkInside(logical, count, what);
  while (count > 0) {
    const std::uint64_t inPage = logical % kPageDataSize;
    const std::uint64_t take = std::min(count, kPageDataSize - inPage);
    std::memcpy(out, file_.data() + physicalFromLogical(logical), take);
    out += take;
    logical += take;
    count -= take;
  }
}

void PagedFile::append(std::uint64_t logical, std::uint64_t count, std::string& out, std::string_view what) const {
  checkInside(logical, count, what);
  while (count > 0) {
    const std::uint64_t take = std::min(count, kPageDataSize - logical % kPageDataSize);
    out.append(file_.data() + physicalFromLogical(logical), take);
    logical += take;
    count -= take;
  }
}

}  // namespace apo::e57
