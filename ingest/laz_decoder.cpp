// LAZ point data to raw LAS point records (laz_decoder.h has the layout).
// Every count and offset is checked against the file before it sizes
// anything; the records grow as points are actually decoded, so a count the
// data cannot back fails at the first chunk that runs dry instead of
// allocating what the header claims.
#include "ingest/laz_decoder.h"

#include "ingest/laz_arithmetic.h"
#include "ingest/laz_items.h"
#include "ingest/parse_util.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <utility>
#include <vector>

namespace apo::laz {
namespace {

using parse::fail;

constexpr std::size_t kVlrHeaderSize = 54;
constexpr std::size_t kLaszipVlrFixedSize = 34;  // the fields before the items
constexpr std::size_t kItemSize = 6;              // type, size, version: uint16 each
constexpr std::uint16_t kLaszipRecordId = 22204;
constexpr std::string_view kLaszipUserId = "laszip encoded";
constexpr std::uint32_t kVariableChunks = 0xFFFFFFFFU;

// No LASzip stream codes a point in less than about 1/1000 of a byte (all
// models at their most skewed, every field unchanged): a header claiming
// more points than this many per byte of point data is refused unread.
constexpr std::uint64_t kMostPointsPerByte = 4096;
// Points decoded between checks that the decoder has not run off its bytes.
constexpr std::uint64_t kPointsPerBatch = 4096;
// LASzip rarely compresses more than tenfold: the records' memory is taken in
// one go up to this many times the compressed bytes, and beyond it grows only
// as points are decoded (a claimed count is not trusted with memory).
constexpr std::uint64_t kReservedBytesPerCompressedByte = 32;

enum Compressor : std::uint16_t { kPointwise = 1, kPointwiseChunked = 2, kLayeredChunked = 3 };

// The LASzip VLR's record (laszip.cpp, LASzip::unpack), offsets from its start:
//   0 uint16 compressor   2 uint16 coder (0: arithmetic)
//   4 uint8 version major 5 uint8 minor  6 uint16 revision  8 uint32 options
//  12 uint32 chunk size (points; 0 or 0xFFFFFFFF: variable)
//  16 int64 special EVLRs 24 int64 their offset   32 uint16 items
//  34 items: uint16 type, uint16 size, uint16 version
struct LaszipVlr {
  std::size_t at = 0;  // file offset of the record
  std::uint16_t compressor = 0;
  int versionMajor = 0, versionMinor = 0, versionRevision = 0;
  std::uint32_t chunkSize = 0;
  std::vector<Item> items;
};

template <class T>
T read(std::string_view file, std::size_t at, std::string_view what) {
  return parse::BinaryCursor(file, at).read<T>(false, what);
}

// Where the LASzip VLR's record starts and how long it is.
std::pair<std::size_t, std::size_t> findLaszipVlr(std::string_view file, const PointRecords& las) {
  std::size_t at = las.vlrsAt;
  for (std::uint32_t i = 0; i < las.vlrCount && at + kVlrHeaderSize <= las.pointsAt; ++i) {
    const std::string_view userId = file.substr(at + 2, 16);
    const auto recordId = read<std::uint16_t>(file, at + 18, "VLR record id");
    const auto length = read<std::uint16_t>(file, at + 20, "VLR record length");
    if (userId.substr(0, userId.find('\0')) == kLaszipUserId && recordId == kLaszipRecordId)
      return {at + kVlrHeaderSize, length};
    at += kVlrHeaderSize + length;
  }
  fail("byte 104: the point format byte marks LASzip-compressed points (LAZ), but no LASzip VLR (user id '{}', "
       "record {}) is among the {} VLRs before the point data at byte {}",
       kLaszipUserId, kLaszipRecordId, las.vlrCount, las.pointsAt);
}

std::string_view compressorName(std::uint16_t compressor) {
  switch (compressor) {
    case kPointwise: return "pointwise";
    case kPointwiseChunked: return "chunked";
    case kLayeredChunked: return "LAS 1.4 layered chunks";
    default: return "unknown";
  }
}

// The item's decoder exists for this compressor (versions 1-2 of the point
// 0-5 items for compressors 1 and 2, version 3 of the point 6-10 items for 3).
void checkItemDecodable(const Item& item, std::uint16_t compressor, std::size_t at, std::size_t index) {
  const bool layeredType = item.type == ItemType::Point14 || item.type == ItemType::Rgb14 ||
                           item.type == ItemType::RgbNir14 || item.type == ItemType::Byte14 ||
                           item.type == ItemType::WavePacket14;
  const auto type = static_cast<std::uint16_t>(item.type);
  if (itemName(type) == "unknown")
    fail("byte {}: LASzip VLR item {}: type {} is unknown (LASzip defines 0 and 6 to 14)", at, index, type);
  if (item.type == ItemType::WavePacket13 || item.type == ItemType::WavePacket14)
    fail("byte {}: LASzip VLR item {}: {} (waveform packets) is not supported", at, index, itemName(type));
  if (layeredType != (compressor == kLayeredChunked))
    fail("byte {}: LASzip VLR item {}: {} cannot be coded by compressor {} ({})", at, index, itemName(type), compressor,
         compressorName(compressor));
  if (!decodable(item, layeredType))
    fail("byte {}: LASzip VLR item {}: {} version {} is not supported (versions {})", at + 4, index, itemName(type),
         item.version, layeredType ? "3" : "1 and 2");
}

// The size every item but the extra bytes must have.
std::uint16_t fixedItemSize(ItemType type) {
  switch (type) {
    case ItemType::Point10: return 20;
    case ItemType::GpsTime11: return 8;
    case ItemType::Rgb12: return 6;
    case ItemType::Point14: return 30;
    case ItemType::Rgb14: return 6;
    case ItemType::RgbNir14: return 8;
    default: return 0;
  }
}

LaszipVlr parseLaszipVlr(std::string_view file, const PointRecords& las) {
  const auto [at, length] = findLaszipVlr(file, las);
  if (length < kLaszipVlrFixedSize || at + length > las.pointsAt)
    fail("byte {}: the LASzip VLR's record of {} bytes is shorter than its {} fixed bytes or runs into the points",
         at - kVlrHeaderSize + 20, length, kLaszipVlrFixedSize);
  LaszipVlr vlr;
  vlr.at = at;
  vlr.compressor = read<std::uint16_t>(file, at, "LASzip compressor");
  if (vlr.compressor < kPointwise || vlr.compressor > kLayeredChunked)
    fail("byte {}: LASzip VLR: compressor {} is unknown (1 pointwise, 2 chunked, 3 LAS 1.4 layered chunks)", at,
         vlr.compressor);
  const auto coder = read<std::uint16_t>(file, at + 2, "LASzip coder");
  if (coder != 0) fail("byte {}: LASzip VLR: coder {} is unknown (0: arithmetic)", at + 2, coder);
  vlr.versionMajor = static_cast<std::uint8_t>(file[at + 4]);
  vlr.versionMinor = static_cast<std::uint8_t>(file[at + 5]);
  vlr.versionRevision = read<std::uint16_t>(file, at + 6, "LASzip revision");
  vlr.chunkSize = read<std::uint32_t>(file, at + 12, "LASzip chunk size");
  const auto itemCount = read<std::uint16_t>(file, at + 32, "LASzip item count");
  if (kLaszipVlrFixedSize + kItemSize * itemCount > length)
    fail("byte {}: LASzip VLR: {} items need {} bytes, the record has {}", at + 32, itemCount,
         kLaszipVlrFixedSize + kItemSize * itemCount, length);
  std::size_t recordBytes = 0;
  for (std::size_t i = 0; i < itemCount; ++i) {
    const std::size_t itemAt = at + kLaszipVlrFixedSize + kItemSize * i;
    const Item item{static_cast<ItemType>(read<std::uint16_t>(file, itemAt, "LASzip item type")),
                    read<std::uint16_t>(file, itemAt + 2, "LASzip item size"),
                    read<std::uint16_t>(file, itemAt + 4, "LASzip item version")};
    checkItemDecodable(item, vlr.compressor, itemAt, i);
    const std::uint16_t expected = fixedItemSize(item.type);
    if (expected != 0 && item.size != expected)
      fail("byte {}: LASzip VLR item {}: {} takes {} bytes, not {}", itemAt + 2, i,
           itemName(static_cast<std::uint16_t>(item.type)), expected, item.size);
    if (item.size == 0)
      fail("byte {}: LASzip VLR item {}: {} of 0 bytes", itemAt + 2, i,
           itemName(static_cast<std::uint16_t>(item.type)));
    recordBytes += item.size;
    vlr.items.push_back(item);
  }
  if (itemCount == 0 || (vlr.compressor == kLayeredChunked) != (vlr.items.front().type == ItemType::Point14) ||
      (vlr.compressor != kLayeredChunked && vlr.items.front().type != ItemType::Point10))
    fail("byte {}: LASzip VLR: the items must start with POINT10 (compressors 1 and 2) or POINT14 (compressor 3)",
         at + 32);
  if (recordBytes != las.recordLength)
    fail("byte {}: LASzip VLR: the items add up to {} bytes a point, the header's point record length is {}", at + 32,
         recordBytes, las.recordLength);
  return vlr;
}

// ---------------------------------------------------------------------------
// Chunks
// ---------------------------------------------------------------------------

// A chunk's place in the file and its point count.
struct Chunk {
  // The begin of a chunk read in sequence: where the one before it ended.
  static constexpr std::size_t kAfterThePrevious = 0;
  std::size_t begin = kAfterThePrevious;
  std::size_t end = 0;  // of its bytes, or of the file when not known
  std::uint64_t points = 0;
};

// The items of every point, with their byte offsets in a record.
class PointDecoder {
 public:
  PointDecoder(const LaszipVlr& vlr, std::uint16_t recordLength) : recordLength_(recordLength) {
    std::size_t offset = 0;
    for (const Item& item : vlr.items) {
      offsets_.push_back(offset);
      offset += item.size;
      if (vlr.compressor == kLayeredChunked) layered_.push_back(makeLayeredItemDecoder(item));
      else pointwise_.push_back(makePointwiseItemDecoder(item));
    }
  }

