// The .apo file, format versions 1 to 4 (docs/apo-format.md): a 128-byte
// little-endian header (160 bytes in versions 2 to 4, which add the scan's local
// frame origin), then the texture's texels. The reader trusts nothing:
// every header field is checked, sizes against the actual file size before
// anything is allocated for them, the payload against its SHA-256, and the
// texel structure by decodeApo, so a corrupt file is a BadInput naming the
// field, never a crash.
#include "format/format.h"
#include "format/header_io.h"
#include "format/texel_layout.h"
#include "core/file_io.h"
#include "core/image_io.h"

#include <algorithm>
#include <bit>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <sstream>
#include <ostream>
#include <string_view>
#include <type_traits>

namespace apo {
namespace {

namespace fs = std::filesystem;
using namespace header_io;

// The header, in file order (docs/apo-format.md, "Header"): header_io's
// leading fields (magic to offset z), then these. The writer checks that it
// lands on these offsets, the tests read the bytes at them.
constexpr Field kCoarseDepth{52, 1, "coarse depth"};
constexpr Field kMaxDepth{53, 1, "max depth"};
constexpr Field kCompleteDepth{54, 1, "complete depth"};
constexpr Field kEncoding{55, 1, "normal encoding"};
constexpr Field kWidth{56, 4, "width"};
constexpr Field kHeight{60, 4, "height"};
constexpr Field kLeafNodes{64, 8, "leaf nodes"};
constexpr Field kInternalNodes{72, 8, "internal nodes"};
constexpr Field kUsedTexels{80, 8, "used texels"};
constexpr Field kPayloadSize{88, 8, "payload size"};
constexpr Field kChecksum{96, 32, "payload SHA-256"};
constexpr std::size_t kHeaderBytes = 128;
static_assert(kChecksum.offset + kChecksum.size == kHeaderBytes);
// Version 2's extension: the origin of the scan's local frame (file
// coordinates = origin + world coordinates of the transform above), then
// the count of two-sided leaves (zero before version 4).
constexpr std::array<Field, 3> kOrigin = {Field{128, 8, "origin x"}, Field{136, 8, "origin y"}, Field{144, 8, "origin z"}};
constexpr Field kTwoSidedLeaves{152, 8, "two-sided leaves"};
constexpr std::size_t kHeaderBytesV2 = 160;
static_assert(kTwoSidedLeaves.offset + kTwoSidedLeaves.size == kHeaderBytesV2);
constexpr std::array<Field, 23> kFields = {kMagic,      kVersion,   kByteOrder,  kHeaderSize,    kScale,       kOffset[0],
                                           kOffset[1],  kOffset[2], kCoarseDepth, kMaxDepth,     kCompleteDepth, kEncoding,
                                           kWidth,      kHeight,    kLeafNodes,  kInternalNodes, kUsedTexels,  kPayloadSize,
                                           kChecksum,   kOrigin[0], kOrigin[1],  kOrigin[2],     kTwoSidedLeaves};

// 0x89 catches 7-bit transfers, CR LF and LF catch line-ending conversions,
// 0x1A stops a DOS `type` (the PNG signature's reasoning).
constexpr Magic kMagicBytes = {0x89, 'A', 'P', 'O', '\r', '\n', 0x1A, '\n'};
// Version 1 is written when the origin is zero (the same bytes as before
// version 2 existed), version 2 otherwise; both are read.
constexpr std::uint32_t kFormatVersion = 1;
constexpr std::uint32_t kFormatVersionWithOrigin = 2;
// Version 3: version 2's header (origin zero or not), and leaves may hold
// the code of "m's own normal" (docs/apo-format.md). Written only when some
// leaf does.
constexpr std::uint32_t kFormatVersionDeferringToCoarse = 3;
// Version 4: version 3, and leaves of two texels (one normal per side of m),
// counted at byte 152, and internal nodes that may show m's normal. Written
// only when some leaf is two-sided or some internal node shows m.
constexpr std::uint32_t kFormatVersionTwoSided = 4;
constexpr std::uint32_t kNewestFormatVersion = kFormatVersionTwoSided;
bool hasOrigin(std::uint32_t version) { return version >= kFormatVersionWithOrigin; }

std::uint32_t headerBytesOf(std::uint32_t version) { return hasOrigin(version) ? kHeaderBytesV2 : kHeaderBytes; }

// The header's fields as stored.
struct Header : LeadingHeader {
  std::uint8_t coarseDepth = 0, maxDepth = 0, completeDepth = 0, encoding = 0;
  std::uint32_t width = 0, height = 0;
  std::uint64_t leafNodes = 0, internalNodes = 0, usedTexels = 0, payloadSize = 0;
  std::array<std::uint8_t, 32> checksum{};
  std::array<double, 3> origin{};  // version 2
  std::uint64_t twoSidedLeaves = 0;  // versions 2 to 4 (zero before 4)
};

// ---- Writing ------------------------------------------------------------------

Header headerOf(const ApoTexture& texture) {
  Header header;
  header.magic = kMagicBytes;
  header.origin = texture.origin;
  header.version = texture.twoSidedLeaves > 0 || texture.coarseAtInternalNodes ? kFormatVersionTwoSided
                   : texture.defersToCoarse                       ? kFormatVersionDeferringToCoarse
                   : header.origin == std::array<double, 3>{} ? kFormatVersion
                                                              : kFormatVersionWithOrigin;
  header.twoSidedLeaves = texture.twoSidedLeaves;
  header.byteOrderMark = kByteOrderMark;
  header.headerSize = headerBytesOf(header.version);
  header.scale = texture.transform.scale;
  header.offset = texture.transform.offset;
  header.coarseDepth = texture.coarseDepth;
  header.maxDepth = texture.maxDepth;
  header.completeDepth = texture.completeDepth;
  header.encoding = static_cast<std::uint8_t>(texture.encoding);
  header.width = texture.width;
  header.height = texture.height;
  header.leafNodes = texture.leafNodes;
  header.internalNodes = texture.internalNodes;
  header.usedTexels = texture.usedTexels();
  header.payloadSize = texture.texels.size();
  header.checksum = checksumOf(texture.texels);
  return header;
}

std::string headerBytes(const Header& header) {
  HeaderWriter out;
  writeLeadingHeader(out, header);
  out.integer(kCoarseDepth, header.coarseDepth);
  out.integer(kMaxDepth, header.maxDepth);
  out.integer(kCompleteDepth, header.completeDepth);
  out.integer(kEncoding, header.encoding);
  out.integer(kWidth, header.width);
  out.integer(kHeight, header.height);
  out.integer(kLeafNodes, header.leafNodes);
  out.integer(kInternalNodes, header.internalNodes);
  out.integer(kUsedTexels, header.usedTexels);
  out.integer(kPayloadSize, header.payloadSize);
  out.raw(kChecksum, header.checksum);
  if (hasOrigin(header.version)) {
    out.float64s(kOrigin, header.origin);
    out.integer(kTwoSidedLeaves, header.twoSidedLeaves);
  }
  APO_CHECK_OP(out.bytes().size(), ==, header.headerSize);
  return out.bytes();
}

// ---- Reading ------------------------------------------------------------------

Result<Header> parseHeader(std::string_view bytes, std::uint64_t fileSize) {
  HeaderReader in(bytes, fileSize);
  Header header;
  APO_RETURN_IF_ERROR(readLeadingHeader(in, kMagicBytes, ".apo", header));
  APO_RETURN_IF_ERROR(in.integer(kCoarseDepth, header.coarseDepth));
  APO_RETURN_IF_ERROR(in.integer(kMaxDepth, header.maxDepth));
  APO_RETURN_IF_ERROR(in.integer(kCompleteDepth, header.completeDepth));
  APO_RETURN_IF_ERROR(in.integer(kEncoding, header.encoding));
  APO_RETURN_IF_ERROR(in.integer(kWidth, header.width));
  APO_RETURN_IF_ERROR(in.integer(kHeight, header.height));
  APO_RETURN_IF_ERROR(in.integer(kLeafNodes, header.leafNodes));
  APO_RETURN_IF_ERROR(in.integer(kInternalNodes, header.internalNodes));
  APO_RETURN_IF_ERROR(in.integer(kUsedTexels, header.usedTexels));
  APO_RETURN_IF_ERROR(in.integer(kPayloadSize, header.payloadSize));
  APO_RETURN_IF_ERROR(in.raw(kChecksum, header.checksum));
  if (hasOrigin(header.version)) {
    APO_RETURN_IF_ERROR(in.float64s(kOrigin, header.origin));
    APO_RETURN_IF_ERROR(in.integer(kTwoSidedLeaves, header.twoSidedLeaves));
  }
  return header;
}

Status checkIdentity(const Header& header) {
  APO_RETURN_IF_ERROR(checkMagic(header.magic, kMagicBytes, ".apo"));
  if (header.version < kFormatVersion || header.version > kNewestFormatVersion)
    return fieldError(kVersion, "expected {} to {} (the versions this reader knows), found {}", kFormatVersion,
                      kNewestFormatVersion, header.version);
  APO_RETURN_IF_ERROR(checkByteOrder(kByteOrder, header.byteOrderMark));
  if (header.headerSize != headerBytesOf(header.version))
    return fieldError(kHeaderSize, "expected {} for format version {}, found {}", headerBytesOf(header.version),
                      header.version, header.headerSize);
  return okStatus();
}

Status checkOrigin(const Header& header) {
  if (!hasOrigin(header.version)) return okStatus();
  APO_RETURN_IF_ERROR(checkFinite(kOrigin, header.origin));
  if (header.version < kFormatVersionTwoSided && header.twoSidedLeaves != 0)
    return fieldError(kTwoSidedLeaves, "expected 0 in format version {} (two-sided leaves came with version 4), found {}",
                      header.version, header.twoSidedLeaves);
  return okStatus();
}

Status checkSettings(const Header& header) {
  if (header.maxDepth > texel::kMaxDepth)
    return fieldError(kMaxDepth, "expected at most {}, found {}", texel::kMaxDepth, int{header.maxDepth});
  if (header.coarseDepth > header.maxDepth)
    return fieldError(kCoarseDepth, "expected at most the max depth {}, found {}", int{header.maxDepth},
                      int{header.coarseDepth});
  const int completeLimit = std::min<int>(texel::kMaxCompleteDepth, header.coarseDepth);
  if (header.completeDepth > completeLimit)
    return fieldError(kCompleteDepth, "expected at most min({}, coarse depth {}) = {}, found {}",
                      texel::kMaxCompleteDepth, int{header.coarseDepth}, completeLimit, int{header.completeDepth});
  if (header.encoding > static_cast<std::uint8_t>(NormalEncoding::Oct24))
    return fieldError(kEncoding, "expected 0 (xyz8) or 1 (oct24), found {}", int{header.encoding});
  return okStatus();
}

// Sizes against each other and against the bytes the file really has.
Status checkSizes(const Header& header, std::uint64_t fileSize) {
  if (header.width == 0 || !std::has_single_bit(header.width) || header.width > texel::kMaxWidth)
    return fieldError(kWidth, "expected a power of two at most {}, found {}", texel::kMaxWidth, header.width);
  const std::uint64_t texels = std::uint64_t{header.width} * header.height;  // < 2^46: no overflow
  if (header.payloadSize != 4 * texels)
    return fieldError(kPayloadSize, "expected width x height x 4 = {} x {} x 4 = {}, found {}", header.width,
                      header.height, 4 * texels, header.payloadSize);
  if (fileSize < header.headerSize || header.payloadSize != fileSize - header.headerSize)
    return fieldError(kPayloadSize, "the header claims {} bytes of texels, but the file has {} bytes after the "
                      "header (truncated or padded file)",
                      header.payloadSize, fileSize < header.headerSize ? 0 : fileSize - header.headerSize);
  const std::uint64_t gridTexels = std::uint64_t{1} << (3 * header.completeDepth);
  if (header.usedTexels < gridTexels || header.usedTexels > texels)
    return fieldError(kUsedTexels, "expected between the {} grid texels and the {} texels of the texture, found {}",
                      gridTexels, texels, header.usedTexels);
  if (header.leafNodes > header.usedTexels || header.internalNodes > header.usedTexels ||
      header.twoSidedLeaves > header.leafNodes ||
      gridTexels + header.leafNodes + header.twoSidedLeaves + 2 * header.internalNodes != header.usedTexels)
    return fieldError(kUsedTexels,
                      "expected grid + leaves + two-sided leaves + 2 x internal nodes = {} + {} + {} + 2 x {}, found {}",
                      gridTexels, header.leafNodes, header.twoSidedLeaves, header.internalNodes, header.usedTexels);
  if (header.height != texel::rowsFor(header.usedTexels, header.width))
    return fieldError(kHeight, "expected {} rows for {} used texels at width {}, found {}",
                      texel::rowsFor(header.usedTexels, header.width), header.usedTexels, header.width,
                      header.height);
  return okStatus();
}

// Every field but the checksum, in file order; fileSize is the whole file's.
Status checkHeader(const Header& header, std::uint64_t fileSize) {
  APO_RETURN_IF_ERROR(checkIdentity(header));
  APO_RETURN_IF_ERROR(checkTransform(header));
  APO_RETURN_IF_ERROR(checkOrigin(header));
  APO_RETURN_IF_ERROR(checkSettings(header));
  return checkSizes(header, fileSize);
}

ApoTexture textureOf(const Header& header, std::vector<std::uint8_t> texels) {
  ApoTexture texture;
  texture.transform.scale = header.scale;
  texture.transform.offset = header.offset;
  texture.coarseDepth = header.coarseDepth;
  texture.maxDepth = header.maxDepth;
  texture.completeDepth = header.completeDepth;
  texture.encoding = static_cast<NormalEncoding>(header.encoding);
  texture.width = header.width;
  texture.height = header.height;
  texture.leafNodes = header.leafNodes;
  texture.internalNodes = header.internalNodes;
  texture.texels = std::move(texels);
  texture.origin = header.origin;
  // Version 4 is version 3 with two-sided leaves: both may hold m's code.
  texture.defersToCoarse = header.version >= kFormatVersionDeferringToCoarse;
  texture.twoSidedLeaves = header.twoSidedLeaves;
  texture.coarseAtInternalNodes = header.version >= kFormatVersionTwoSided;
  return texture;
}

// The file's header and its checked payload; errors without the path.
Result<ApoTexture> readTexture(std::istream& in, std::uint64_t fileSize) {
  std::string head(std::min<std::uint64_t>(fileSize, kHeaderBytesV2), '\0');
  in.read(head.data(), static_cast<std::streamsize>(head.size()));
  if (static_cast<std::size_t>(in.gcount()) != head.size())
    return badInput("read {} of the first {} bytes", in.gcount(), head.size());
  const Result<Header> header = parseHeader(head, fileSize);
  if (!header.ok()) return header.error();
  APO_RETURN_IF_ERROR(checkHeader(*header, fileSize));

  // payloadSize now equals the bytes the file has after its header.
  in.clear();
  in.seekg(static_cast<std::streamoff>(header->headerSize));
  std::vector<std::uint8_t> texels(header->payloadSize);
  in.read(reinterpret_cast<char*>(texels.data()), static_cast<std::streamsize>(texels.size()));
  if (static_cast<std::uint64_t>(in.gcount()) != texels.size())
    return badInput("byte {}: read {} of the {} bytes of texels (the file changed while read?)", header->headerSize,
                    in.gcount(), texels.size());
  const std::array<std::uint8_t, 32> checksum = checksumOf(texels);
  if (checksum != header->checksum)
    return fieldError(kChecksum, "the texels hash to {}, the header says {} (corrupt payload)",
                      hexBytes(checksum.data(), 32, ""), hexBytes(header->checksum.data(), 32, ""));

  ApoTexture texture = textureOf(*header, std::move(texels));
  // The structure; its node counts are checked against the header's.
  const Result<Octree> decoded = decodeApo(texture);
  if (!decoded.ok()) return badInput("payload: {}", decoded.error().message);
  return texture;
}

}  // namespace

std::uint64_t apoFileBytes(std::uint64_t usedTexels, bool withOrigin) {
  const std::uint32_t width = texel::textureWidthFor(usedTexels);
  return headerBytesOf(withOrigin ? kFormatVersionWithOrigin : kFormatVersion) +
         4 * std::uint64_t{width} * texel::rowsFor(usedTexels, width);
}

Status writeApoFile(const fs::path& path, const ApoTexture& texture) {
  const Header header = headerOf(texture);
  // Never write a file the reader would refuse.
  if (Status valid = checkHeader(header, header.headerSize + texture.texels.size()); !valid.ok())
    return internalError("{}: refusing to write an inconsistent texture: {}", path.string(), valid.error().message);
  const std::string head = headerBytes(header);
  return writeFileAtomically(path, [&](std::ostream& out) {
    out.write(head.data(), static_cast<std::streamsize>(head.size()));
    out.write(reinterpret_cast<const char*>(texture.texels.data()),
              static_cast<std::streamsize>(texture.texels.size()));
    return okStatus();
  });
}

Result<ApoTexture> readApoFile(const fs::path& path) {
  return readBinaryFile<ApoTexture>(path, [](std::istream& in, std::uint64_t fileSize) { return readTexture(in, fileSize); });
}

std::string describeApoFileByte(std::string_view bytes, std::uint64_t offset) {
  const Result<Header> header = parseHeader(bytes.substr(0, std::min<std::size_t>(bytes.size(), kHeaderBytesV2)), bytes.size());
  const std::uint64_t headerSize = header.ok() ? headerBytesOf(header->version) : kHeaderBytes;
  if (offset < headerSize) {
    for (const Field& field : kFields)
      if (offset >= field.offset && offset < field.offset + field.size)
        return fmt::format("the header's {} (bytes {} to {})", field.name, field.offset, field.offset + field.size - 1);
  }
  const std::uint64_t texel = (offset - headerSize) / 4;
  const char channel = "RGBA"[(offset - headerSize) % 4];
  const std::string where = fmt::format("texel {}, channel {}", texel, channel);
  if (!header.ok() || header->completeDepth > texel::kMaxCompleteDepth) return where;
  const std::uint64_t gridTexels = std::uint64_t{1} << (3 * header->completeDepth);
  if (texel < gridTexels) return where + fmt::format(" (a grid entry: the grid has {} texels)", gridTexels);
  if (texel < header->usedTexels) return where + fmt::format(" (a node: nodes run from texel {} to {})", gridTexels, header->usedTexels - 1);
  return where + fmt::format(" (padding after the {} used texels)", header->usedTexels);
}

Result<ApoTexture> parseApoFile(std::string_view bytes) {
  std::istringstream in{std::string(bytes)};
  return readTexture(in, bytes.size());
}

Status writeApoPng(const fs::path& path, const ApoTexture& texture) {
  return writePngRgba8(path, texture.width, texture.height, texture.texels);
}

}  // namespace apo
