// Raw LAS point records to LAZ point data (laz_encoder.h has the layout).
// The item encoders mirror laz_items.cpp's decoders line for line: each
// codes what changed from the last point in the contexts the decoder will
// have when it reads it.
#include "ingest/laz_encoder.h"

#include "ingest/laz_item_contexts.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cstring>

namespace apo::laz {

static_assert(std::endian::native == std::endian::little, "the item encoders read little-endian records as they are");

// One item of compressor 2: all the items of a point share one arithmetic
// encoder, which starts after the chunk's first point (stored raw).
class PointwiseItemEncoder {
 public:
  virtual ~PointwiseItemEncoder() = default;
  // A new chunk whose first point holds `first` (the item's raw bytes).
  virtual void startChunk(const std::uint8_t* first) = 0;
  // The next point's item, from its raw bytes.
  virtual void encode(ArithmeticEncoder& encoder, const std::uint8_t* item) = 0;
};

namespace {

constexpr std::uint16_t kLaszipRecordId = 22204;
constexpr std::uint16_t kCompressorChunked = 2;
// The LASzip release whose encoding this is (LASzip 3.4r3; compressor 2
// has not changed since 2.0).
constexpr std::uint8_t kVersionMajor = 3, kVersionMinor = 4;
constexpr std::uint16_t kVersionRevision = 3;

std::int32_t wrappingSubtract(std::int32_t a, std::int32_t b) {
  return static_cast<std::int32_t>(static_cast<std::uint32_t>(a) - static_cast<std::uint32_t>(b));
}

// LASzip's laswriteitemcompressed_v2.cpp, POINT10.
class Point10V2 final : public PointwiseItemEncoder {
 public:
  void startChunk(const std::uint8_t* first) override {
    resetAll(lastXDiff_);
    resetAll(lastYDiff_);
    lastIntensity_ = {};
    lastHeight_ = {};
    changed_.reset();
    intensity_.reset();
    scanAngleRank_[0].reset();
    scanAngleRank_[1].reset();
    pointSourceId_.reset();
    returnsByte_.startChunk();
    classification_.startChunk();
    userData_.startChunk();
    dx_.reset();
    dy_.reset();
    z_.reset();
    std::memcpy(&last_, first, sizeof last_);
  }

  void encode(ArithmeticEncoder& encoder, const std::uint8_t* item) override {
    Point10 point;
    std::memcpy(&point, item, sizeof point);
    const std::uint32_t r = point.returnNumber(), n = point.numberOfReturns();
    const std::uint32_t m = kReturnMap10[n][r];
    const std::uint32_t l = returnLevel(n, r, 7);
    // Which fields changed (intensity: from the last in its return context).
    const std::uint32_t changed = (std::uint32_t{last_.returns != point.returns} << 5) |
                                  (std::uint32_t{lastIntensity_[m] != point.intensity} << 4) |
                                  (std::uint32_t{last_.classification != point.classification} << 3) |
                                  (std::uint32_t{last_.scanAngleRank != point.scanAngleRank} << 2) |
                                  (std::uint32_t{last_.userData != point.userData} << 1) |
                                  std::uint32_t{last_.pointSourceId != point.pointSourceId};
    encoder.encodeSymbol(changed_, changed);
    if (changed & 32) encoder.encodeSymbol(returnsByte_[last_.returns], point.returns);
    encodeAttributes(encoder, changed, m, point);
    // x, then y in a context of x's corrector size, then z of both.
    std::int32_t diff = wrappingSubtract(point.x, last_.x);
    dx_.encode(encoder, lastXDiff_[m].median(), diff, n == 1);
    lastXDiff_[m].add(diff);
    std::uint32_t kBits = dx_.k();
    diff = wrappingSubtract(point.y, last_.y);
    dy_.encode(encoder, lastYDiff_[m].median(), diff, (n == 1) + (kBits < 20 ? evenBits(kBits) : 20));
    lastYDiff_[m].add(diff);
    kBits = (dx_.k() + dy_.k()) / 2;
    z_.encode(encoder, lastHeight_[l], point.z, (n == 1) + (kBits < 18 ? evenBits(kBits) : 18));
    lastHeight_[l] = point.z;
    last_ = point;
  }

