// LASzip's item decoders, from lasreaditemcompressed_v1.cpp (versions 1),
// _v2.cpp (versions 2) and _v3.cpp (LAS 1.4 layered, versions 3) of
// LASzip/LASzip, and laszip_common_v2.hpp / _v3.hpp for their contexts. Each
// works on the raw little-endian bytes of its part of a LAS point record.
// Where LASzip's arithmetic would overflow a signed integer, this wraps
// (what LASzip's compiled code does).
#include "ingest/laz_items.h"

#include "ingest/laz_item_contexts.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cstddef>
#include <cstring>
#include <vector>

namespace apo::laz {
namespace {

static_assert(std::endian::native == std::endian::little, "the item decoders copy little-endian records as they are");

// ---------------------------------------------------------------------------
// Shared pieces (the rest are in laz_item_contexts.h)
// ---------------------------------------------------------------------------

// The same for points 6-10, in 6 contexts (laszip_common_v3.hpp).
constexpr std::uint8_t kReturnMap14[16][16] = {
    {0, 1, 2, 3, 4, 5, 3, 4, 4, 5, 5, 5, 5, 5, 5, 5}, {1, 0, 1, 3, 3, 3, 3, 3, 3, 3, 3, 3, 3, 3, 3, 3},
    {2, 1, 2, 4, 4, 4, 4, 4, 4, 4, 4, 3, 3, 3, 3, 3}, {3, 3, 4, 5, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4},
    {4, 3, 4, 4, 5, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4}, {5, 3, 4, 4, 4, 5, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4},
    {3, 3, 4, 4, 4, 4, 5, 4, 4, 4, 4, 4, 4, 4, 4, 4}, {4, 3, 4, 4, 4, 4, 4, 5, 4, 4, 4, 4, 4, 4, 4, 4},
    {4, 3, 4, 4, 4, 4, 4, 4, 5, 4, 4, 4, 4, 4, 4, 4}, {5, 3, 4, 4, 4, 4, 4, 4, 4, 5, 4, 4, 4, 4, 4, 4},
    {5, 3, 4, 4, 4, 4, 4, 4, 4, 4, 5, 4, 4, 4, 4, 4}, {5, 3, 3, 4, 4, 4, 4, 4, 4, 4, 4, 5, 5, 4, 4, 4},
    {5, 3, 3, 4, 4, 4, 4, 4, 4, 4, 4, 5, 5, 5, 4, 4}, {5, 3, 3, 4, 4, 4, 4, 4, 4, 4, 4, 4, 5, 5, 5, 4},
    {5, 3, 3, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 5, 5, 5}, {5, 3, 3, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 4, 5, 5}};

// One colour from the last (LASzip's RGB v2 coding, shared by v3).
void decodeRgb(ArithmeticDecoder& decoder, RgbModels& models, const std::uint16_t* last, std::uint16_t* rgb) {
  const std::uint32_t changed = decoder.decodeSymbol(models.changed);
  auto lowOf = [](std::uint32_t v) { return static_cast<std::int32_t>(v & 0xFF); };
  auto highOf = [](std::uint32_t v) { return static_cast<std::int32_t>(v >> 8); };
  auto corrected = [&](int byte, std::int32_t predicted) {
    return foldByte(static_cast<std::int32_t>(decoder.decodeSymbol(models.difference[byte])) + predicted);
  };
  // Red: low then high byte from the last red.
  rgb[0] = (changed & 1) ? corrected(0, lowOf(last[0])) : last[0] & 0xFF;
  rgb[0] |= (changed & 2) ? corrected(1, highOf(last[0])) << 8 : last[0] & 0xFF00;
  if ((changed & 64) == 0) {
    // Grey: green and blue are red.
    rgb[1] = rgb[2] = rgb[0];
    return;
  }
  // Low bytes of green and blue, predicted by red's (and green's) change.
  std::int32_t diff = lowOf(rgb[0]) - lowOf(last[0]);
  rgb[1] = (changed & 4) ? corrected(2, clampByte(diff + lowOf(last[1]))) : last[1] & 0xFF;
  if (changed & 16) {
    diff = (diff + lowOf(rgb[1]) - lowOf(last[1])) / 2;
    rgb[2] = corrected(4, clampByte(diff + lowOf(last[2])));
  } else {
    rgb[2] = last[2] & 0xFF;
  }
  // High bytes the same way.
  diff = highOf(rgb[0]) - highOf(last[0]);
  rgb[1] |= (changed & 8) ? corrected(3, clampByte(diff + highOf(last[1]))) << 8 : last[1] & 0xFF00;
  if (changed & 32) {
    diff = (diff + highOf(rgb[1]) - highOf(last[1])) / 2;
    rgb[2] |= corrected(5, clampByte(diff + highOf(last[2]))) << 8;
  } else {
    rgb[2] |= last[2] & 0xFF00;
  }
}


// ---------------------------------------------------------------------------
// Versions 1 (LASzip 1.0-1.x, compressor 1)
// ---------------------------------------------------------------------------

class Point10V1 final : public PointwiseItemDecoder {
 public:
  void startChunk(const std::uint8_t* first) override {
    lastXDiff_ = lastYDiff_ = {};
    nextDiff_ = 0;
    dx_.reset();
    dy_.reset();
    z_.reset();
    intensity_.reset();
    scanAngleRank_.reset();
    pointSourceId_.reset();
    changed_.reset();
    returnsByte_.startChunk();
    classification_.startChunk();
    userData_.startChunk();
    std::memcpy(&last_, first, sizeof last_);
  }