  // Appends `chunk.points` records decoded from the chunk to `records`;
  // returns the bytes the chunk took.
  std::size_t decodeChunk(std::string_view file, const Chunk& chunk, std::size_t index, std::string& records) {
    const auto* begin = reinterpret_cast<const std::uint8_t*>(file.data()) + chunk.begin;
    const auto* end = reinterpret_cast<const std::uint8_t*>(file.data()) + chunk.end;
    if (static_cast<std::size_t>(end - begin) < recordLength_)
      fail("byte {}: LAZ chunk {} is truncated: {} bytes, less than its first point's {}", chunk.begin, index,
           end - begin, recordLength_);
    const std::size_t firstAt = records.size();
    records.append(reinterpret_cast<const char*>(begin), recordLength_);
    try {
      return layered_.empty() ? decodePointwise(begin, end, chunk.points, records, firstAt)
                              : decodeLayered(begin, end, chunk, index, records, firstAt);
    } catch (const CorruptStream& corrupt) {
      fail("byte {}: LAZ chunk {} is truncated or corrupt: {}", chunk.begin, index, corrupt.what());
    }
  }

 private:
  static std::uint8_t* recordAt(std::string& records, std::size_t at) {
    return reinterpret_cast<std::uint8_t*>(records.data()) + at;
  }

