#include "format/format.h"
#include "core/file_io.h"
#include "tests/format/apo_test_trees.h"
#include "tests/test_support.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstring>
#include <limits>
#include <random>

#define STB_IMAGE_STATIC
#define STB_IMAGE_IMPLEMENTATION
#include <stb/stb_image.h>

namespace apo {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

// The header of docs/apo-format.md, offsets copied from its table.
constexpr std::size_t kMagicAt = 0, kVersionAt = 8, kByteOrderAt = 12, kHeaderSizeAt = 16, kScaleAt = 20,
                      kOffsetXAt = 28, kOffsetYAt = 36, kOffsetZAt = 44, kCoarseDepthAt = 52, kMaxDepthAt = 53,
                      kCompleteDepthAt = 54, kEncodingAt = 55, kWidthAt = 56, kHeightAt = 60, kLeafNodesAt = 64,
                      kInternalNodesAt = 72, kUsedTexelsAt = 80, kPayloadSizeAt = 88, kChecksumAt = 96,
                      kPayloadAt = 128;

ApoTexture sampleTexture(int completeDepth = 2) {
  Octree octree = test::randomOctree(21, 2, 6, 0.5);
  octree.transform.scale = 0.37;
  octree.transform.offset = {0.25, -1.5, 1e-3};
  Result<ApoTexture> texture = encodeApo(octree, completeDepth, NormalEncoding::Oct24, 3, 9);
  EXPECT_TRUE(texture.ok()) << texture.error().message;
  return *texture;
}

// A small file: the tiny tree of encoding_test.cpp's shape, 48 payload bytes.
ApoTexture tinyTexture() {
  const Octree octree = test::octreeFromPaths({{0}, {3, 1}, {3, 6}, {7}}, [](const test::ChildPath& path) {
    return Vec3f(1.0f, static_cast<float>(path.size()), path.empty() ? 0.0f : static_cast<float>(path.back()))
        .normalized();
  });
  Result<ApoTexture> texture = encodeApo(octree, 0, NormalEncoding::Xyz8, 1, 2);
  EXPECT_TRUE(texture.ok()) << texture.error().message;
  return *texture;
}

std::string fileBytes(const fs::path& path) {
  Result<std::string> bytes = readFileBytes(path);
  EXPECT_TRUE(bytes.ok()) << bytes.error().message;
  return bytes.ok() ? *bytes : std::string();
}

// The bytes writeApoFile writes, in a fresh folder (earlier files of the test
// are gone).
std::string writtenBytes(const ApoTexture& texture) {
  const fs::path path = test::freshTempDir() / "t.apo";
  const Status written = writeApoFile(path, texture);
  EXPECT_TRUE(written.ok()) << written.error().message;
  return fileBytes(path);
}

template <class T>
T fieldAt(const std::string& bytes, std::size_t offset) {
  T value;
  std::memcpy(&value, bytes.data() + offset, sizeof(T));  // the test machine is little-endian
  return value;
}

template <class T>
void patch(std::string& bytes, std::size_t offset, T value) {
  std::memcpy(bytes.data() + offset, &value, sizeof(T));
}

void recomputeChecksum(std::string& bytes) {
  const std::string hex = sha256OfBytes(std::string_view(bytes).substr(kPayloadAt));
  for (std::size_t i = 0; i < 32; ++i)
    bytes[kChecksumAt + i] = static_cast<char>(std::stoul(hex.substr(2 * i, 2), nullptr, 16));
}

// Reads `bytes` as an .apo file (in a fresh folder: earlier files of the
// test are gone); expects BadInput naming the path and `what`.
void expectRejected(const std::string& bytes, const std::string& what) {
  const fs::path path = test::freshTempDir() / "bad.apo";
  test::writeBytes(path, bytes);
  const Result<ApoTexture> read = readApoFile(path);
  ASSERT_FALSE(read.ok()) << "accepted; expected: " << what;
  EXPECT_EQ(read.error().kind, ErrorKind::BadInput);
  EXPECT_THAT(read.error().message, HasSubstr(path.string()));
  EXPECT_THAT(read.error().message, HasSubstr(what));
}

void expectSameTexture(const ApoTexture& a, const ApoTexture& b) {
  EXPECT_EQ(a.transform.scale, b.transform.scale);
  EXPECT_EQ(a.transform.offset, b.transform.offset);
  EXPECT_EQ(a.coarseDepth, b.coarseDepth);
  EXPECT_EQ(a.maxDepth, b.maxDepth);
  EXPECT_EQ(a.completeDepth, b.completeDepth);
  EXPECT_EQ(a.encoding, b.encoding);
  EXPECT_EQ(a.width, b.width);
  EXPECT_EQ(a.height, b.height);
  EXPECT_EQ(a.leafNodes, b.leafNodes);
  EXPECT_EQ(a.internalNodes, b.internalNodes);
  EXPECT_EQ(a.twoSidedLeaves, b.twoSidedLeaves);
  EXPECT_TRUE(a.texels == b.texels);
}

TEST(ApoFile, RoundTripGivesTheSameTexture) {
  for (int completeDepth = 0; completeDepth <= 2; ++completeDepth) {
    const ApoTexture texture = sampleTexture(completeDepth);
    const fs::path path = test::freshTempDir() / "sub" / "model.apo";
    ASSERT_TRUE(writeApoFile(path, texture).ok());
    const Result<ApoTexture> read = readApoFile(path);
    ASSERT_TRUE(read.ok()) << read.error().message;
    expectSameTexture(texture, *read);
    // Deterministic bytes (read before writtenBytes empties the test's folder).
    const std::string first = fileBytes(path);
    EXPECT_TRUE(first == writtenBytes(texture));
  }
}

TEST(ApoFile, HeaderFieldsAreAtTheDocumentedOffsets) {
  const ApoTexture texture = sampleTexture();
  const std::string bytes = writtenBytes(texture);
  ASSERT_EQ(bytes.size(), kPayloadAt + texture.texels.size());
  EXPECT_EQ(bytes.substr(kMagicAt, 8), std::string("\x89" "APO\r\n\x1A\n", 8));
  EXPECT_EQ(fieldAt<std::uint32_t>(bytes, kVersionAt), 1u);
  EXPECT_EQ(bytes.substr(kByteOrderAt, 4), std::string("\x04\x03\x02\x01", 4));
  EXPECT_EQ(fieldAt<std::uint32_t>(bytes, kHeaderSizeAt), 128u);
  EXPECT_EQ(fieldAt<double>(bytes, kScaleAt), 0.37);
  EXPECT_EQ(fieldAt<double>(bytes, kOffsetXAt), 0.25);
  EXPECT_EQ(fieldAt<double>(bytes, kOffsetYAt), -1.5);
  EXPECT_EQ(fieldAt<double>(bytes, kOffsetZAt), 1e-3);
  EXPECT_EQ(fieldAt<std::uint8_t>(bytes, kCoarseDepthAt), 3);
  EXPECT_EQ(fieldAt<std::uint8_t>(bytes, kMaxDepthAt), 9);
  EXPECT_EQ(fieldAt<std::uint8_t>(bytes, kCompleteDepthAt), 2);
  EXPECT_EQ(fieldAt<std::uint8_t>(bytes, kEncodingAt), 1);  // oct24
  EXPECT_EQ(fieldAt<std::uint32_t>(bytes, kWidthAt), texture.width);
  EXPECT_EQ(fieldAt<std::uint32_t>(bytes, kHeightAt), texture.height);
  EXPECT_EQ(fieldAt<std::uint64_t>(bytes, kLeafNodesAt), texture.leafNodes);
  EXPECT_EQ(fieldAt<std::uint64_t>(bytes, kInternalNodesAt), texture.internalNodes);
  EXPECT_EQ(fieldAt<std::uint64_t>(bytes, kUsedTexelsAt), texture.usedTexels());
  EXPECT_EQ(fieldAt<std::uint64_t>(bytes, kPayloadSizeAt), texture.texels.size());
  std::string hex;
  for (std::size_t i = 0; i < 32; ++i) hex += fmt::format("{:02x}", static_cast<std::uint8_t>(bytes[kChecksumAt + i]));
  EXPECT_EQ(hex, sha256OfBytes(std::string_view(bytes).substr(kPayloadAt)));
  EXPECT_TRUE(std::equal(texture.texels.begin(), texture.texels.end(), bytes.begin() + kPayloadAt,
                         [](std::uint8_t a, char b) { return a == static_cast<std::uint8_t>(b); }));
}

TEST(ApoFile, EveryTruncationIsBadInputNamingTheField) {
  const std::string bytes = writtenBytes(tinyTexture());
  ASSERT_EQ(bytes.size(), 128u + 48u);
  // The field the file ends in, from the table of docs/apo-format.md.
  struct Field {
    std::size_t end;
    const char* name;
  };
  const Field fields[] = {{8, "(magic)"},        {12, "(format version)"},  {16, "(byte-order mark)"},
                          {20, "(header size)"}, {28, "(scale)"},           {36, "(offset x)"},
                          {44, "(offset y)"},    {52, "(offset z)"},        {53, "(coarse depth)"},
                          {54, "(max depth)"},   {55, "(complete depth)"},  {56, "(normal encoding)"},
                          {60, "(width)"},       {64, "(height)"},          {72, "(leaf nodes)"},
                          {80, "(internal nodes)"}, {88, "(used texels)"}, {96, "(payload size)"},
                          {128, "(payload SHA-256)"}};
  for (std::size_t length = 0; length < bytes.size(); ++length) {
    std::string name = "(payload size)";  // a whole header: the payload is short
    for (const Field& field : fields) {
      if (length < field.end) {
        name = field.name;
        break;
      }
    }
    SCOPED_TRACE(length);
    expectRejected(bytes.substr(0, length), name);
  }
}

TEST(ApoFile, FlippedPayloadByteFailsTheChecksum) {
  std::string bytes = writtenBytes(tinyTexture());
  bytes[kPayloadAt + 17] ^= 0x04;
  expectRejected(bytes, "byte 96 (payload SHA-256): the texels hash to");
}

TEST(ApoFile, BadIdentityFields) {
  const std::string good = writtenBytes(tinyTexture());
  std::string magic = good;
  magic[1] = 'X';
  expectRejected(magic, "byte 0 (magic): expected 89 41 50 4f 0d 0a 1a 0a, found 89 58");
  // A text-mode transfer turning CR LF into LF shifts everything.
  std::string mangled = good;
  mangled.erase(4, 1);
  expectRejected(mangled, "(magic)");
  std::string version = good;
  patch<std::uint32_t>(version, kVersionAt, 5);
  expectRejected(version, "byte 8 (format version): expected 1 to 4 (the versions this reader knows), found 5");
  std::string claimsTwo = good;
  patch<std::uint32_t>(claimsTwo, kVersionAt, 2);
  expectRejected(claimsTwo, "byte 16 (header size): expected 160 for format version 2, found 128");
  std::string byteOrder = good;
  patch<std::uint32_t>(byteOrder, kByteOrderAt, 0x04030201);
  expectRejected(byteOrder, "byte 12 (byte-order mark)");
  std::string headerSize = good;
  patch<std::uint32_t>(headerSize, kHeaderSizeAt, 136);
  expectRejected(headerSize, "byte 16 (header size): expected 128 for format version 1, found 136");
}

// Version 3 (leaves showing m's normal): version 2's header, written only
// when some leaf shows m, whatever the origin; read back as such.
TEST(ApoFile, LeavesShowingMMakeAVersion3File) {
  Octree octree = test::octreeFromPaths({{0}, {3, 1}, {3, 6}, {7}}, [](const test::ChildPath& path) {
    return Vec3f(1.0f, static_cast<float>(path.size()), 0.0f).normalized();
  });
  octree.nodes.back().coarseNormal = true;  // a leaf: the last brood's last child
  ASSERT_TRUE(octree.nodes.back().isLeaf());
  Result<ApoTexture> texture = encodeApo(octree, 0, NormalEncoding::Xyz8, 1, 2);
  ASSERT_TRUE(texture.ok()) << texture.error().message;
  const std::string bytes = writtenBytes(*texture);
  EXPECT_EQ(fieldAt<std::uint32_t>(bytes, kVersionAt), 3u);
  EXPECT_EQ(fieldAt<std::uint32_t>(bytes, kHeaderSizeAt), 160u);
  EXPECT_EQ(fieldAt<double>(bytes, 128), 0.0);
  EXPECT_EQ(bytes.size(), 160u + texture->texels.size());
  const Result<ApoTexture> read = parseApoFile(bytes);
  ASSERT_TRUE(read.ok()) << read.error().message;
  EXPECT_TRUE(read->defersToCoarse);
  EXPECT_FALSE(parseApoFile(writtenBytes(tinyTexture()))->defersToCoarse);
}

TEST(ApoFile, TwoSidedLeavesMakeAVersion4FileCountingThemAtByte152) {
  Octree octree = test::octreeFromPaths({{0}, {3, 1}, {3, 6}, {7}}, [](const test::ChildPath& path) {
    return Vec3f(1.0f, static_cast<float>(path.size()), 0.0f).normalized();
  });
  OctreeNode& leaf = octree.nodes.back();  // {3, 6}, at depth 2
  ASSERT_TRUE(leaf.isLeaf());
  leaf.twoSided = true;
  leaf.sideAxis = 1;
  leaf.sides = {Vec3f::UnitY(), -Vec3f::UnitY()};
  Result<ApoTexture> texture = encodeApo(octree, 0, NormalEncoding::Xyz8, 1, 2);
  ASSERT_TRUE(texture.ok()) << texture.error().message;
  const std::string bytes = writtenBytes(*texture);
  EXPECT_EQ(fieldAt<std::uint32_t>(bytes, kVersionAt), 4u);
  EXPECT_EQ(fieldAt<std::uint32_t>(bytes, kHeaderSizeAt), 160u);
  EXPECT_EQ(fieldAt<std::uint64_t>(bytes, 152), 1u);
  // grid 1 + leaves 4 + two-sided 1 + 2 x internal 2.
  EXPECT_EQ(fieldAt<std::uint64_t>(bytes, kUsedTexelsAt), 10u);
  const Result<ApoTexture> read = parseApoFile(bytes);
  ASSERT_TRUE(read.ok()) << read.error().message;
  expectSameTexture(*texture, *read);
  EXPECT_TRUE(read->needsCoarseNormals());
  EXPECT_TRUE(read->coarseAtInternalNodes) << "version 4: internal nodes may show m";
  // The count is absent before version 4.
  std::string older = bytes;
  older[kVersionAt] = 3;
  EXPECT_THAT(parseApoFile(older).error().message,
              HasSubstr("byte 152 (two-sided leaves): expected 0 in format version 3"));
}

// Version 2 (a scan in a local frame): the version-1 header, then the
// origin at 128, 136 and 144 and 8 reserved zero bytes; the payload at 160.
TEST(ApoFile, AnOriginMakesAVersion2FileThatReadsBack) {
  ApoTexture texture = tinyTexture();
  texture.origin = {512000.0, 5403000.5, -300.25};
  const std::string bytes = writtenBytes(texture);
  ASSERT_EQ(bytes.size(), 160u + 48u);
  EXPECT_EQ(fieldAt<std::uint32_t>(bytes, kVersionAt), 2u);
  EXPECT_EQ(fieldAt<std::uint32_t>(bytes, kHeaderSizeAt), 160u);
  EXPECT_EQ(fieldAt<double>(bytes, 128), 512000.0);
  EXPECT_EQ(fieldAt<double>(bytes, 136), 5403000.5);
  EXPECT_EQ(fieldAt<double>(bytes, 144), -300.25);
  EXPECT_EQ(fieldAt<std::uint64_t>(bytes, 152), 0u);
  // The payload and its checksum are version 1's.
  const std::string v1 = writtenBytes(tinyTexture());
  EXPECT_EQ(bytes.substr(160), v1.substr(kPayloadAt));
  EXPECT_EQ(bytes.substr(kChecksumAt, 32), v1.substr(kChecksumAt, 32));
  const Result<ApoTexture> read = parseApoFile(bytes);
  ASSERT_TRUE(read.ok()) << read.error().message;
  expectSameTexture(texture, *read);
  EXPECT_EQ(read->origin, texture.origin);
  EXPECT_EQ(parseApoFile(v1)->origin, (std::array<double, 3>{0.0, 0.0, 0.0}));

  std::string nan = bytes;
  patch(nan, 136, std::numeric_limits<double>::quiet_NaN());
  expectRejected(nan, "byte 136 (origin y): expected a finite number, found nan");
  std::string reserved = bytes;
  reserved[155] = 1;
  expectRejected(reserved, "byte 152 (two-sided leaves): expected 0 in format version 2");
  expectRejected(bytes.substr(0, 150), "byte 144 (origin z): the file ends after 150 bytes");
  EXPECT_EQ(describeApoFileByte(bytes, 140), "the header's origin y (bytes 136 to 143)");
  EXPECT_EQ(describeApoFileByte(bytes, 160), "texel 0, channel R (a grid entry: the grid has 1 texels)");
}

TEST(ApoFile, BadTransformAndSettings) {
  const std::string good = writtenBytes(tinyTexture());
  for (double scale : {0.0, -1.0, std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity()}) {
    std::string bytes = good;
    patch(bytes, kScaleAt, scale);
    expectRejected(bytes, "byte 20 (scale): expected a finite positive number");
  }
  std::string offset = good;
  patch(offset, kOffsetYAt, -std::numeric_limits<double>::infinity());
  expectRejected(offset, "byte 36 (offset y): expected a finite number, found -inf");
  std::string maxDepth = good;
  patch<std::uint8_t>(maxDepth, kMaxDepthAt, 21);
  expectRejected(maxDepth, "byte 53 (max depth): expected at most 20, found 21");
  std::string coarse = good;
  patch<std::uint8_t>(coarse, kCoarseDepthAt, 3);  // max depth is 2
  expectRejected(coarse, "byte 52 (coarse depth): expected at most the max depth 2, found 3");
  std::string complete = good;
  patch<std::uint8_t>(complete, kCompleteDepthAt, 2);  // coarse depth is 1
  expectRejected(complete, "byte 54 (complete depth): expected at most min(10, coarse depth 1) = 1, found 2");
  std::string encoding = good;
  patch<std::uint8_t>(encoding, kEncodingAt, 2);
  expectRejected(encoding, "byte 55 (normal encoding): expected 0 (xyz8) or 1 (oct24), found 2");
}

TEST(ApoFile, BadSizes) {
  const std::string good = writtenBytes(tinyTexture());  // 4 x 3 texels, 9 used
  for (std::uint32_t width : {0u, 3u, 6u, 32768u}) {
    std::string bytes = good;
    patch(bytes, kWidthAt, width);
    expectRejected(bytes, fmt::format("byte 56 (width): expected a power of two at most 16384, found {}", width));
  }
  std::string height = good;
  patch<std::uint32_t>(height, kHeightAt, 4);
  expectRejected(height, "byte 88 (payload size): expected width x height x 4 = 4 x 4 x 4 = 64, found 48");
  std::string rows = good;  // consistent with the payload, not with the used texels
  patch<std::uint32_t>(rows, kWidthAt, 2);
  patch<std::uint32_t>(rows, kHeightAt, 6);
  expectRejected(rows, "byte 60 (height): expected 5 rows for 9 used texels at width 2, found 6");
  std::string used = good;
  patch<std::uint64_t>(used, kUsedTexelsAt, 10);
  expectRejected(used, "byte 80 (used texels): expected grid + leaves + two-sided leaves + 2 x internal nodes = 1 + 4 + 0 + 2 x 2, found 10");
  std::string padded = good + std::string(4, '\0');
  expectRejected(padded, "byte 88 (payload size): the header claims 48 bytes of texels, but the file has 52");
}

TEST(ApoFile, AbsurdClaimedSizesAreRejectedBeforeAnyAllocation) {
  const std::string good = writtenBytes(tinyTexture());
  // A consistent header claiming 16384 x 4e9 texels (256 TiB).
  std::string huge = good;
  patch<std::uint32_t>(huge, kWidthAt, 16384);
  patch<std::uint32_t>(huge, kHeightAt, 0xFFFFFFFF);
  patch<std::uint64_t>(huge, kPayloadSizeAt, std::uint64_t{16384} * 0xFFFFFFFF * 4);
  expectRejected(huge, "byte 88 (payload size): the header claims 281474976645120 bytes of texels, but the file "
                       "has 48");
  std::string payload = good;
  patch<std::uint64_t>(payload, kPayloadSizeAt, std::numeric_limits<std::uint64_t>::max());
  expectRejected(payload, "byte 88 (payload size)");
  std::string nodes = good;
  patch<std::uint64_t>(nodes, kLeafNodesAt, std::numeric_limits<std::uint64_t>::max() - 1);
  expectRejected(nodes, "byte 80 (used texels)");
}

TEST(ApoFile, StructureIsValidatedBehindAValidChecksum) {
  const std::string good = writtenBytes(tinyTexture());
  // Texel 4 is child 3's first texel (encoding_test.cpp); its offset 3 -> 5.
  std::string offset = good;
  offset[kPayloadAt + 4 * 4] = 5;
  recomputeChecksum(offset);
  expectRejected(offset, "payload: texel 4: the offset 5 to the children points to texel 9, expected 7");
  // The header's split of the used texels into leaves and internal nodes.
  std::string counts = good;
  patch<std::uint64_t>(counts, kLeafNodesAt, 2);
  patch<std::uint64_t>(counts, kInternalNodesAt, 3);
  expectRejected(counts, "payload: the nodes end at texel 9 with 4 leaves (0 two-sided) and 2 internal nodes");
}

TEST(ApoFile, RandomCorruptionIsBadInputOrAValidTexture) {
  // Byte changes anywhere, half of them behind a recomputed checksum: the
  // reader rejects the file or returns a texture decodeApo accepts.
  const std::string good = writtenBytes(sampleTexture(1));
  const fs::path path = test::freshTempDir() / "fuzz.apo";
  std::mt19937_64 random(5);
  std::uniform_int_distribution<std::size_t> byteDist(0, good.size() - 1);
  std::uniform_int_distribution<int> valueDist(0, 255);
  for (int trial = 0; trial < 400; ++trial) {
    std::string bytes = good;
    for (int changes = 1 + trial % 3; changes > 0; --changes)
      bytes[byteDist(random)] = static_cast<char>(valueDist(random));
    if (trial % 2) recomputeChecksum(bytes);
    test::writeBytes(path, bytes);
    const Result<ApoTexture> read = readApoFile(path);
    if (read.ok())
      EXPECT_TRUE(decodeApo(*read).ok());
    else
      EXPECT_EQ(read.error().kind, ErrorKind::BadInput);
  }
}

TEST(ApoFile, TheBytesInMemoryReadAsTheFileDoes) {
  const ApoTexture texture = sampleTexture(1);
  const std::string bytes = writtenBytes(texture);
  auto parsed = parseApoFile(bytes);
  ASSERT_TRUE(parsed.ok()) << parsed.error().message;
  EXPECT_EQ(parsed->texels, texture.texels);
  EXPECT_FALSE(parseApoFile(bytes.substr(0, 100)).ok());
}

TEST(ApoFile, EveryByteIsDescribedByItsField) {
  const ApoTexture texture = sampleTexture(1);
  const std::string bytes = writtenBytes(texture);
  EXPECT_EQ(describeApoFileByte(bytes, 0), "the header's magic (bytes 0 to 7)");
  EXPECT_EQ(describeApoFileByte(bytes, 57), "the header's width (bytes 56 to 59)");
  EXPECT_EQ(describeApoFileByte(bytes, 127), "the header's payload SHA-256 (bytes 96 to 127)");
  const std::uint64_t grid = texture.gridTexels();
  EXPECT_THAT(describeApoFileByte(bytes, 128 + 1), HasSubstr("texel 0, channel G (a grid entry"));
  EXPECT_THAT(describeApoFileByte(bytes, 128 + 4 * grid + 3), HasSubstr(fmt::format("texel {}, channel A (a node", grid)));
  if (texture.usedTexels() < std::uint64_t{texture.width} * texture.height) {
    EXPECT_THAT(describeApoFileByte(bytes, 128 + 4 * texture.usedTexels()), HasSubstr("(padding"));
  }
}

TEST(ApoFile, MissingFileIsBadInput) {
  const fs::path path = test::freshTempDir() / "none.apo";
  const Result<ApoTexture> read = readApoFile(path);
  ASSERT_FALSE(read.ok());
  EXPECT_EQ(read.error().kind, ErrorKind::BadInput);
  EXPECT_THAT(read.error().message, HasSubstr("no such file"));
}

TEST(ApoFile, WriterRefusesAnInconsistentTexture) {
  ApoTexture texture = tinyTexture();
  texture.width = 3;
  const fs::path path = test::freshTempDir() / "bad.apo";
  const Status written = writeApoFile(path, texture);
  ASSERT_FALSE(written.ok());
  EXPECT_EQ(written.error().kind, ErrorKind::Internal);
  EXPECT_THAT(written.error().message, HasSubstr("(width)"));
  EXPECT_FALSE(fs::exists(path));
}

TEST(ApoPng, HoldsTheTexelsAndIsDeterministic) {
  const ApoTexture texture = sampleTexture();
  const fs::path dir = test::freshTempDir();
  ASSERT_TRUE(writeApoPng(dir / "a.png", texture).ok());
  ASSERT_TRUE(writeApoPng(dir / "b.png", texture).ok());
  const std::string png = fileBytes(dir / "a.png");
  EXPECT_EQ(png, fileBytes(dir / "b.png"));
  int width = 0, height = 0, channels = 0;
  stbi_uc* pixels = stbi_load_from_memory(reinterpret_cast<const stbi_uc*>(png.data()), static_cast<int>(png.size()),
                                          &width, &height, &channels, 4);
  ASSERT_NE(pixels, nullptr) << stbi_failure_reason();
  EXPECT_EQ(static_cast<std::uint32_t>(width), texture.width);
  EXPECT_EQ(static_cast<std::uint32_t>(height), texture.height);
  EXPECT_EQ(channels, 4);
  EXPECT_TRUE(std::equal(texture.texels.begin(), texture.texels.end(), pixels));
  stbi_image_free(pixels);
}

}  // namespace
}  // namespace apo