  void decode(ArithmeticDecoder& decoder, std::uint8_t* out) override {
    // Coordinates: x and y from the median of the last three differences.
    const std::int32_t xDiff = dx_.decode(decoder, medianOf3(lastXDiff_));
    last_.x = wrappingAdd(last_.x, xDiff);
    std::uint32_t kBits = dx_.k();
    const std::int32_t yDiff = dy_.decode(decoder, medianOf3(lastYDiff_), std::min(kBits, 19U));
    last_.y = wrappingAdd(last_.y, yDiff);
    kBits = (kBits + dy_.k()) / 2;
    last_.z = z_.decode(decoder, last_.z, std::min(kBits, 19U));
    // The other fields, each only when the point says it changed.
    const std::uint32_t changed = decoder.decodeSymbol(changed_);
    if (changed & 32) last_.intensity = static_cast<std::uint16_t>(intensity_.decode(decoder, last_.intensity));
    if (changed & 16) last_.returns = static_cast<std::uint8_t>(decoder.decodeSymbol(returnsByte_[last_.returns]));
    if (changed & 8)
      last_.classification = static_cast<std::uint8_t>(decoder.decodeSymbol(classification_[last_.classification]));
    if (changed & 4)
      last_.scanAngleRank = static_cast<std::uint8_t>(scanAngleRank_.decode(decoder, last_.scanAngleRank, kBits < 3));
    if (changed & 2) last_.userData = static_cast<std::uint8_t>(decoder.decodeSymbol(userData_[last_.userData]));
    if (changed & 1)
      last_.pointSourceId = static_cast<std::uint16_t>(pointSourceId_.decode(decoder, last_.pointSourceId));
    lastXDiff_[nextDiff_] = xDiff;
    lastYDiff_[nextDiff_] = yDiff;
    nextDiff_ = (nextDiff_ + 1) % 3;
    std::memcpy(out, &last_, sizeof last_);
  }

 private:
  static std::int32_t medianOf3(const std::array<std::int32_t, 3>& v) {
    if (v[0] < v[1]) return v[1] < v[2] ? v[1] : v[0] < v[2] ? v[2] : v[0];
    return v[0] < v[2] ? v[0] : v[1] < v[2] ? v[2] : v[1];
  }

  Point10 last_{};
  std::array<std::int32_t, 3> lastXDiff_{}, lastYDiff_{};
  int nextDiff_ = 0;
  IntegerDecoder dx_{32}, dy_{32, 20}, z_{32, 20}, intensity_{16}, scanAngleRank_{8, 2}, pointSourceId_{16};
  SymbolModel changed_{64};
  LazySymbolModels returnsByte_{256, 256}, classification_{256, 256}, userData_{256, 256};
};

class GpsTime11V1 final : public PointwiseItemDecoder {
 public:
  void startChunk(const std::uint8_t* first) override {
    lastDiff_ = 0;
    extremeCount_ = 0;
    multi_.reset();
    zeroDiff_.reset();
    gpsTime_.reset();
    last_ = load<std::uint64_t>(first);
  }

  void decode(ArithmeticDecoder& decoder, std::uint8_t* out) override {
    if (lastDiff_ == 0) {
      // After an unchanged time: unchanged, a 32-bit difference or a full value.
      const std::uint32_t code = decoder.decodeSymbol(zeroDiff_);
      if (code == 1) {
        lastDiff_ = gpsTime_.decode(decoder, 0, 0);
        last_ += static_cast<std::uint64_t>(static_cast<std::int64_t>(lastDiff_));
      } else if (code == 2) {
        last_ = decoder.readInt64();
      }
    } else {
      // A multiple of the last difference, corrected; or a full value.
      const auto multi = static_cast<std::int32_t>(decoder.decodeSymbol(multi_));
      if (multi < kMultiMax - 2) {
        std::int32_t diff;
        if (multi == 1) {
          diff = gpsTime_.decode(decoder, lastDiff_, 1);
          lastDiff_ = diff;
          extremeCount_ = 0;
        } else if (multi == 0) {
          diff = gpsTime_.decode(decoder, lastDiff_ / 4, 2);
          adoptAfterExtremes(diff);
        } else {
          diff = gpsTime_.decode(decoder, wrappingMultiply(multi, lastDiff_), multi < 10 ? 3 : multi < 50 ? 4 : 5);
          if (multi == kMultiMax - 3) adoptAfterExtremes(diff);
        }
        last_ += static_cast<std::uint64_t>(static_cast<std::int64_t>(diff));
      } else if (multi < kMultiMax - 1) {
        last_ = decoder.readInt64();
      }
    }
    std::memcpy(out, &last_, sizeof last_);
  }

 private:
  static constexpr std::int32_t kMultiMax = 512;

  // An extreme multiple four times running becomes the new difference.
  void adoptAfterExtremes(std::int32_t diff) {
    if (++extremeCount_ > 3) {
      lastDiff_ = diff;
      extremeCount_ = 0;
    }
  }

  std::uint64_t last_ = 0;
  std::int32_t lastDiff_ = 0;
  int extremeCount_ = 0;
  SymbolModel multi_{kMultiMax}, zeroDiff_{3};
  IntegerDecoder gpsTime_{32, 6};
};

class Rgb12V1 final : public PointwiseItemDecoder {
 public:
  void startChunk(const std::uint8_t* first) override {
    changed_.reset();
    rgb_.reset();
    std::memcpy(last_.data(), first, 6);
  }

  void decode(ArithmeticDecoder& decoder, std::uint8_t* out) override {
    // Each byte of each channel: corrected from the last when flagged.
    const std::uint32_t changed = decoder.decodeSymbol(changed_);
    std::array<std::uint16_t, 3> rgb{};
    for (std::uint32_t channel = 0; channel < 3; ++channel) {
      const std::uint32_t lowBit = 1U << (2 * channel), highBit = lowBit << 1;
      const std::uint16_t last = last_[channel];
      rgb[channel] = (changed & lowBit)
                         ? static_cast<std::uint16_t>(rgb_.decode(decoder, last & 0xFF, 2 * channel))
                         : static_cast<std::uint16_t>(last & 0xFF);
      rgb[channel] |= (changed & highBit)
                          ? static_cast<std::uint16_t>(rgb_.decode(decoder, last >> 8, 2 * channel + 1) << 8)
                          : static_cast<std::uint16_t>(last & 0xFF00);
    }
    last_ = rgb;
    std::memcpy(out, rgb.data(), 6);
  }