  // Grows `records` by the next batch of up to kPointsPerBatch points.
  static std::uint64_t growBatch(std::string& records, std::uint64_t remaining, std::uint16_t recordLength) {
    const std::uint64_t batch = std::min(remaining, kPointsPerBatch);
    records.resize(records.size() + batch * recordLength);
    return batch;
  }

  std::size_t decodePointwise(const std::uint8_t* begin, const std::uint8_t* end, std::uint64_t points,
                              std::string& records, std::size_t firstAt) {
    for (std::size_t i = 0; i < pointwise_.size(); ++i)
      pointwise_[i]->startChunk(recordAt(records, firstAt) + offsets_[i]);
    decoder_.start(begin + recordLength_, end);
    for (std::uint64_t remaining = points - 1; remaining > 0 && !decoder_.overran();) {
      const std::uint64_t batch = growBatch(records, remaining, recordLength_);
      std::uint8_t* out = recordAt(records, records.size() - batch * recordLength_);
      for (std::uint64_t p = 0; p < batch; ++p, out += recordLength_)
        for (std::size_t i = 0; i < pointwise_.size(); ++i) pointwise_[i]->decode(decoder_, out + offsets_[i]);
      remaining -= batch;
    }
    if (decoder_.overran()) throw CorruptStream("its compressed data ends before its last point");
    return static_cast<std::size_t>(decoder_.position() - begin);
  }