 private:
  // Intensity, classification, scan angle, user data, point source: as flagged.
  void encodeAttributes(ArithmeticEncoder& encoder, std::uint32_t changed, std::uint32_t m, const Point10& point) {
    if (changed & 16) {
      intensity_.encode(encoder, lastIntensity_[m], point.intensity, std::min(m, 3U));
      lastIntensity_[m] = point.intensity;
    }
    if (changed & 8) encoder.encodeSymbol(classification_[last_.classification], point.classification);
    if (changed & 4)
      encoder.encodeSymbol(scanAngleRank_[point.scanDirection()], foldByte(point.scanAngleRank - last_.scanAngleRank));
    if (changed & 2) encoder.encodeSymbol(userData_[last_.userData], point.userData);
    if (changed & 1) pointSourceId_.encode(encoder, last_.pointSourceId, point.pointSourceId);
  }

  Point10 last_{};
  std::array<StreamingMedian5, 16> lastXDiff_{}, lastYDiff_{};
  std::array<std::uint16_t, 16> lastIntensity_{};
  std::array<std::int32_t, 8> lastHeight_{};
  SymbolModel changed_{64};
  IntegerEncoder intensity_{16, 4};
  std::array<SymbolModel, 2> scanAngleRank_{SymbolModel(256), SymbolModel(256)};
  IntegerEncoder pointSourceId_{16};
  LazySymbolModels returnsByte_{256, 256}, classification_{256, 256}, userData_{256, 256};
  IntegerEncoder dx_{32, 2}, dy_{32, 22}, z_{32, 20};
};

// LASzip's GPSTIME11 v2: GPS times as up to four interleaved sequences, each
// with its last time and last 32-bit difference; a time is coded as a
// multiple of its sequence's difference, corrected.
class GpsTime11V2 final : public PointwiseItemEncoder {
 public:
  void startChunk(const std::uint8_t* first) override {
    last_ = next_ = 0;
    time_ = {load<std::int64_t>(first), 0, 0, 0};
    diff_ = {};
    extremeCount_ = {};
    multi_.reset();
    zeroDiff_.reset();
    gpsTime_.reset();
  }

  void encode(ArithmeticEncoder& encoder, const std::uint8_t* item) override {
    const auto time = load<std::int64_t>(item);
    // A switch to another sequence codes the time again in that one, where
    // it is within 32 bits of the last: at most one switch.
    while (!encodeInSequence(encoder, time)) {
    }
  }

 private:
  static constexpr std::int32_t kMulti = 500, kMultiMinus = -10;
  static constexpr std::uint32_t kUnchanged = 511, kFull = 512, kTotal = 516;

  // The sequence within 32 bits of `time` other than the current one, as
  // the step from it (1 to 3); 0 when none is.
  std::uint32_t sequenceNear(std::int64_t time) const {
    for (std::uint32_t step = 1; step < 4; ++step)
      if (fitsIn32(time - time_[(last_ + step) & 3])) return step;
    return 0;
  }

  static bool fitsIn32(std::int64_t diff) { return diff == static_cast<std::int32_t>(diff); }