 private:
  std::array<std::uint16_t, 3> last_{};
  SymbolModel changed_{64};
  IntegerDecoder rgb_{8, 6};
};

class ByteV1 final : public PointwiseItemDecoder {
 public:
  explicit ByteV1(std::uint16_t count) : last_(count), bytes_(8, count) {}

  void startChunk(const std::uint8_t* first) override {
    bytes_.reset();
    std::memcpy(last_.data(), first, last_.size());
  }

  void decode(ArithmeticDecoder& decoder, std::uint8_t* out) override {
    for (std::uint32_t i = 0; i < last_.size(); ++i)
      out[i] = last_[i] = static_cast<std::uint8_t>(bytes_.decode(decoder, last_[i], i));
  }

 private:
  std::vector<std::uint8_t> last_;
  IntegerDecoder bytes_;
};

// ---------------------------------------------------------------------------
// Versions 2 (LASzip 2.x and later, compressor 2)
// ---------------------------------------------------------------------------

class Point10V2 final : public PointwiseItemDecoder {
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
    // LASzip predicts the chunk's second intensity from 0, not the first's.
    last_.intensity = 0;
  }

  void decode(ArithmeticDecoder& decoder, std::uint8_t* out) override {
    const std::uint32_t changed = decoder.decodeSymbol(changed_);
    if (changed & 32) last_.returns = static_cast<std::uint8_t>(decoder.decodeSymbol(returnsByte_[last_.returns]));
    const std::uint32_t r = last_.returnNumber(), n = last_.numberOfReturns();
    const std::uint32_t m = kReturnMap10[n][r];
    const std::uint32_t l = returnLevel(n, r, 7);
    if (changed != 0) decodeAttributes(decoder, changed, m);
    // x, then y in a context of x's corrector size, then z of both.
    std::int32_t diff = dx_.decode(decoder, lastXDiff_[m].median(), n == 1);
    last_.x = wrappingAdd(last_.x, diff);
    lastXDiff_[m].add(diff);
    std::uint32_t kBits = dx_.k();
    diff = dy_.decode(decoder, lastYDiff_[m].median(), (n == 1) + (kBits < 20 ? evenBits(kBits) : 20));
    last_.y = wrappingAdd(last_.y, diff);
    lastYDiff_[m].add(diff);
    kBits = (dx_.k() + dy_.k()) / 2;
    last_.z = z_.decode(decoder, lastHeight_[l], (n == 1) + (kBits < 18 ? evenBits(kBits) : 18));
    lastHeight_[l] = last_.z;
    std::memcpy(out, &last_, sizeof last_);
  }

 private:
  // Intensity, classification, scan angle, user data, point source: as flagged.
  void decodeAttributes(ArithmeticDecoder& decoder, std::uint32_t changed, std::uint32_t m) {
    if (changed & 16) {
      last_.intensity = static_cast<std::uint16_t>(intensity_.decode(decoder, lastIntensity_[m], std::min(m, 3U)));
      lastIntensity_[m] = last_.intensity;
    } else {
      last_.intensity = lastIntensity_[m];
    }
    if (changed & 8)
      last_.classification = static_cast<std::uint8_t>(decoder.decodeSymbol(classification_[last_.classification]));
    if (changed & 4) {
      const auto delta = static_cast<std::int32_t>(decoder.decodeSymbol(scanAngleRank_[last_.scanDirection()]));
      last_.scanAngleRank = foldByte(delta + last_.scanAngleRank);
    }
    if (changed & 2) last_.userData = static_cast<std::uint8_t>(decoder.decodeSymbol(userData_[last_.userData]));
    if (changed & 1)
      last_.pointSourceId = static_cast<std::uint16_t>(pointSourceId_.decode(decoder, last_.pointSourceId));
  }

  Point10 last_{};
  std::array<StreamingMedian5, 16> lastXDiff_{}, lastYDiff_{};
  std::array<std::uint16_t, 16> lastIntensity_{};
  std::array<std::int32_t, 8> lastHeight_{};
  SymbolModel changed_{64};
  IntegerDecoder intensity_{16, 4};
  std::array<SymbolModel, 2> scanAngleRank_{SymbolModel(256), SymbolModel(256)};
  IntegerDecoder pointSourceId_{16};
  LazySymbolModels returnsByte_{256, 256}, classification_{256, 256}, userData_{256, 256};
  IntegerDecoder dx_{32, 2}, dy_{32, 22}, z_{32, 20};
};

// GPS times as up to four interleaved sequences (LASzip's v2 coding, which the
// v3 one varies): each with its last time and its last 32-bit difference.
struct GpsSequences {
  std::uint32_t last = 0, next = 0;
  std::array<std::uint64_t, 4> time{};
  std::array<std::int32_t, 4> diff{};
  std::array<std::int32_t, 4> extremeCount{};