  std::size_t decodeLayered(const std::uint8_t* begin, const std::uint8_t* end, const Chunk& chunk,
                            std::size_t index, std::string& records, std::size_t firstAt) {
    // The point count and every layer's byte count after the first point.
    std::size_t layerCount = 0;
    for (const auto& item : layered_) layerCount += item->layerCount();
    const std::size_t headerBytes = recordLength_ + 4 + 4 * layerCount;
    if (static_cast<std::size_t>(end - begin) < headerBytes)
      fail("byte {}: LAZ chunk {} is truncated: {} bytes, less than its first point and {} layer sizes", chunk.begin,
           index, end - begin, layerCount);
    std::vector<std::uint32_t> layerBytes(layerCount);
    std::memcpy(layerBytes.data(), begin + recordLength_ + 4, 4 * layerCount);
    std::uint64_t total = headerBytes;
    for (const std::uint32_t bytes : layerBytes) total += bytes;
    if (total > static_cast<std::uint64_t>(end - begin))
      fail("byte {}: LAZ chunk {} is truncated: its layers end at byte {}, its bytes at {}", chunk.begin, index,
           chunk.begin + total, chunk.end);
    // Each item's layers, in order; the first point starts them all.
    std::vector<std::span<const std::uint8_t>> layers;
    const std::uint8_t* at = begin + headerBytes;
    for (const std::uint32_t bytes : layerBytes) {
      layers.emplace_back(at, bytes);
      at += bytes;
    }
    unsigned channel = 0;
    std::span<const std::span<const std::uint8_t>> itemLayers(layers);
    for (std::size_t i = 0; i < layered_.size(); ++i) {
      layered_[i]->startChunk(recordAt(records, firstAt) + offsets_[i], itemLayers.first(layered_[i]->layerCount()),
                              channel);
      itemLayers = itemLayers.subspan(layered_[i]->layerCount());
    }
    for (std::uint64_t remaining = chunk.points - 1; remaining > 0 && !anyLayerOverran();) {
      const std::uint64_t batch = growBatch(records, remaining, recordLength_);
      std::uint8_t* out = recordAt(records, records.size() - batch * recordLength_);
      for (std::uint64_t p = 0; p < batch; ++p, out += recordLength_)
        for (std::size_t i = 0; i < layered_.size(); ++i) layered_[i]->decode(out + offsets_[i], channel);
      remaining -= batch;
    }
    if (anyLayerOverran()) throw CorruptStream("a layer's compressed data ends before its last point");
    return static_cast<std::size_t>(total);
  }

  bool anyLayerOverran() const {
    return std::any_of(layered_.begin(), layered_.end(), [](const auto& item) { return item->overran(); });
  }

