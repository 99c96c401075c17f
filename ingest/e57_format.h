// Internal to ingest: the E57 (ASTM E2807) layouts that the reader and the
// writer share. Integers are little-endian; offsets marked physical count
// the page CRCs (e57_pages.h), the others are logical.
//
// File header, logical bytes 0-47 of page 0:
//
//   0   char[8]  signature "ASTM-E57"
//   8   uint32   major version (1)
//   12  uint32   minor version (0)
//   16  uint64   physical length of the file
//   24  uint64   XML section's physical offset
//   32  uint64   XML section's logical length
//   40  uint64   page size (1024)
//
// The XML section describes everything else: /data3D holds one Structure per
// scan, whose `points` CompressedVector names a binary section by its
// physical `fileOffset`, its `recordCount`, and a `prototype` whose leaves
// (Integer, ScaledInteger, Float) are the record's fields, depth first.
//
// Compressed vector section (section header, then packets):
//
//   0   uint8    section id (1: compressed vector)
//   1   byte[7]  reserved (0)
//   8   uint64   section logical length (header and packets)
//   16  uint64   physical offset of the first data packet
//   24  uint64   physical offset of the first index packet (0: none)
//
// Packets, each a multiple of 4 bytes long, follow one another:
//
//   data (type 1):   0 uint8 type, 1 uint8 flags, 2 uint16 length - 1,
//                    4 uint16 bytestream count (one per prototype leaf),
//                    6 uint16[count] bytestream lengths, then the streams
//   index (type 0):  0 uint8 type, 1 uint8 reserved, 2 uint16 length - 1, ...
//   empty (type 2):  0 uint8 type, 1 uint8 reserved, 2 uint16 length - 1, ...
//
// Bytestream i of every data packet continues leaf i's bit stream: values
// packed least significant bit first, Integer and ScaledInteger fields as
// value - minimum in bitsForRange(minimum, maximum) bits, Float fields as
// their 4 or 8 IEEE bytes.
#pragma once

#include <cstdint>

namespace apo::e57 {

inline constexpr char kSignature[] = "ASTM-E57";
inline constexpr std::uint64_t kFileHeaderSize = 48;
inline constexpr char kNamespace[] = "http://www.astm.org/COMMIT/E57/2010-e57-v1.0";

inline constexpr std::uint8_t kCompressedVectorSectionId = 1;
inline constexpr std::uint64_t kSectionHeaderSize = 32;

inline constexpr std::uint8_t kIndexPacket = 0, kDataPacket = 1, kEmptyPacket = 2;
inline constexpr std::uint64_t kPacketHeaderSize = 4;      // type, flags, length - 1
inline constexpr std::uint64_t kDataPacketHeaderSize = 6;  // plus the bytestream count
inline constexpr std::uint64_t kMaxPacketSize = 65536;

// Bits per value of an integer field declared in [minimum, maximum]: the
// fewest that hold maximum - minimum (0 when they are equal, 64 at most).
inline int bitsForRange(std::int64_t minimum, std::int64_t maximum) {
  std::uint64_t range = static_cast<std::uint64_t>(maximum) - static_cast<std::uint64_t>(minimum);
  int bits = 0;
  for (; range != 0; range >>= 1) ++bits;
  return bits;
}

}  // namespace apo::e57