  void reset(std::uint64_t first) {
    last = next = 0;
    time = {first, 0, 0, 0};
    diff = {};
    extremeCount = {};
  }
  void add(std::int32_t delta) { time[last] += static_cast<std::uint64_t>(static_cast<std::int64_t>(delta)); }
  // An extreme multiple four times running becomes the sequence's difference.
  void adoptAfterExtremes(std::int32_t delta) {
    if (++extremeCount[last] > 3) {
      diff[last] = delta;
      extremeCount[last] = 0;
    }
  }
  // A new sequence from a full time: its high half predicted by the current one's.
  void startNew(ArithmeticDecoder& decoder, IntegerDecoder& gpsTime) {
    next = (next + 1) & 3;
    const auto high = static_cast<std::uint32_t>(
        gpsTime.decode(decoder, static_cast<std::int32_t>(time[last] >> 32), 8));
    time[next] = (std::uint64_t{high} << 32) | decoder.readInt();
    last = next;
    diff[last] = 0;
    extremeCount[last] = 0;
  }
  // A multiple of the sequence's difference, corrected (codes below `full`).
  void addMultiple(ArithmeticDecoder& decoder, IntegerDecoder& gpsTime, std::int32_t multi) {
    constexpr std::int32_t kMulti = 500, kMultiMinus = -10;
    std::int32_t delta;
    if (multi == 0) {
      delta = gpsTime.decode(decoder, 0, 7);
      adoptAfterExtremes(delta);
    } else if (multi < kMulti) {
      delta = gpsTime.decode(decoder, wrappingMultiply(multi, diff[last]), multi < 10 ? 2 : 3);
    } else if (multi == kMulti) {
      delta = gpsTime.decode(decoder, wrappingMultiply(kMulti, diff[last]), 4);
      adoptAfterExtremes(delta);
    } else {
      multi = kMulti - multi;
      if (multi > kMultiMinus) {
        delta = gpsTime.decode(decoder, wrappingMultiply(multi, diff[last]), 5);
      } else {
        delta = gpsTime.decode(decoder, wrappingMultiply(kMultiMinus, diff[last]), 6);
        adoptAfterExtremes(delta);
      }
    }
    add(delta);
  }
};

// A writer switches sequence at most once per point; more is corruption (and
// LASzip's recursion would not end on it).
constexpr int kMostSequenceSwitches = 4;

[[noreturn]] void failSequenceSwitches() {
  throw CorruptStream(fmt::format("GPS time switches sequence more than {} times in one point", kMostSequenceSwitches));
}

class GpsTime11V2 final : public PointwiseItemDecoder {
 public:
  void startChunk(const std::uint8_t* first) override {
    multi_.reset();
    zeroDiff_.reset();
    gpsTime_.reset();
    sequences_.reset(load<std::uint64_t>(first));
  }

  void decode(ArithmeticDecoder& decoder, std::uint8_t* out) override {
    GpsSequences& s = sequences_;
    for (int switches = 0; switches <= kMostSequenceSwitches; ++switches) {
      if (s.diff[s.last] == 0) {
        // After an unchanged time: unchanged (0), a 32-bit difference (1), a
        // full time (2) or a switch to another sequence (3-5).
        const std::uint32_t code = decoder.decodeSymbol(zeroDiff_);
        if (code == 1) {
          s.diff[s.last] = gpsTime_.decode(decoder, 0, 0);
          s.add(s.diff[s.last]);
          s.extremeCount[s.last] = 0;
        } else if (code == 2) {
          s.startNew(decoder, gpsTime_);
        } else if (code > 2) {
          s.last = (s.last + code - 2) & 3;
          continue;
        }
      } else {
        const auto multi = static_cast<std::int32_t>(decoder.decodeSymbol(multi_));
        if (multi == 1) {
          s.add(gpsTime_.decode(decoder, s.diff[s.last], 1));
          s.extremeCount[s.last] = 0;
        } else if (multi < kUnchanged) {
          s.addMultiple(decoder, gpsTime_, multi);
        } else if (multi == kFull) {
          s.startNew(decoder, gpsTime_);
        } else if (multi > kFull) {
          s.last = (s.last + static_cast<std::uint32_t>(multi - kFull)) & 3;
          continue;
        }
      }
      std::memcpy(out, &s.time[s.last], 8);
      return;
    }
    failSequenceSwitches();
  }

 private:
  static constexpr std::int32_t kUnchanged = 511, kFull = 512, kTotal = 516;

  GpsSequences sequences_;
  SymbolModel multi_{kTotal}, zeroDiff_{6};
  IntegerDecoder gpsTime_{32, 9};
};

class Rgb12V2 final : public PointwiseItemDecoder {
 public:
  void startChunk(const std::uint8_t* first) override {
    models_.reset();
    std::memcpy(last_.data(), first, 6);
  }

  void decode(ArithmeticDecoder& decoder, std::uint8_t* out) override {
    std::array<std::uint16_t, 3> rgb{};
    decodeRgb(decoder, models_, last_.data(), rgb.data());
    last_ = rgb;
    std::memcpy(out, rgb.data(), 6);
  }

 private:
  std::array<std::uint16_t, 3> last_{};
  RgbModels models_;
};

class ByteV2 final : public PointwiseItemDecoder {
 public:
  explicit ByteV2(std::uint16_t count) : last_(count) {
    models_.reserve(count);
    for (std::uint16_t i = 0; i < count; ++i) models_.emplace_back(256);
  }

  void startChunk(const std::uint8_t* first) override {
    for (SymbolModel& m : models_) m.reset();
    std::memcpy(last_.data(), first, last_.size());
  }

  void decode(ArithmeticDecoder& decoder, std::uint8_t* out) override {
    for (std::size_t i = 0; i < last_.size(); ++i)
      out[i] = last_[i] = foldByte(last_[i] + static_cast<std::int32_t>(decoder.decodeSymbol(models_[i])));
  }

 private:
  std::vector<std::uint8_t> last_;
  std::vector<SymbolModel> models_;
};

// ---------------------------------------------------------------------------
// Versions 3 (LAS 1.4 point formats 6-10, layered, compressor 3)
// ---------------------------------------------------------------------------

using Layers = std::span<const std::span<const std::uint8_t>>;

// One layer's decoder: started only on a non-empty layer (an empty one means
// the field never changes in the chunk).
struct Layer {
  ArithmeticDecoder decoder;
  bool changes = false;

