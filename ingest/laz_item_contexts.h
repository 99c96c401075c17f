// Internal to ingest: the pieces LASzip's item coders share between its
// decoders (laz_items.cpp) and its encoders (laz_encoder.cpp): the raw
// POINT10 record, byte arithmetic, the contexts of returns and the running
// medians of coordinate differences (laszip_common_v2.hpp), and the RGB
// models. Each must stay exactly LASzip's, or the two sides drift apart.
#pragma once

#include "ingest/laz_arithmetic.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstring>

namespace apo::laz {

template <class T>
inline T load(const std::uint8_t* at) {
  T value;
  std::memcpy(&value, at, sizeof value);
  return value;
}

inline std::int32_t wrappingAdd(std::int32_t a, std::int32_t b) {
  return static_cast<std::int32_t>(static_cast<std::uint32_t>(a) + static_cast<std::uint32_t>(b));
}
inline std::int32_t wrappingMultiply(std::int32_t a, std::int32_t b) {
  return static_cast<std::int32_t>(static_cast<std::uint32_t>(a) * static_cast<std::uint32_t>(b));
}

// LASzip's U8_FOLD: a byte difference added back, modulo 256.
inline std::uint8_t foldByte(std::int32_t n) {
  return static_cast<std::uint8_t>(n < 0 ? n + 256 : n > 255 ? n - 256 : n);
}
// LASzip's U8_CLAMP.
inline std::int32_t clampByte(std::int32_t n) { return std::clamp(n, 0, 255); }
// LASzip's U32_ZERO_BIT_0: contexts come in pairs by the corrector's bit length.
inline std::uint32_t evenBits(std::uint32_t k) { return k & ~1U; }

// LASzip's StreamingMedian5: the median of the last five values, kept with a
// few comparisons per value.
class StreamingMedian5 {
 public:
  void reset() {
    values_ = {};
    high_ = true;
  }
  std::int32_t median() const { return values_[2]; }
  void add(std::int32_t v) {
    auto& x = values_;
    if (high_) {
      if (v < x[2]) {
        x[4] = x[3];
        x[3] = x[2];
        if (v < x[0]) {
          x[2] = x[1];
          x[1] = x[0];
          x[0] = v;
        } else if (v < x[1]) {
          x[2] = x[1];
          x[1] = v;
        } else {
          x[2] = v;
        }
      } else {
        if (v < x[3]) {
          x[4] = x[3];
          x[3] = v;
        } else {
          x[4] = v;
        }
        high_ = false;
      }
    } else {
      if (x[2] < v) {
        x[0] = x[1];
        x[1] = x[2];
        if (x[4] < v) {
          x[2] = x[3];
          x[3] = x[4];
          x[4] = v;
        } else if (x[3] < v) {
          x[2] = x[3];
          x[3] = v;
        } else {
          x[2] = v;
        }
      } else {
        if (x[1] < v) {
          x[0] = x[1];
          x[1] = v;
        } else {
          x[0] = v;
        }
        high_ = true;
      }
    }
  }

 private:
  std::array<std::int32_t, 5> values_{};
  bool high_ = true;
};

template <std::size_t N>
inline void resetAll(std::array<StreamingMedian5, N>& medians) {
  for (StreamingMedian5& m : medians) m.reset();
}

// The context of a point's return number r and number of returns n for
// points 0-5 (laszip_common_v2.hpp): the valid pairs first, the odd ones
// (r or n 0, r > n) folded in.
inline constexpr std::uint8_t kReturnMap10[8][8] = {
    {15, 14, 13, 12, 11, 10, 9, 8}, {14, 0, 1, 3, 6, 10, 10, 9},   {13, 1, 2, 4, 7, 11, 11, 10},
    {12, 3, 4, 5, 8, 12, 12, 11},   {11, 6, 7, 8, 9, 13, 13, 12},  {10, 10, 11, 12, 13, 14, 14, 13},
    {9, 10, 11, 12, 13, 14, 15, 14}, {8, 9, 10, 11, 12, 13, 14, 15}};


// How deep a return is, |n - r|: LASzip's number_return_level tables (v2's
// in full, v3's capped at 7).
inline std::uint32_t returnLevel(std::uint32_t n, std::uint32_t r, std::uint32_t cap) {
  return std::min(n > r ? n - r : r - n, cap);
}

// The six byte models of RGB12 v2 and RGB14/RGBNIR14 v3: which bytes changed,
// then each byte's difference, the green and blue ones predicted from red's.
struct RgbModels {
  SymbolModel changed{128};
  std::array<SymbolModel, 6> difference{SymbolModel(256), SymbolModel(256), SymbolModel(256),
                                        SymbolModel(256), SymbolModel(256), SymbolModel(256)};
  void reset() {
    changed.reset();
    for (SymbolModel& m : difference) m.reset();
  }
};


// The raw 20 bytes of point formats 0-5 (POINT10), in the record's order.
struct Point10 {
  std::int32_t x, y, z;
  std::uint16_t intensity;
  std::uint8_t returns;  // return number (bits 0-2), number of returns (3-5), scan direction (6), edge (7)
  std::uint8_t classification;
  std::uint8_t scanAngleRank;
  std::uint8_t userData;
  std::uint16_t pointSourceId;

  std::uint32_t returnNumber() const { return returns & 7; }
  std::uint32_t numberOfReturns() const { return (returns >> 3) & 7; }
  std::uint32_t scanDirection() const { return (returns >> 6) & 1; }
};
static_assert(sizeof(Point10) == 20);

}  // namespace apo::laz
