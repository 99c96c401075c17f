// Internal to format/: header fields of the binary files (.apo, .n3t) at
// documented offsets, written in order and read with errors that name the
// field; the fields both files' headers start with; and the SHA-256 of a
// payload as raw bytes.
#pragma once

#include "core/error.h"
#include "core/file_io.h"

#include <array>
#include <cerrno>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <new>
#include <bit>
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

namespace apo::header_io {

// A header field: where it is, how long, its name in messages and the doc.
struct Field {
  std::size_t offset;
  std::size_t size;
  std::string_view name;
};

template <class... Args>
Error fieldError(const Field& field, fmt::format_string<Args...> format, Args&&... args) {
  return badInput("byte {} ({}): {}", field.offset, field.name, fmt::format(format, std::forward<Args>(args)...));
}

// Every binary file's byte-order mark: stored little-endian as 04 03 02 01;
// any other order means a writer that ignored the byte order.
inline constexpr std::uint32_t kByteOrderMark = 0x01020304;

inline std::string hexBytes(const std::uint8_t* bytes, std::size_t count, std::string_view separator) {
  std::string hex;
  for (std::size_t i = 0; i < count; ++i) hex += fmt::format("{}{:02x}", i ? separator : "", bytes[i]);
  return hex;
}

inline Status checkByteOrder(const Field& field, std::uint32_t found) {
  if (found != kByteOrderMark)
    return fieldError(field, "expected {:#010x} stored as 04 03 02 01, found {:#010x}", kByteOrderMark, found);
  return okStatus();
}

class HeaderWriter {
 public:
  template <class T>
  void integer(const Field& field, T value) {
    static_assert(std::is_unsigned_v<T>);
    at(field, sizeof(T));
    for (std::size_t i = 0; i < sizeof(T); ++i) bytes_.push_back(static_cast<char>((value >> (8 * i)) & 0xFF));
  }
  void float64(const Field& field, double value) { integer(field, std::bit_cast<std::uint64_t>(value)); }
  void float64s(const std::array<Field, 3>& fields, const std::array<double, 3>& values) {
    for (int axis = 0; axis < 3; ++axis) float64(fields[axis], values[axis]);
  }
  template <std::size_t N>
  void raw(const Field& field, const std::array<std::uint8_t, N>& value) {
    at(field, N);
    bytes_.append(reinterpret_cast<const char*>(value.data()), N);
  }
  const std::string& bytes() const { return bytes_; }

 private:
  // The fields are written in order, each at its documented offset.
  void at(const Field& field, std::size_t size) {
    APO_CHECK_OP(bytes_.size(), ==, field.offset);
    APO_CHECK_OP(size, ==, field.size);
  }
  std::string bytes_;
};

inline std::array<std::uint8_t, 32> checksumOf(const std::vector<std::uint8_t>& payload) {
  const std::string hex = sha256OfBytes(
      std::string_view(reinterpret_cast<const char*>(payload.data()), payload.size()));
  APO_CHECK_OP(hex.size(), ==, 64u);
  std::array<std::uint8_t, 32> digest{};
  for (std::size_t i = 0; i < digest.size(); ++i)
    digest[i] = static_cast<std::uint8_t>(std::stoul(hex.substr(2 * i, 2), nullptr, 16));
  return digest;
}

// Fields read from the bytes of the header the file has, which may be fewer
// than the header's size: reading past them names the field the file ends in.
class HeaderReader {
 public:
  HeaderReader(std::string_view bytes, std::uint64_t fileSize) : bytes_(bytes), fileSize_(fileSize) {}

  template <class T>
  Status integer(const Field& field, T& value) {
    APO_RETURN_IF_ERROR(available(field));
    value = 0;
    for (std::size_t i = 0; i < sizeof(T); ++i)
      value |= static_cast<T>(static_cast<T>(static_cast<std::uint8_t>(bytes_[field.offset + i])) << (8 * i));
    return okStatus();
  }
  Status float64(const Field& field, double& value) {
    std::uint64_t bits = 0;
    APO_RETURN_IF_ERROR(integer(field, bits));
    value = std::bit_cast<double>(bits);
    return okStatus();
  }
  Status float64s(const std::array<Field, 3>& fields, std::array<double, 3>& values) {
    for (int axis = 0; axis < 3; ++axis) APO_RETURN_IF_ERROR(float64(fields[axis], values[axis]));
    return okStatus();
  }
  template <std::size_t N>
  Status raw(const Field& field, std::array<std::uint8_t, N>& value) {
    APO_RETURN_IF_ERROR(available(field));
    std::memcpy(value.data(), bytes_.data() + field.offset, N);
    return okStatus();
  }