  void start(std::span<const std::uint8_t> bytes) {
    changes = !bytes.empty();
    if (changes) decoder.start(bytes.data(), bytes.data() + bytes.size());
  }
  bool overran() const { return changes && decoder.overran(); }
};

// The raw 30 bytes of point formats 6-10 (POINT14) and LASzip's flag of
// whether the GPS time changed at this point.
struct Point14 {
  std::int32_t x, y, z;
  std::uint16_t intensity;
  std::uint8_t returns;  // return number (bits 0-3), number of returns (4-7)
  std::uint8_t flags;    // classification flags (0-3), scanner channel (4-5), scan direction (6), edge (7)
  std::uint8_t classification;
  std::uint8_t userData;
  std::int16_t scanAngle;
  std::uint16_t pointSourceId;
  std::uint64_t gpsTime;  // at byte 22 of the record
  bool gpsTimeChange;

  static constexpr std::size_t kBytesBeforeGpsTime = 22;

  static Point14 fromRecord(const std::uint8_t* at) {
    Point14 p{};
    std::memcpy(&p, at, kBytesBeforeGpsTime);
    std::memcpy(&p.gpsTime, at + kBytesBeforeGpsTime, 8);
    return p;
  }
  void toRecord(std::uint8_t* at) const {
    std::memcpy(at, this, kBytesBeforeGpsTime);
    std::memcpy(at + kBytesBeforeGpsTime, &gpsTime, 8);
  }

  std::uint32_t returnNumber() const { return returns & 0x0F; }
  std::uint32_t numberOfReturns() const { return returns >> 4; }
  std::uint32_t channel() const { return (flags >> 4) & 3; }
  void setReturnNumber(std::uint32_t r) { returns = static_cast<std::uint8_t>((returns & 0xF0) | r); }
  void setNumberOfReturns(std::uint32_t n) { returns = static_cast<std::uint8_t>((returns & 0x0F) | (n << 4)); }
  void setChannel(std::uint32_t c) { flags = static_cast<std::uint8_t>((flags & ~0x30) | (c << 4)); }
};
static_assert(offsetof(Point14, pointSourceId) == 20);

class Point14V3 final : public LayeredItemDecoder {
 public:
  std::size_t layerCount() const override { return kLayers; }

  void startChunk(const std::uint8_t* first, Layers layers, unsigned& channel) override {
    for (std::size_t i = 0; i < kLayers; ++i) layers_[i].start(layers[i]);
    // The XY layer is always decoded (an empty one only passes in a chunk of
    // one point, where nothing is decoded).
    if (!layers_[kXY].changes) layers_[kXY].decoder.start(layers[kXY].data(), layers[kXY].data());
    decodedAny_ = false;
    for (auto& c : channels_)
      if (c) c->used = false;
    const Point14 point = Point14::fromRecord(first);
    current_ = channel = point.channel();
    activate(current_, point);
  }

  void decode(std::uint8_t* out, unsigned& channel) override {
    decodedAny_ = true;
    ArithmeticDecoder& xy = layers_[kXY].decoder;
    Channel* c = channels_[current_].get();
    const std::uint32_t changed = xy.decodeSymbol(c->changedValues[lastPointReturn(c->last)]);
    // A new scanner channel: its own context, started from the current point.
    if (changed & (1 << 6)) {
      const std::uint32_t next = (current_ + xy.decodeSymbol(c->scannerChannel) + 1) % 4;
      if (!channels_[next] || !channels_[next]->used) activate(next, c->last);
      current_ = channel = next;
      c = channels_[current_].get();
      c->last.setChannel(next);
    }
    const bool pointSourceChange = changed & (1 << 5);
    const bool gpsTimeChange = changed & (1 << 4);
    const bool scanAngleChange = changed & (1 << 3);
    Point14& last = c->last;
    const std::uint32_t n = decodeNumberOfReturns(*c, changed);
    const std::uint32_t r = decodeReturnNumber(*c, changed, gpsTimeChange);
    const std::uint32_t m = kReturnMap14[n][r];
    const std::uint32_t l = returnLevel(n, r, 7);
    // Single (3), first (2), last (1) or intermediate (0) return.
    const std::uint32_t cpr = (r == 1 ? 2 : 0) + (r >= n ? 1 : 0);
    decodeXYZ(*c, n, l, (m << 1) | gpsTimeChange);
    if (layers_[kClassification].changes) {
      const std::uint32_t context = ((last.classification & 0x1F) << 1) + (cpr == 3 ? 1 : 0);
      last.classification =
          static_cast<std::uint8_t>(layers_[kClassification].decoder.decodeSymbol(c->classification[context]));
    }
    if (layers_[kFlags].changes) {
      const std::uint32_t lastFlags = ((last.flags >> 7) << 5) | (((last.flags >> 6) & 1) << 4) | (last.flags & 0x0F);
      const std::uint32_t flags = layers_[kFlags].decoder.decodeSymbol(c->flags[lastFlags]);
      last.flags = static_cast<std::uint8_t>((((flags >> 5) & 1) << 7) | (((flags >> 4) & 1) << 6) |
                                             (last.flags & 0x30) | (flags & 0x0F));
    }
    if (layers_[kIntensity].changes) {
      const std::uint32_t slot = (cpr << 1) | gpsTimeChange;
      last.intensity = static_cast<std::uint16_t>(
          c->intensity.decode(layers_[kIntensity].decoder, c->lastIntensity[slot], cpr));
      c->lastIntensity[slot] = last.intensity;
    }
    if (layers_[kScanAngle].changes && scanAngleChange)
      last.scanAngle = static_cast<std::int16_t>(
          c->scanAngle.decode(layers_[kScanAngle].decoder, last.scanAngle, gpsTimeChange));
    if (layers_[kUserData].changes)
      last.userData =
          static_cast<std::uint8_t>(layers_[kUserData].decoder.decodeSymbol(c->userData[last.userData / 4]));
    if (layers_[kPointSource].changes && pointSourceChange)
      last.pointSourceId =
          static_cast<std::uint16_t>(c->pointSourceId.decode(layers_[kPointSource].decoder, last.pointSourceId));
    if (layers_[kGpsTime].changes && gpsTimeChange) last.gpsTime = decodeGpsTime(*c);
    last.toRecord(out);
    last.gpsTimeChange = gpsTimeChange;
  }