  std::uint16_t recordLength_;
  std::vector<std::size_t> offsets_;
  std::vector<std::unique_ptr<PointwiseItemDecoder>> pointwise_;
  std::vector<std::unique_ptr<LayeredItemDecoder>> layered_;
  ArithmeticDecoder decoder_;
};

// ---------------------------------------------------------------------------
// The chunk table (lasreadpoint.cpp, LASreadPoint::read_chunk_table)
// ---------------------------------------------------------------------------

struct ChunkTable {
  std::vector<Chunk> chunks;  // empty when there is no usable table
  std::string problem;        // why not, when not
};

ChunkTable unusable(std::string problem) { return {{}, std::move(problem)}; }

ChunkTable readChunkTable(std::string_view file, const PointRecords& las, bool variable) {
  const std::size_t chunksBegin = las.pointsAt + 8;
  if (chunksBegin > file.size())
    fail("byte {}: the file ends inside the 8-byte LAZ chunk table offset", las.pointsAt);
  auto tableAt = read<std::int64_t>(file, las.pointsAt, "chunk table offset");
  // -1: a writer that could not seek back put the offset at the very end.
  if (tableAt == -1) tableAt = read<std::int64_t>(file, file.size() - 8, "chunk table offset at the end");
  if (tableAt == static_cast<std::int64_t>(las.pointsAt))
    return unusable("the LAZ chunk table is missing (its writer was interrupted)");
  if (tableAt < static_cast<std::int64_t>(chunksBegin) || tableAt > static_cast<std::int64_t>(file.size()) - 8)
    return unusable(fmt::format("the LAZ chunk table offset {} (byte {}) is outside the file's point data", tableAt,
                                las.pointsAt));
  const auto at = static_cast<std::size_t>(tableAt);
  const auto version = read<std::uint32_t>(file, at, "chunk table version");
  if (version != 0) return unusable(fmt::format("the LAZ chunk table at byte {} has version {}, not 0", at, version));
  const auto count = read<std::uint32_t>(file, at + 4, "chunk count");
  // Every chunk holds at least its first point, raw.
  if (count == 0 || count > (at - chunksBegin) / las.recordLength)
    return unusable(fmt::format("the LAZ chunk table at byte {} lists {} chunks, and {} bytes of chunks hold 1 to {}",
                                at, count, at - chunksBegin, (at - chunksBegin) / las.recordLength));
  // Each chunk's point count (variable chunks) and bytes, predicted from the
  // previous chunk's.
  ArithmeticDecoder decoder;
  const auto* bytes = reinterpret_cast<const std::uint8_t*>(file.data());
  decoder.start(bytes + at + 8, bytes + file.size());
  IntegerDecoder sizes(32, 2);
  std::vector<Chunk> chunks(count);
  std::int32_t lastPoints = 0, lastBytes = 0;
  std::size_t begin = chunksBegin;
  for (Chunk& chunk : chunks) {
    if (variable) lastPoints = sizes.decode(decoder, lastPoints, 0);
    lastBytes = sizes.decode(decoder, lastBytes, 1);
    if (variable && lastPoints <= 0)
      return unusable(fmt::format("the LAZ chunk table at byte {} is corrupt: chunk {} of {} points", at,
                                  &chunk - chunks.data(), lastPoints));
    if (lastBytes <= 0 || static_cast<std::size_t>(lastBytes) > at - begin)
      return unusable(fmt::format("the LAZ chunk table at byte {} is corrupt: chunk {} of {} bytes at byte {} runs "
                                  "past the table",
                                  at, &chunk - chunks.data(), lastBytes, begin));
    chunk = {begin, begin + static_cast<std::size_t>(lastBytes), static_cast<std::uint32_t>(lastPoints)};
    begin = chunk.end;
  }
  if (decoder.overran()) return unusable(fmt::format("the LAZ chunk table at byte {} is truncated", at));
  return {std::move(chunks), {}};
}

// The chunks to decode: from the table, or (fixed-size chunks without one)
// one after another from the first, each ending where the previous one did.
std::vector<Chunk> planChunks(std::string_view file, const PointRecords& las, const LaszipVlr& vlr,
                              std::string& note) {
  if (vlr.compressor == kPointwise) return {{las.pointsAt, file.size(), las.pointCount}};
  const bool variable = vlr.chunkSize == 0 || vlr.chunkSize == kVariableChunks;
  ChunkTable table = readChunkTable(file, las, variable);
  if (table.chunks.empty()) {
    if (variable)
      fail("byte {}: the LAZ chunks vary in size, which only the chunk table says, and {}", las.pointsAt,
           table.problem);
    note = table.problem + "; the chunks were read one after another";
    const std::uint64_t chunks = (las.pointCount + vlr.chunkSize - 1) / vlr.chunkSize;
    if (chunks > (file.size() - las.pointsAt - 8) / las.recordLength)
      fail("byte {}: the header claims {} points, {} chunks of {}: more than the file's {} bytes of chunks hold",
           las.pointCountAt, las.pointCount, chunks, vlr.chunkSize, file.size() - las.pointsAt - 8);
    std::vector<Chunk> sequence(chunks, Chunk{Chunk::kAfterThePrevious, file.size(), vlr.chunkSize});
    sequence.back().points = las.pointCount - (chunks - 1) * vlr.chunkSize;
    return sequence;
  }
  // Fixed-size chunks: the table gives their bytes; the last may be partial.
  std::vector<Chunk>& chunks = table.chunks;
  if (!variable)
    for (Chunk& chunk : chunks) chunk.points = vlr.chunkSize;
  std::uint64_t tabled = 0, needed = 0;
  for (const Chunk& chunk : chunks) {
    if (tabled >= las.pointCount) break;
    tabled += chunk.points;
    ++needed;
  }
  if (tabled < las.pointCount)
    fail("byte {}: the header claims {} points, the LAZ chunk table's {} chunks hold {}", las.pointCountAt,
         las.pointCount, chunks.size(), tabled);
  chunks.resize(needed);
  chunks.back().points -= tabled - las.pointCount;
  return chunks;
}

std::string describe(const LaszipVlr& vlr, std::size_t chunks) {
  std::string items;
  for (const Item& item : vlr.items)
    items += fmt::format("{}{} v{}", items.empty() ? "" : ", ", itemName(static_cast<std::uint16_t>(item.type)),
                         item.version);
  const bool variable = vlr.chunkSize == 0 || vlr.chunkSize == kVariableChunks;
  const std::string chunking = vlr.compressor == kPointwise ? "one stream"
                               : variable ? fmt::format("{} chunk{} of varying size", chunks, chunks == 1 ? "" : "s")
                                          : fmt::format("{} chunk{} of up to {} points", chunks,
                                                        chunks == 1 ? "" : "s", vlr.chunkSize);
  return fmt::format("points decompressed from LAZ (LASzip {}.{}r{}, compressor {}: {}, {}; items {})",
                     vlr.versionMajor, vlr.versionMinor, vlr.versionRevision, vlr.compressor,
                     compressorName(vlr.compressor), chunking, items);
}

}  // namespace

std::string decompressPointsInRuns(std::string_view file, const PointRecords& las, std::uint64_t runPoints,
                                   const std::function<void(std::string& records, std::size_t end)>& take) {
  const LaszipVlr vlr = parseLaszipVlr(file, las);
  if (las.pointCount == 0) return describe(vlr, 0);
  const std::uint64_t dataBytes = file.size() - las.pointsAt;
  if (las.pointCount > kMostPointsPerByte * dataBytes)
    fail("byte {}: the header claims {} points, more than LASzip could code in the {} bytes of point data",
         las.pointCountAt, las.pointCount, dataBytes);
  std::string tableNote;
  const std::vector<Chunk> chunks = planChunks(file, las, vlr, tableNote);
  std::string summary = describe(vlr, chunks.size());
  if (!tableNote.empty()) summary += "; " + tableNote;
  const std::uint64_t runBytes = runPoints * las.recordLength;
  std::string records;
  records.reserve(std::min({las.pointCount * las.recordLength, runBytes, kReservedBytesPerCompressedByte * dataBytes}));
  PointDecoder decoder(vlr, las.recordLength);
  std::size_t sequentialAt = las.pointsAt + 8;
  for (std::size_t i = 0; i < chunks.size(); ++i) {
    Chunk chunk = chunks[i];
    if (chunk.begin == Chunk::kAfterThePrevious) chunk.begin = sequentialAt;
    sequentialAt = chunk.begin + decoder.decodeChunk(file, chunk, i, records);
    if (records.size() >= runBytes || i + 1 == chunks.size()) {
      take(records, sequentialAt);
      records.clear();
    }
  }
  return summary;
}

Decompressed decompressPoints(std::string_view file, const PointRecords& las) {
  Decompressed result;
  result.summary = decompressPointsInRuns(file, las, std::numeric_limits<std::uint64_t>::max() / las.recordLength,
                                          [&](std::string& records, std::size_t) { result.records = std::move(records); });
  return result;
}

}  // namespace apo::laz