 private:
  Status available(const Field& field) const {
    if (field.offset + field.size > bytes_.size())
      return fieldError(field, "the file ends after {} bytes, inside the header (truncated file)", fileSize_);
    return okStatus();
  }
  std::string_view bytes_;
  std::uint64_t fileSize_;
};

// ---- The fields every binary file's header starts with ---------------------------
// Bytes 0 to 51 of .apo and .n3t alike (docs/apo-format.md, "Header";
// docs/n3tree-format.md, "The file"): which file it is, its version, its byte
// order and header size, then the unit-cube transform (unit = world * scale
// + offset). Each file's own fields follow from byte 52.

using Magic = std::array<std::uint8_t, 8>;

inline constexpr Field kMagic{0, 8, "magic"};
inline constexpr Field kVersion{8, 4, "format version"};
inline constexpr Field kByteOrder{12, 4, "byte-order mark"};
inline constexpr Field kHeaderSize{16, 4, "header size"};
inline constexpr Field kScale{20, 8, "scale"};
inline constexpr std::array<Field, 3> kOffset = {Field{28, 8, "offset x"}, Field{36, 8, "offset y"},
                                                 Field{44, 8, "offset z"}};
inline constexpr std::size_t kLeadingHeaderBytes = 52;
static_assert(kOffset[2].offset + kOffset[2].size == kLeadingHeaderBytes);

// Those fields as stored.
struct LeadingHeader {
  Magic magic{};
  std::uint32_t version = 0, byteOrderMark = 0, headerSize = 0;
  double scale = 0;
  std::array<double, 3> offset{};
};

inline void writeLeadingHeader(HeaderWriter& out, const LeadingHeader& header) {
  out.raw(kMagic, header.magic);
  out.integer(kVersion, header.version);
  out.integer(kByteOrder, header.byteOrderMark);
  out.integer(kHeaderSize, header.headerSize);
  out.float64(kScale, header.scale);
  out.float64s(kOffset, header.offset);
}

// `fileKind` names the file the magic says it is (".apo").
inline Status checkMagic(const Magic& found, const Magic& expected, std::string_view fileKind) {
  if (found != expected)
    return fieldError(kMagic, "expected {}, found {}: not an {} file, or one altered by a text-mode transfer",
                      hexBytes(expected.data(), 8, " "), hexBytes(found.data(), 8, " "), fileKind);
  return okStatus();
}

// The magic checked first, so that any other file is reported as such even
// when it is shorter than a header.
inline Status readLeadingHeader(HeaderReader& in, const Magic& expected, std::string_view fileKind, LeadingHeader& header) {
  APO_RETURN_IF_ERROR(in.raw(kMagic, header.magic));
  APO_RETURN_IF_ERROR(checkMagic(header.magic, expected, fileKind));
  APO_RETURN_IF_ERROR(in.integer(kVersion, header.version));
  APO_RETURN_IF_ERROR(in.integer(kByteOrder, header.byteOrderMark));
  APO_RETURN_IF_ERROR(in.integer(kHeaderSize, header.headerSize));
  APO_RETURN_IF_ERROR(in.float64(kScale, header.scale));
  return in.float64s(kOffset, header.offset);
}

inline Status checkFinite(const std::array<Field, 3>& fields, const std::array<double, 3>& values) {
  for (int axis = 0; axis < 3; ++axis)
    if (!std::isfinite(values[axis])) return fieldError(fields[axis], "expected a finite number, found {}", values[axis]);
  return okStatus();
}

inline Status checkTransform(const LeadingHeader& header) {
  if (!std::isfinite(header.scale) || !(header.scale > 0))
    return fieldError(kScale, "expected a finite positive number, found {}", header.scale);
  return checkFinite(kOffset, header.offset);
}

// A binary file read by `readFrom(stream, fileSize)` (which knows nothing of
// the path): errors prefixed with the path, memory exhaustion a BadInput.
template <class T, class ReadFrom>
Result<T> readBinaryFile(const std::filesystem::path& path, ReadFrom&& readFrom) {
  APO_RETURN_IF_ERROR(checkReadableFile(path));
  std::error_code ec;
  const std::uintmax_t fileSize = std::filesystem::file_size(path, ec);
  if (ec) return badInput("{}: cannot read its size: {}", path.string(), ec.message());
  std::ifstream in(path, std::ios::binary);
  if (!in) return badInput("{}: cannot be opened: {}", path.string(), std::strerror(errno));
  try {
    Result<T> read = readFrom(in, static_cast<std::uint64_t>(fileSize));
    if (!read.ok()) return badInput("{}: {}", path.string(), read.error().message);
    return read;
  } catch (const std::bad_alloc&) {
    return badInput("{}: not enough memory to hold its {} bytes", path.string(), fileSize);
  }
}

}  // namespace apo::header_io