  // False when it switched to another sequence instead of coding the time.
  bool encodeInSequence(ArithmeticEncoder& encoder, std::int64_t time) {
    const bool lastWasZero = diff_[last_] == 0;
    SymbolModel& model = lastWasZero ? zeroDiff_ : multi_;
    if (time == time_[last_]) {
      encoder.encodeSymbol(model, lastWasZero ? 0 : kUnchanged);
      return true;
    }
    const std::int64_t diff64 = time - time_[last_];
    if (fitsIn32(diff64)) {
      const auto diff = static_cast<std::int32_t>(diff64);
      if (lastWasZero) {
        encoder.encodeSymbol(zeroDiff_, 1);
        gpsTime_.encode(encoder, 0, diff, 0);
        diff_[last_] = diff;
        extremeCount_[last_] = 0;
      } else {
        encodeMultiple(encoder, diff);
      }
    } else if (const std::uint32_t step = sequenceNear(time); step != 0) {
      encoder.encodeSymbol(model, lastWasZero ? step + 2 : kFull + step);
      last_ = (last_ + step) & 3;
      return false;
    } else {
      // A new sequence from the full time: its high half predicted by the current one's.
      encoder.encodeSymbol(model, lastWasZero ? 2 : kFull);
      gpsTime_.encode(encoder, static_cast<std::int32_t>(static_cast<std::uint64_t>(time_[last_]) >> 32),
                      static_cast<std::int32_t>(static_cast<std::uint64_t>(time) >> 32), 8);
      encoder.writeInt(static_cast<std::uint32_t>(time));
      next_ = (next_ + 1) & 3;
      last_ = next_;
      diff_[last_] = 0;
      extremeCount_[last_] = 0;
    }
    time_[last_] = time;
    return true;
  }

  // The difference as a multiple of the sequence's last one (LASzip's
  // I32_QUANTIZE of their float ratio), corrected.
  void encodeMultiple(ArithmeticEncoder& encoder, std::int32_t diff) {
    const float ratio = static_cast<float>(diff) / static_cast<float>(diff_[last_]);
    // Beyond ±2^30 every multiple codes alike (as kMulti or kMultiMinus).
    const float clamped = std::clamp(ratio, -1e9f, 1e9f);
    const auto multi = static_cast<std::int32_t>(clamped >= 0 ? clamped + 0.5f : clamped - 0.5f);
    const std::int32_t last = diff_[last_];
    if (multi == 1) {
      encoder.encodeSymbol(multi_, 1);
      gpsTime_.encode(encoder, last, diff, 1);
      extremeCount_[last_] = 0;
    } else if (multi > 0 && multi < kMulti) {
      encoder.encodeSymbol(multi_, static_cast<std::uint32_t>(multi));
      gpsTime_.encode(encoder, wrappingMultiply(multi, last), diff, multi < 10 ? 2 : 3);
    } else if (multi >= kMulti) {
      encoder.encodeSymbol(multi_, kMulti);
      gpsTime_.encode(encoder, wrappingMultiply(kMulti, last), diff, 4);
      adoptAfterExtremes(diff);
    } else if (multi < 0 && multi > kMultiMinus) {
      encoder.encodeSymbol(multi_, static_cast<std::uint32_t>(kMulti - multi));
      gpsTime_.encode(encoder, wrappingMultiply(multi, last), diff, 5);
    } else if (multi < 0) {
      encoder.encodeSymbol(multi_, static_cast<std::uint32_t>(kMulti - kMultiMinus));
      gpsTime_.encode(encoder, wrappingMultiply(kMultiMinus, last), diff, 6);
      adoptAfterExtremes(diff);
    } else {
      encoder.encodeSymbol(multi_, 0);
      gpsTime_.encode(encoder, 0, diff, 7);
      adoptAfterExtremes(diff);
    }
  }

  // An extreme multiple four times running becomes the sequence's difference.
  void adoptAfterExtremes(std::int32_t diff) {
    if (++extremeCount_[last_] > 3) {
      diff_[last_] = diff;
      extremeCount_[last_] = 0;
    }
  }

  std::uint32_t last_ = 0, next_ = 0;
  std::array<std::int64_t, 4> time_{};
  std::array<std::int32_t, 4> diff_{};
  std::array<std::int32_t, 4> extremeCount_{};
  SymbolModel multi_{kTotal}, zeroDiff_{6};
  IntegerEncoder gpsTime_{32, 9};
};

// LASzip's RGB12 v2: which bytes changed, then each byte's difference, the
// green and blue ones predicted from red's.
class Rgb12V2 final : public PointwiseItemEncoder {
 public:
  void startChunk(const std::uint8_t* first) override {
    models_.reset();
    std::memcpy(last_.data(), first, 6);
  }

