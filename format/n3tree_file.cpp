// The .n3t file, version 1 (docs/n3tree-format.md): a 136-byte little-endian
// header, then the indirection pool, the LOD pool and the side pairs. The
// reader trusts nothing: every header field is checked, sizes against the
// actual file size before anything is allocated for them, the payload
// against its SHA-256, and the structure by validateN3Tree.
#include "format/format.h"
#include "format/header_io.h"
#include "format/texel_layout.h"

#include <cerrno>
#include <cmath>
#include <fstream>
#include <sstream>

namespace apo {
namespace {

namespace fs = std::filesystem;
using namespace header_io;

// The header, in file order (docs/n3tree-format.md, "The file"): header_io's
// leading fields (magic to offset z), then these.
constexpr std::array<Field, 3> kOrigin = {Field{52, 8, "origin x"}, Field{60, 8, "origin y"}, Field{68, 8, "origin z"}};
constexpr Field kN{76, 1, "N"};
constexpr Field kLevels{77, 1, "levels"};
constexpr Field kEncoding{78, 1, "normal encoding"};
constexpr Field kFlags{79, 1, "flags"};
constexpr std::array<Field, 3> kGrids = {Field{80, 2, "grids along u"}, Field{82, 2, "grids along v"},
                                         Field{84, 2, "grids along w"}};
constexpr Field kReserved{86, 2, "reserved"};
constexpr Field kUsedGrids{88, 4, "used grids"};
constexpr Field kTwoSidedLeaves{92, 4, "two-sided leaves"};
constexpr Field kPayloadSize{96, 8, "payload size"};
constexpr Field kChecksum{104, 32, "payload SHA-256"};
constexpr std::uint32_t kHeaderBytes = 136;
static_assert(kChecksum.offset + kChecksum.size == kHeaderBytes);

constexpr Magic kMagicBytes = {0x89, 'N', '3', 'T', '\r', '\n', 0x1A, '\n'};
constexpr std::uint32_t kFormatVersion = 1;
constexpr std::uint8_t kDefersToCoarse = 1, kCoarseAtInternalNodes = 2;

struct Header : LeadingHeader {
  std::array<double, 3> origin{};
  std::uint8_t n = 0, levels = 0, encoding = 0, flags = 0;
  std::array<std::uint16_t, 3> grids{};
  std::uint16_t reserved = 0;
  std::uint32_t usedGrids = 0, twoSidedLeaves = 0;
  std::uint64_t payloadSize = 0;
  std::array<std::uint8_t, 32> checksum{};
};

// The payload's three parts, from the header's shape.
struct PayloadSizes {
  std::uint64_t pool = 0, lod = 0, sides = 0;
  std::uint64_t total() const { return pool + lod + sides; }
};

PayloadSizes payloadSizes(std::uint32_t n, const std::array<std::uint16_t, 3>& grids, std::uint32_t twoSidedLeaves) {
  const std::uint64_t gridCount = std::uint64_t{grids[0]} * grids[1] * grids[2];
  const std::uint64_t rows = (2 * std::uint64_t{twoSidedLeaves} + N3Tree::kSidesWidth - 1) / N3Tree::kSidesWidth;
  return {4 * gridCount * n * n * n, 4 * gridCount, 4 * rows * N3Tree::kSidesWidth};
}

std::vector<std::uint8_t> payloadOf(const N3Tree& tree) {
  std::vector<std::uint8_t> payload;
  payload.reserve(tree.textureBytes());
  for (const std::vector<std::uint8_t>* part : {&tree.pool, &tree.lod, &tree.sides})
    payload.insert(payload.end(), part->begin(), part->end());
  return payload;
}

std::string headerBytes(const N3Tree& tree, const std::vector<std::uint8_t>& payload) {
  HeaderWriter out;
  writeLeadingHeader(out, {kMagicBytes, kFormatVersion, kByteOrderMark, kHeaderBytes, tree.transform.scale,
                           tree.transform.offset});
  out.float64s(kOrigin, tree.origin);
  out.integer(kN, static_cast<std::uint8_t>(tree.n));
  out.integer(kLevels, static_cast<std::uint8_t>(tree.levels));
  out.integer(kEncoding, static_cast<std::uint8_t>(tree.encoding));
  out.integer(kFlags, static_cast<std::uint8_t>((tree.defersToCoarse ? kDefersToCoarse : 0) |
                                                (tree.coarseAtInternalNodes ? kCoarseAtInternalNodes : 0)));
  for (int axis = 0; axis < 3; ++axis) out.integer(kGrids[axis], static_cast<std::uint16_t>(tree.grids[axis]));
  out.integer(kReserved, std::uint16_t{0});
  out.integer(kUsedGrids, tree.usedGrids);
  out.integer(kTwoSidedLeaves, tree.twoSidedLeaves);
  out.integer(kPayloadSize, static_cast<std::uint64_t>(payload.size()));
  out.raw(kChecksum, checksumOf(payload));
  return out.bytes();
}

Result<Header> parseHeader(std::string_view bytes, std::uint64_t fileSize) {
  HeaderReader in(bytes, fileSize);
  Header h;
  APO_RETURN_IF_ERROR(readLeadingHeader(in, kMagicBytes, ".n3t", h));
  APO_RETURN_IF_ERROR(in.float64s(kOrigin, h.origin));
  APO_RETURN_IF_ERROR(in.integer(kN, h.n));
  APO_RETURN_IF_ERROR(in.integer(kLevels, h.levels));
  APO_RETURN_IF_ERROR(in.integer(kEncoding, h.encoding));
  APO_RETURN_IF_ERROR(in.integer(kFlags, h.flags));
  for (int axis = 0; axis < 3; ++axis) APO_RETURN_IF_ERROR(in.integer(kGrids[axis], h.grids[axis]));
  APO_RETURN_IF_ERROR(in.integer(kReserved, h.reserved));
  APO_RETURN_IF_ERROR(in.integer(kUsedGrids, h.usedGrids));
  APO_RETURN_IF_ERROR(in.integer(kTwoSidedLeaves, h.twoSidedLeaves));
  APO_RETURN_IF_ERROR(in.integer(kPayloadSize, h.payloadSize));
  APO_RETURN_IF_ERROR(in.raw(kChecksum, h.checksum));
  return h;
}

Status checkHeader(const Header& h, std::uint64_t fileSize) {
  if (h.version != kFormatVersion)
    return fieldError(kVersion, "expected {} (the version this reader knows), found {}", kFormatVersion, h.version);
  APO_RETURN_IF_ERROR(checkByteOrder(kByteOrder, h.byteOrderMark));
  if (h.headerSize != kHeaderBytes) return fieldError(kHeaderSize, "expected {}, found {}", kHeaderBytes, h.headerSize);
  APO_RETURN_IF_ERROR(checkTransform(h));
  APO_RETURN_IF_ERROR(checkFinite(kOrigin, h.origin));
  if (h.n != 2 && h.n != 4) return fieldError(kN, "expected 2 or 4, found {}", int{h.n});
  const int log2n = h.n == 2 ? 1 : 2;
  if (h.levels < 1 || h.levels * log2n > texel::kMaxDepth)
    return fieldError(kLevels, "expected 1 to {} for N = {}, found {}", texel::kMaxDepth / log2n, int{h.n}, int{h.levels});
  if (h.encoding > static_cast<std::uint8_t>(NormalEncoding::Oct24))
    return fieldError(kEncoding, "expected 0 (xyz8) or 1 (oct24), found {}", int{h.encoding});
  if (h.flags > (kDefersToCoarse | kCoarseAtInternalNodes)) return fieldError(kFlags, "expected 0 to 3, found {}", int{h.flags});
  for (int axis = 0; axis < 3; ++axis)
    if (h.grids[axis] < 1 || h.grids[axis] > 256) return fieldError(kGrids[axis], "expected 1 to 256, found {}", h.grids[axis]);
  if (h.reserved != 0) return fieldError(kReserved, "expected 0, found {}", h.reserved);
  const std::uint64_t capacity = std::uint64_t{h.grids[0]} * h.grids[1] * h.grids[2];
  if (h.usedGrids < 1 || h.usedGrids > capacity)
    return fieldError(kUsedGrids, "expected 1 to the pool's {} grids, found {}", capacity, h.usedGrids);
  const PayloadSizes sizes = payloadSizes(h.n, h.grids, h.twoSidedLeaves);
  if (h.payloadSize != sizes.total())
    return fieldError(kPayloadSize, "expected pool {} + LOD pool {} + sides {} = {} bytes, found {}", sizes.pool, sizes.lod,
                      sizes.sides, sizes.total(), h.payloadSize);
  if (fileSize < kHeaderBytes || h.payloadSize != fileSize - kHeaderBytes)
    return fieldError(kPayloadSize, "the header claims {} bytes after it, but the file has {} (truncated or padded file)",
                      h.payloadSize, fileSize < kHeaderBytes ? 0 : fileSize - kHeaderBytes);
  return okStatus();
}

N3Tree treeOf(const Header& h, const std::vector<std::uint8_t>& payload) {
  const PayloadSizes sizes = payloadSizes(h.n, h.grids, h.twoSidedLeaves);
  N3Tree tree;
  tree.transform.scale = h.scale;
  tree.transform.offset = h.offset;
  tree.origin = h.origin;
  tree.n = h.n;
  tree.levels = h.levels;
  tree.encoding = static_cast<NormalEncoding>(h.encoding);
  tree.defersToCoarse = (h.flags & kDefersToCoarse) != 0;
  tree.coarseAtInternalNodes = (h.flags & kCoarseAtInternalNodes) != 0;
  tree.grids = {h.grids[0], h.grids[1], h.grids[2]};
  tree.usedGrids = h.usedGrids;
  tree.twoSidedLeaves = h.twoSidedLeaves;
  const auto from = [&](std::uint64_t begin, std::uint64_t size) {
    return std::vector<std::uint8_t>(payload.begin() + static_cast<std::ptrdiff_t>(begin),
                                     payload.begin() + static_cast<std::ptrdiff_t>(begin + size));
  };
  tree.pool = from(0, sizes.pool);
  tree.lod = from(sizes.pool, sizes.lod);
  tree.sides = from(sizes.pool + sizes.lod, sizes.sides);
  return tree;
}

Result<N3Tree> readTree(std::istream& in, std::uint64_t fileSize) {
  std::string head(std::min<std::uint64_t>(fileSize, kHeaderBytes), '\0');
  in.read(head.data(), static_cast<std::streamsize>(head.size()));
  if (static_cast<std::size_t>(in.gcount()) != head.size()) return badInput("read {} of the first {} bytes", in.gcount(), head.size());
  const Result<Header> header = parseHeader(head, fileSize);
  if (!header.ok()) return header.error();
  APO_RETURN_IF_ERROR(checkHeader(*header, fileSize));
  std::vector<std::uint8_t> payload(header->payloadSize);
  in.read(reinterpret_cast<char*>(payload.data()), static_cast<std::streamsize>(payload.size()));
  if (static_cast<std::uint64_t>(in.gcount()) != payload.size())
    return badInput("byte {}: read {} of the {} bytes of the payload (the file changed while read?)", kHeaderBytes,
                    in.gcount(), payload.size());
  const std::array<std::uint8_t, 32> checksum = checksumOf(payload);
  if (checksum != header->checksum)
    return fieldError(kChecksum, "the payload hashes to {}, the header says {} (corrupt payload)", hexBytes(checksum.data(), 32, ""),
                      hexBytes(header->checksum.data(), 32, ""));
  N3Tree tree = treeOf(*header, payload);
  if (Status valid = validateN3Tree(tree); !valid.ok()) return badInput("payload: {}", valid.error().message);
  return tree;
}

}  // namespace

Status writeN3TreeFile(const fs::path& path, const N3Tree& tree) {
  if (Status valid = validateN3Tree(tree); !valid.ok())
    return internalError("{}: refusing to write an inconsistent N^3-tree: {}", path.string(), valid.error().message);
  const std::vector<std::uint8_t> payload = payloadOf(tree);
  const std::string head = headerBytes(tree, payload);
  return writeFileAtomically(path, [&](std::ostream& out) {
    out.write(head.data(), static_cast<std::streamsize>(head.size()));
    out.write(reinterpret_cast<const char*>(payload.data()), static_cast<std::streamsize>(payload.size()));
    return okStatus();
  });
}

Result<N3Tree> readN3TreeFile(const fs::path& path) {
  return readBinaryFile<N3Tree>(path, [](std::istream& in, std::uint64_t fileSize) { return readTree(in, fileSize); });
}

Result<N3Tree> parseN3TreeFile(std::string_view bytes) {
  std::istringstream in{std::string(bytes)};
  return readTree(in, bytes.size());
}

}  // namespace apo