  bool overran() const override {
    return std::any_of(layers_.begin(), layers_.end(), [](const Layer& l) { return l.overran(); }) ||
           (decodedAny_ && layers_[kXY].decoder.overran());
  }

 private:
  // The layers, in the order of their byte counts in the chunk.
  enum : std::size_t {
    kXY, kZ, kClassification, kFlags, kIntensity, kScanAngle, kUserData, kPointSource, kGpsTime, kLayers
  };
  static constexpr std::int32_t kGpsFull = 511, kGpsTotal = 515;

  // A scanner channel's context (LASzip's LAScontextPOINT14).
  struct Channel {
    bool used = false;
    Point14 last{};
    std::array<std::uint16_t, 8> lastIntensity{};
    std::array<StreamingMedian5, 12> lastXDiff{}, lastYDiff{};
    std::array<std::int32_t, 8> lastZ{};
    std::array<SymbolModel, 8> changedValues{SymbolModel(128), SymbolModel(128), SymbolModel(128), SymbolModel(128),
                                             SymbolModel(128), SymbolModel(128), SymbolModel(128), SymbolModel(128)};
    SymbolModel scannerChannel{3};
    LazySymbolModels numberOfReturns{16, 16}, returnNumber{16, 16};
    SymbolModel returnNumberGpsSame{13};
    IntegerDecoder dx{32, 2}, dy{32, 22}, z{32, 20};
    LazySymbolModels classification{64, 256}, flags{64, 64}, userData{64, 256};
    IntegerDecoder intensity{16, 4}, scanAngle{16, 2}, pointSourceId{16};
    GpsSequences gps;
    SymbolModel gpsMulti{kGpsTotal}, gpsZeroDiff{5};
    IntegerDecoder gpsTime{32, 9};
  };

  // LASzip's createAndInitModelsAndDecompressors: a channel's context from
  // `from`, the point before its first.
  void activate(std::uint32_t index, const Point14& from) {
    if (!channels_[index]) channels_[index] = std::make_unique<Channel>();
    Channel& c = *channels_[index];
    for (SymbolModel& model : c.changedValues) model.reset();
    c.scannerChannel.reset();
    c.numberOfReturns.startChunk();
    c.returnNumber.startChunk();
    c.returnNumberGpsSame.reset();
    c.dx.reset();
    c.dy.reset();
    resetAll(c.lastXDiff);
    resetAll(c.lastYDiff);
    c.z.reset();
    c.lastZ.fill(from.z);
    c.classification.startChunk();
    c.flags.startChunk();
    c.userData.startChunk();
    c.intensity.reset();
    c.lastIntensity.fill(from.intensity);
    c.scanAngle.reset();
    c.pointSourceId.reset();
    c.gpsMulti.reset();
    c.gpsZeroDiff.reset();
    c.gpsTime.reset();
    c.gps.reset(from.gpsTime);
    c.last = from;
    c.last.gpsTimeChange = false;
    c.used = true;
  }

  // Single (3), first (1), last (2) or intermediate (0) return of the last
  // point, plus 4 when its GPS time changed.
  static std::uint32_t lastPointReturn(const Point14& last) {
    const std::uint32_t r = last.returnNumber();
    return (r == 1 ? 1 : 0) + (r >= last.numberOfReturns() ? 2 : 0) + (last.gpsTimeChange ? 4 : 0);
  }

  std::uint32_t decodeNumberOfReturns(Channel& c, std::uint32_t changed) {
    const std::uint32_t lastN = c.last.numberOfReturns();
    if ((changed & (1 << 2)) == 0) return lastN;
    const std::uint32_t n = layers_[kXY].decoder.decodeSymbol(c.numberOfReturns[lastN]);
    c.last.setNumberOfReturns(n);
    return n;
  }

  // The same (0), one more (1), one less (2) or coded (3), modulo 16.
  std::uint32_t decodeReturnNumber(Channel& c, std::uint32_t changed, bool gpsTimeChange) {
    const std::uint32_t lastR = c.last.returnNumber();
    std::uint32_t r;
    switch (changed & 3) {
      case 0: return lastR;
      case 1: r = (lastR + 1) % 16; break;
      case 2: r = (lastR + 15) % 16; break;
      default:
        r = gpsTimeChange ? layers_[kXY].decoder.decodeSymbol(c.returnNumber[lastR])
                          : (lastR + layers_[kXY].decoder.decodeSymbol(c.returnNumberGpsSame) + 2) % 16;
    }
    c.last.setReturnNumber(r);
    return r;
  }

  void decodeXYZ(Channel& c, std::uint32_t n, std::uint32_t l, std::uint32_t medianSlot) {
    ArithmeticDecoder& xy = layers_[kXY].decoder;
    std::int32_t diff = c.dx.decode(xy, c.lastXDiff[medianSlot].median(), n == 1);
    c.last.x = wrappingAdd(c.last.x, diff);
    c.lastXDiff[medianSlot].add(diff);
    std::uint32_t kBits = c.dx.k();
    diff = c.dy.decode(xy, c.lastYDiff[medianSlot].median(), (n == 1) + (kBits < 20 ? evenBits(kBits) : 20));
    c.last.y = wrappingAdd(c.last.y, diff);
    c.lastYDiff[medianSlot].add(diff);
    if (!layers_[kZ].changes) return;
    kBits = (c.dx.k() + c.dy.k()) / 2;
    c.last.z = c.z.decode(layers_[kZ].decoder, c.lastZ[l], (n == 1) + (kBits < 18 ? evenBits(kBits) : 18));
    c.lastZ[l] = c.last.z;
  }