  void encode(ArithmeticEncoder& encoder, const std::uint8_t* item) override {
    std::array<std::uint16_t, 3> rgb{};
    std::memcpy(rgb.data(), item, 6);
    auto lowOf = [](std::uint32_t v) { return static_cast<std::int32_t>(v & 0xFF); };
    auto highOf = [](std::uint32_t v) { return static_cast<std::int32_t>(v >> 8); };
    const std::uint32_t changed = changedBytes(rgb);
    encoder.encodeSymbol(models_.changed, changed);
    auto code = [&](int byte, std::int32_t value, std::int32_t predicted) {
      encoder.encodeSymbol(models_.difference[byte], foldByte(value - predicted));
    };
    // Red from the last red; green and blue (when not grey) from red's change.
    std::int32_t diffLow = 0, diffHigh = 0;
    if (changed & 1) {
      diffLow = lowOf(rgb[0]) - lowOf(last_[0]);
      code(0, lowOf(rgb[0]), lowOf(last_[0]));
    }
    if (changed & 2) {
      diffHigh = highOf(rgb[0]) - highOf(last_[0]);
      code(1, highOf(rgb[0]), highOf(last_[0]));
    }
    if (changed & 64) {
      if (changed & 4) code(2, lowOf(rgb[1]), clampByte(diffLow + lowOf(last_[1])));
      if (changed & 16) {
        diffLow = (diffLow + lowOf(rgb[1]) - lowOf(last_[1])) / 2;
        code(4, lowOf(rgb[2]), clampByte(diffLow + lowOf(last_[2])));
      }
      if (changed & 8) code(3, highOf(rgb[1]), clampByte(diffHigh + highOf(last_[1])));
      if (changed & 32) {
        diffHigh = (diffHigh + highOf(rgb[1]) - highOf(last_[1])) / 2;
        code(5, highOf(rgb[2]), clampByte(diffHigh + highOf(last_[2])));
      }
    }
    last_ = rgb;
  }

 private:
  // Bits 0-5: each byte (red low, red high, green low, ...) differs from the
  // last; bit 6: the colour is not grey.
  std::uint32_t changedBytes(const std::array<std::uint16_t, 3>& rgb) const {
    std::uint32_t changed = 0;
    for (int channel = 0; channel < 3; ++channel) {
      changed |= std::uint32_t{(last_[channel] & 0x00FF) != (rgb[channel] & 0x00FF)} << (2 * channel);
      changed |= std::uint32_t{(last_[channel] & 0xFF00) != (rgb[channel] & 0xFF00)} << (2 * channel + 1);
    }
    const bool grey = rgb[0] == rgb[1] && rgb[0] == rgb[2];
    return changed | (std::uint32_t{!grey} << 6);
  }

  std::array<std::uint16_t, 3> last_{};
  RgbModels models_;
};

// The items of a point format, in record order.
struct ItemLayout {
  std::uint16_t type, size;
};

std::vector<ItemLayout> itemsOf(int format) {
  std::vector<ItemLayout> items = {{6, 20}};                        // POINT10
  if (format == 1 || format == 3) items.push_back({7, 8});         // GPSTIME11
  if (format == 2 || format == 3) items.push_back({8, 6});         // RGB12
  return items;
}

template <class T>
void append(std::string& out, T value) {
  out.append(reinterpret_cast<const char*>(&value), sizeof value);
}

}  // namespace

std::string laszipVlr(int format) {
  const std::vector<ItemLayout> items = itemsOf(format);
  const auto recordLength = static_cast<std::uint16_t>(34 + 6 * items.size());
  std::string vlr;
  // The VLR header: reserved, user id, record id, record length, description.
  append<std::uint16_t>(vlr, 0);
  vlr += std::string("laszip encoded").append(16 - 14, '\0');
  append<std::uint16_t>(vlr, kLaszipRecordId);
  append<std::uint16_t>(vlr, recordLength);
  const std::string description = "apo (LASzip 3.4r3 compressor 2)";
  vlr += description + std::string(32 - description.size(), '\0');
  // The record (laszip.cpp, LASzip::pack): compressor, coder (arithmetic),
  // version, options, chunk size, no special EVLRs (-1, -1), the items.
  append<std::uint16_t>(vlr, kCompressorChunked);
  append<std::uint16_t>(vlr, 0);
  append<std::uint8_t>(vlr, kVersionMajor);
  append<std::uint8_t>(vlr, kVersionMinor);
  append<std::uint16_t>(vlr, kVersionRevision);
  append<std::uint32_t>(vlr, 0);
  append<std::uint32_t>(vlr, kChunkPoints);
  append<std::int64_t>(vlr, -1);
  append<std::int64_t>(vlr, -1);
  append<std::uint16_t>(vlr, static_cast<std::uint16_t>(items.size()));
  for (const ItemLayout& item : items) {
    append<std::uint16_t>(vlr, item.type);
    append<std::uint16_t>(vlr, item.size);
    append<std::uint16_t>(vlr, 2);  // version 2
  }
  return vlr;
}

PointCompressor::PointCompressor(int format, std::string& file) : file_(file) {
  std::size_t offset = 0;
  for (const ItemLayout& item : itemsOf(format)) {
    itemOffsets_.push_back(offset);
    offset += item.size;
    if (item.type == 6) items_.push_back(std::make_unique<Point10V2>());
    else if (item.type == 7) items_.push_back(std::make_unique<GpsTime11V2>());
    else items_.push_back(std::make_unique<Rgb12V2>());
  }
  recordLength_ = offset;
  // The chunk table's offset, written once the table is.
  chunkTableOffsetAt_ = file_.size();
  append<std::int64_t>(file_, 0);
  chunkBegin_ = file_.size();
}

PointCompressor::~PointCompressor() = default;

void PointCompressor::add(const std::uint8_t* record) {
  if (pointsInChunk_ == kChunkPoints) endChunk();
  if (pointsInChunk_ == 0) {
    startChunk(record);
  } else {
    for (std::size_t i = 0; i < items_.size(); ++i) items_[i]->encode(encoder_, record + itemOffsets_[i]);
  }
  ++pointsInChunk_;
}

// The chunk's first point goes raw and starts every item's context.
void PointCompressor::startChunk(const std::uint8_t* record) {
  file_.append(reinterpret_cast<const char*>(record), recordLength_);
  for (std::size_t i = 0; i < items_.size(); ++i) items_[i]->startChunk(record + itemOffsets_[i]);
  encoder_.start(file_);
}

void PointCompressor::endChunk() {
  encoder_.finish();
  chunkBytes_.push_back(static_cast<std::uint32_t>(file_.size() - chunkBegin_));
  chunkBegin_ = file_.size();
  pointsInChunk_ = 0;
}

void PointCompressor::finish() {
  if (pointsInChunk_ > 0) endChunk();
  writeChunkTable();
}

// LASzip's write_chunk_table: each chunk's bytes predicted from the last's.
void PointCompressor::writeChunkTable() {
  const auto tableAt = static_cast<std::int64_t>(file_.size());
  std::memcpy(file_.data() + chunkTableOffsetAt_, &tableAt, sizeof tableAt);
  append<std::uint32_t>(file_, 0);  // version
  append<std::uint32_t>(file_, static_cast<std::uint32_t>(chunkBytes_.size()));
  if (chunkBytes_.empty()) return;
  encoder_.start(file_);
  IntegerEncoder sizes(32, 2);
  std::int32_t last = 0;
  for (const std::uint32_t bytes : chunkBytes_) {
    sizes.encode(encoder_, last, static_cast<std::int32_t>(bytes), 1);
    last = static_cast<std::int32_t>(bytes);
  }
  encoder_.finish();
}

}  // namespace apo::laz