  // LASzip's read_gps_time for POINT14: as GPSTIME11 v2 without the
  // "unchanged" code (the changed bits say so already).
  std::uint64_t decodeGpsTime(Channel& c) {
    ArithmeticDecoder& decoder = layers_[kGpsTime].decoder;
    GpsSequences& s = c.gps;
    for (int switches = 0; switches <= kMostSequenceSwitches; ++switches) {
      if (s.diff[s.last] == 0) {
        // A 32-bit difference (0), a full time (1) or another sequence (2-4).
        const std::uint32_t code = decoder.decodeSymbol(c.gpsZeroDiff);
        if (code == 0) {
          s.diff[s.last] = c.gpsTime.decode(decoder, 0, 0);
          s.add(s.diff[s.last]);
          s.extremeCount[s.last] = 0;
        } else if (code == 1) {
          s.startNew(decoder, c.gpsTime);
        } else {
          s.last = (s.last + code - 1) & 3;
          continue;
        }
      } else {
        const auto multi = static_cast<std::int32_t>(decoder.decodeSymbol(c.gpsMulti));
        if (multi == 1) {
          s.add(c.gpsTime.decode(decoder, s.diff[s.last], 1));
          s.extremeCount[s.last] = 0;
        } else if (multi < kGpsFull) {
          s.addMultiple(decoder, c.gpsTime, multi);
        } else if (multi == kGpsFull) {
          s.startNew(decoder, c.gpsTime);
        } else {
          s.last = (s.last + static_cast<std::uint32_t>(multi - kGpsFull)) & 3;
          continue;
        }
      }
      return s.time[s.last];
    }
    failSequenceSwitches();
  }

  std::array<Layer, kLayers> layers_;
  std::array<std::unique_ptr<Channel>, 4> channels_;
  std::uint32_t current_ = 0;
  bool decodedAny_ = false;
};

// The scanner-channel bookkeeping of the items after POINT14, as LASzip's
// readers do it: on a switch to a channel not seen yet in the chunk, its
// context starts from the last item; on a switch back to one already seen,
// LASzip's reader keeps predicting from (and updating) the previous
// channel's last item while using the new channel's models. Its writer
// predicts from the new channel's item instead, so multi-channel files decode
// as LASzip decodes them, not necessarily as they were written: we follow
// the reader, which every LAZ consumer matches.
template <class Context>
class ChannelContexts {
 public:
  // A new chunk starting on `channel`.
  template <class Activate>
  void startChunk(unsigned channel, Activate activate) {
    for (auto& c : contexts_)
      if (c) c->used = false;
    current_ = lastOwner_ = channel;
    activate(ensure(channel));
  }
  // The point's channel; `activate(context, lastItemOf)` starts a new one.
  template <class Activate>
  void follow(unsigned channel, Activate activate) {
    lastOwner_ = current_;
    if (channel == current_) return;
    const unsigned previous = current_;
    current_ = channel;
    if (!contexts_[channel] || !contexts_[channel]->used) {
      activate(ensure(channel), *contexts_[previous]);
      lastOwner_ = channel;
    }
  }
  Context& models() { return *contexts_[current_]; }
  Context& lastItemHolder() { return *contexts_[lastOwner_]; }

 private:
  Context& ensure(unsigned channel) {
    if (!contexts_[channel]) contexts_[channel] = std::make_unique<Context>();
    contexts_[channel]->used = true;
    return *contexts_[channel];
  }

  std::array<std::unique_ptr<Context>, 4> contexts_;
  unsigned current_ = 0, lastOwner_ = 0;
};

class Rgb14V3 final : public LayeredItemDecoder {
 public:
  std::size_t layerCount() const override { return 1; }

  void startChunk(const std::uint8_t* first, Layers layers, unsigned& channel) override {
    layer_.start(layers[0]);
    channels_.startChunk(channel, [&](Context& c) {
      c.models.reset();
      std::memcpy(c.last.data(), first, 6);
    });
  }

  void decode(std::uint8_t* out, unsigned& channel) override {
    channels_.follow(channel, [](Context& c, const Context& from) {
      c.models.reset();
      c.last = from.last;
    });
    auto& last = channels_.lastItemHolder().last;
    if (layer_.changes) {
      std::array<std::uint16_t, 3> rgb{};
      decodeRgb(layer_.decoder, channels_.models().models, last.data(), rgb.data());
      last = rgb;
    }
    std::memcpy(out, last.data(), 6);
  }

  bool overran() const override { return layer_.overran(); }

 private:
  struct Context {
    bool used = false;
    std::array<std::uint16_t, 3> last{};
    RgbModels models;
  };

  Layer layer_;
  ChannelContexts<Context> channels_;
};

class RgbNir14V3 final : public LayeredItemDecoder {
 public:
  std::size_t layerCount() const override { return 2; }

  void startChunk(const std::uint8_t* first, Layers layers, unsigned& channel) override {
    rgbLayer_.start(layers[0]);
    nirLayer_.start(layers[1]);
    channels_.startChunk(channel, [&](Context& c) {
      c.reset();
      std::memcpy(c.last.data(), first, 8);
    });
  }

  void decode(std::uint8_t* out, unsigned& channel) override {
    channels_.follow(channel, [](Context& c, const Context& from) {
      c.reset();
      c.last = from.last;
    });
    auto& last = channels_.lastItemHolder().last;
    Context& models = channels_.models();
    if (rgbLayer_.changes) {
      std::array<std::uint16_t, 3> rgb{};
      decodeRgb(rgbLayer_.decoder, models.rgb, last.data(), rgb.data());
      std::copy(rgb.begin(), rgb.end(), last.begin());
    }
    if (nirLayer_.changes) last[3] = decodeNir(models, last[3]);
    std::memcpy(out, last.data(), 8);
  }

  bool overran() const override { return rgbLayer_.overran() || nirLayer_.overran(); }

 private:
  struct Context {
    bool used = false;
    std::array<std::uint16_t, 4> last{};
    RgbModels rgb;
    SymbolModel nirChanged{4};
    std::array<SymbolModel, 2> nirDifference{SymbolModel(256), SymbolModel(256)};
    void reset() {
      rgb.reset();
      nirChanged.reset();
      nirDifference[0].reset();
      nirDifference[1].reset();
    }
  };

  // Near infrared: each byte corrected from the last when flagged.
  std::uint16_t decodeNir(Context& c, std::uint16_t last) {
    ArithmeticDecoder& decoder = nirLayer_.decoder;
    const std::uint32_t changed = decoder.decodeSymbol(c.nirChanged);
    auto corrected = [&](int byte, std::int32_t predicted) {
      return foldByte(static_cast<std::int32_t>(decoder.decodeSymbol(c.nirDifference[byte])) + predicted);
    };
    std::uint16_t nir = (changed & 1) ? corrected(0, last & 0xFF) : last & 0xFF;
    nir |= (changed & 2) ? corrected(1, last >> 8) << 8 : last & 0xFF00;
    return nir;
  }

  Layer rgbLayer_, nirLayer_;
  ChannelContexts<Context> channels_;
};

class Byte14V3 final : public LayeredItemDecoder {
 public:
  explicit Byte14V3(std::uint16_t count) : count_(count), layers_(count) {}

  std::size_t layerCount() const override { return count_; }

  void startChunk(const std::uint8_t* first, Layers layers, unsigned& channel) override {
    for (std::size_t i = 0; i < count_; ++i) layers_[i].start(layers[i]);
    channels_.startChunk(channel, [&](Context& c) {
      c.reset(count_);
      std::memcpy(c.last.data(), first, count_);
    });
  }

  void decode(std::uint8_t* out, unsigned& channel) override {
    channels_.follow(channel, [&](Context& c, const Context& from) {
      c.reset(count_);
      c.last = from.last;
    });
    std::vector<std::uint8_t>& last = channels_.lastItemHolder().last;
    std::vector<SymbolModel>& models = channels_.models().models;
    for (std::size_t i = 0; i < count_; ++i) {
      if (layers_[i].changes)
        last[i] = foldByte(last[i] + static_cast<std::int32_t>(layers_[i].decoder.decodeSymbol(models[i])));
      out[i] = last[i];
    }
  }

  bool overran() const override {
    return std::any_of(layers_.begin(), layers_.end(), [](const Layer& l) { return l.overran(); });
  }

 private:
  struct Context {
    bool used = false;
    std::vector<std::uint8_t> last;
    std::vector<SymbolModel> models;
    void reset(std::size_t count) {
      last.resize(count);
      if (models.empty())
        for (std::size_t i = 0; i < count; ++i) models.emplace_back(256);
      for (SymbolModel& m : models) m.reset();
    }
  };

  std::size_t count_;
  std::vector<Layer> layers_;
  ChannelContexts<Context> channels_;
};

}  // namespace

std::string_view itemName(std::uint16_t type) {
  switch (static_cast<ItemType>(type)) {
    case ItemType::Byte: return "BYTE";
    case ItemType::Point10: return "POINT10";
    case ItemType::GpsTime11: return "GPSTIME11";
    case ItemType::Rgb12: return "RGB12";
    case ItemType::WavePacket13: return "WAVEPACKET13";
    case ItemType::Point14: return "POINT14";
    case ItemType::Rgb14: return "RGB14";
    case ItemType::RgbNir14: return "RGBNIR14";
    case ItemType::WavePacket14: return "WAVEPACKET14";
    case ItemType::Byte14: return "BYTE14";
  }
  return "unknown";
}

bool decodable(const Item& item, bool layered) {
  switch (item.type) {
    case ItemType::Point10:
    case ItemType::GpsTime11:
    case ItemType::Rgb12:
    case ItemType::Byte: return !layered && (item.version == 1 || item.version == 2);
    case ItemType::Point14:
    case ItemType::Rgb14:
    case ItemType::RgbNir14:
    case ItemType::Byte14: return layered && item.version == 3;
    default: return false;
  }
}

std::unique_ptr<PointwiseItemDecoder> makePointwiseItemDecoder(const Item& item) {
  if (!decodable(item, false)) return nullptr;
  const bool v1 = item.version == 1;
  switch (item.type) {
    case ItemType::Point10:
      if (v1) return std::make_unique<Point10V1>();
      return std::make_unique<Point10V2>();
    case ItemType::GpsTime11:
      if (v1) return std::make_unique<GpsTime11V1>();
      return std::make_unique<GpsTime11V2>();
    case ItemType::Rgb12:
      if (v1) return std::make_unique<Rgb12V1>();
      return std::make_unique<Rgb12V2>();
    default:
      if (v1) return std::make_unique<ByteV1>(item.size);
      return std::make_unique<ByteV2>(item.size);
  }
}

std::unique_ptr<LayeredItemDecoder> makeLayeredItemDecoder(const Item& item) {
  if (!decodable(item, true)) return nullptr;
  switch (item.type) {
    case ItemType::Point14: return std::make_unique<Point14V3>();
    case ItemType::Rgb14: return std::make_unique<Rgb14V3>();
    case ItemType::RgbNir14: return std::make_unique<RgbNir14V3>();
    default: return std::make_unique<Byte14V3>(item.size);
  }
}

}  // namespace apo::laz
