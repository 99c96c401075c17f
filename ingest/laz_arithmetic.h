// Internal to ingest: the entropy decoding under LAZ (LASzip) point
// compression, bit-exact with LASzip's arithmeticdecoder.cpp,
// arithmeticmodel.cpp and integercompressor.cpp (Martin Isenburg's
// adaptation of Amir Said's FastAC range coder: 32-bit interval, periodic
// model updates, table look-up for large alphabets).
//
// Unlike LASzip's, this decoder reads from a span of bytes and never past its
// end: beyond it, it reads zeros and remembers that it overran, which the
// chunk decoders check and report. A corrupt span can therefore only give
// wrong symbols (always within their alphabets), never a read out of bounds.
#pragma once

#include <algorithm>
#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

// The coder's arithmetic on model state is exempt from the fuzzers' coverage
// tracing: there its comparisons are of probabilities, not of the file's
// structure, and tracing them took most of each fuzz execution.
#if defined(__clang__)
#define APO_LAZ_UNTRACED __attribute__((no_sanitize("coverage")))
#else
#define APO_LAZ_UNTRACED
#endif

namespace apo::laz {

// LASzip's constants (arithmeticmodel.hpp): interval and model precision.
inline constexpr std::uint32_t kMinLength = 0x01000000U;  // renormalise below 2^24
inline constexpr std::uint32_t kMaxLength = 0xFFFFFFFFU;
inline constexpr std::uint32_t kBitLengthShift = 13;      // bit models: 13-bit probabilities
inline constexpr std::uint32_t kBitMaxCount = 1U << kBitLengthShift;
inline constexpr std::uint32_t kSymbolLengthShift = 15;   // symbol models: 15-bit distribution
inline constexpr std::uint32_t kSymbolMaxCount = 1U << kSymbolLengthShift;

// An adaptive model of one binary decision.
class BitModel {
 public:
  BitModel() { reset(); }

  // Back to equiprobable, with frequent updates (a new chunk).
  APO_LAZ_UNTRACED void reset() {
    bit0Count_ = 1;
    bitCount_ = 2;
    bit0Probability_ = 1U << (kBitLengthShift - 1);
    updateCycle_ = bitsUntilUpdate_ = 4;
  }

 private:
  friend class ArithmeticDecoder;
  friend class ArithmeticEncoder;

  APO_LAZ_UNTRACED void update() {
    // Halve the counts when they reach the limit.
    if ((bitCount_ += updateCycle_) > kBitMaxCount) {
      bitCount_ = (bitCount_ + 1) >> 1;
      bit0Count_ = (bit0Count_ + 1) >> 1;
      if (bit0Count_ == bitCount_) ++bitCount_;
    }
    const std::uint32_t scale = 0x80000000U / bitCount_;
    bit0Probability_ = (bit0Count_ * scale) >> (31 - kBitLengthShift);
    updateCycle_ = std::min<std::uint32_t>((5 * updateCycle_) >> 2, 64);
    bitsUntilUpdate_ = updateCycle_;
  }

  std::uint32_t updateCycle_ = 0, bitsUntilUpdate_ = 0;
  std::uint32_t bit0Probability_ = 0, bit0Count_ = 0, bitCount_ = 0;
};

// An adaptive model of an alphabet of 2 to 2048 symbols: counts, their
// cumulative distribution and, above 16 symbols, a table that narrows the
// search for a decoded value.
class SymbolModel {
 public:
  explicit SymbolModel(std::uint32_t symbols) : symbols_(symbols), lastSymbol_(symbols - 1) {
    std::uint32_t tableBits = 0;
    if (symbols_ > 16) {
      tableBits = 3;
      while (symbols_ > (1U << (tableBits + 2))) ++tableBits;
      tableSize_ = 1U << tableBits;
      tableShift_ = kSymbolLengthShift - tableBits;
    }
    storage_ = std::make_unique<std::uint32_t[]>(2 * symbols_ + (tableSize_ ? tableSize_ + 2 : 0));
    distribution_ = storage_.get();
    symbolCount_ = distribution_ + symbols_;
    decoderTable_ = tableSize_ ? symbolCount_ + symbols_ : nullptr;
    reset();
  }

  // Back to all symbols equally likely (a new chunk).
  APO_LAZ_UNTRACED void reset() {
    totalCount_ = 0;
    updateCycle_ = symbols_;
    std::fill(symbolCount_, symbolCount_ + symbols_, 1U);
    update();
    symbolsUntilUpdate_ = updateCycle_ = (symbols_ + 6) >> 1;
  }

 private:
  friend class ArithmeticDecoder;
  friend class ArithmeticEncoder;

  APO_LAZ_UNTRACED void update() {
    // Halve the counts when their total reaches the limit.
    if ((totalCount_ += updateCycle_) > kSymbolMaxCount) {
      totalCount_ = 0;
      for (std::uint32_t n = 0; n < symbols_; ++n) totalCount_ += (symbolCount_[n] = (symbolCount_[n] + 1) >> 1);
    }
    // The cumulative distribution, and the decoder table when there is one.
    std::uint32_t sum = 0, s = 0;
    const std::uint32_t scale = 0x80000000U / totalCount_;
    for (std::uint32_t k = 0; k < symbols_; ++k) {
      distribution_[k] = (scale * sum) >> (31 - kSymbolLengthShift);
      sum += symbolCount_[k];
      if (tableSize_ == 0) continue;
      const std::uint32_t w = distribution_[k] >> tableShift_;
      while (s < w) decoderTable_[++s] = k - 1;
    }
    if (tableSize_ != 0) {
      decoderTable_[0] = 0;
      while (s <= tableSize_) decoderTable_[++s] = symbols_ - 1;
    }
    // Update less often as the model settles.
    updateCycle_ = std::min((5 * updateCycle_) >> 2, (symbols_ + 6) << 3);
    symbolsUntilUpdate_ = updateCycle_;
  }

  std::uint32_t symbols_, lastSymbol_;
  std::uint32_t tableSize_ = 0, tableShift_ = 0;
  std::uint32_t totalCount_ = 0, updateCycle_ = 0, symbolsUntilUpdate_ = 0;
  std::unique_ptr<std::uint32_t[]> storage_;
  std::uint32_t* distribution_ = nullptr;
  std::uint32_t* symbolCount_ = nullptr;
  std::uint32_t* decoderTable_ = nullptr;
};

// Symbol models that LASzip creates only when a context first needs them
// (one per previous value of a byte, say): each is made on its first use and
// reset on its first use after startChunk(), which is what LASzip's "create
// or re-initialise" at every chunk amounts to, and keeps its memory from
// chunk to chunk. A chunk (COPC's are small) pays only for the models it uses.
class LazySymbolModels {
 public:
  // `count` models of `symbols` symbols each.
  LazySymbolModels(std::size_t count, std::uint32_t symbols) : LazySymbolModels(std::vector(count, symbols)) {}
  // One model per entry, of that many symbols.
  explicit LazySymbolModels(std::vector<std::uint32_t> symbols)
      : symbols_(std::move(symbols)), models_(symbols_.size()), resetIn_(symbols_.size(), 0) {}

  void startChunk() { ++chunk_; }

  SymbolModel& operator[](std::size_t i) {
    if (resetIn_[i] != chunk_) {
      if (!models_[i]) models_[i] = std::make_unique<SymbolModel>(symbols_[i]);
      else models_[i]->reset();
      resetIn_[i] = chunk_;
    }
    return *models_[i];
  }

 private:
  std::vector<std::uint32_t> symbols_;
  std::uint64_t chunk_ = 1;
  std::vector<std::unique_ptr<SymbolModel>> models_;
  std::vector<std::uint64_t> resetIn_;
};

// The range decoder over one span of compressed bytes.
class ArithmeticDecoder {
 public:
  // Starts on [begin, end): reads the first four bytes of the interval.
  void start(const std::uint8_t* begin, const std::uint8_t* end) {
    at_ = begin;
    end_ = end;
    overran_ = false;
    length_ = kMaxLength;
    value_ = 0;
    for (int i = 0; i < 4; ++i) value_ = (value_ << 8) | nextByte();
  }

  // Whether a read went past the span's end (the span is truncated or corrupt).
  bool overran() const { return overran_; }
  // The next byte the decoder would read.
  const std::uint8_t* position() const { return at_; }

  APO_LAZ_UNTRACED std::uint32_t decodeBit(BitModel& m) {
    const std::uint32_t x = m.bit0Probability_ * (length_ >> kBitLengthShift);
    const std::uint32_t bit = value_ >= x;
    if (bit == 0) {
      length_ = x;
      ++m.bit0Count_;
    } else {
      value_ -= x;
      length_ -= x;
    }
    if (length_ < kMinLength) renormalize();
    if (--m.bitsUntilUpdate_ == 0) m.update();
    return bit;
  }

  APO_LAZ_UNTRACED std::uint32_t decodeSymbol(SymbolModel& m) {
    std::uint32_t symbol, x, y = length_;
    if (m.decoderTable_) {
      // A table look-up, then a bisection between its bounds.
      length_ >>= kSymbolLengthShift;
      const std::uint32_t dv = value_ / length_;
      // Only a corrupt stream (value_ >= the interval's length) leaves the table.
      const std::uint32_t t = std::min(dv >> m.tableShift_, m.tableSize_);
      symbol = m.decoderTable_[t];
      std::uint32_t n = m.decoderTable_[t + 1] + 1;
      while (n > symbol + 1) {
        const std::uint32_t k = (symbol + n) >> 1;
        if (m.distribution_[k] > dv) n = k;
        else symbol = k;
      }
      x = m.distribution_[symbol] * length_;
      if (symbol != m.lastSymbol_) y = m.distribution_[symbol + 1] * length_;
    } else {
      // A bisection with multiplications only (small alphabets).
      x = symbol = 0;
      length_ >>= kSymbolLengthShift;
      std::uint32_t n = m.symbols_;
      std::uint32_t k = n >> 1;
      do {
        const std::uint32_t z = length_ * m.distribution_[k];
        if (z > value_) {
          n = k;
          y = z;
        } else {
          symbol = k;
          x = z;
        }
      } while ((k = (symbol + n) >> 1) != symbol);
    }
    value_ -= x;
    length_ = y - x;
    if (length_ < kMinLength) renormalize();
    ++m.symbolCount_[symbol];
    if (--m.symbolsUntilUpdate_ == 0) m.update();
    return symbol;
  }

  // Raw bits (no model): 1 to 32 of them.
  APO_LAZ_UNTRACED std::uint32_t readBits(std::uint32_t bits) {
    if (bits > 19) {
      const std::uint32_t low = readShort();
      return (readBits(bits - 16) << 16) | low;
    }
    const std::uint32_t value = value_ / (length_ >>= bits);
    value_ -= length_ * value;
    if (length_ < kMinLength) renormalize();
    return value;
  }
  APO_LAZ_UNTRACED std::uint32_t readShort() {
    const std::uint32_t value = value_ / (length_ >>= 16);
    value_ -= length_ * value;
    if (length_ < kMinLength) renormalize();
    return value;
  }
  std::uint32_t readInt() {
    const std::uint32_t low = readShort();
    return (readShort() << 16) | low;
  }
  std::uint64_t readInt64() {
    const std::uint64_t low = readInt();
    return (std::uint64_t{readInt()} << 32) | low;
  }

 private:
  std::uint8_t nextByte() {
    if (at_ < end_) return *at_++;
    overran_ = true;
    return 0;
  }

  APO_LAZ_UNTRACED void renormalize() {
    do value_ = (value_ << 8) | nextByte();
    while ((length_ <<= 8) < kMinLength);
  }

  const std::uint8_t* at_ = nullptr;
  const std::uint8_t* end_ = nullptr;
  bool overran_ = false;
  std::uint32_t value_ = 0, length_ = 0;
};

// The models of LASzip's IntegerCompressor, shared by its decoding side
// (IntegerDecoder) and its encoding side (IntegerEncoder, in
// laz_arithmetic_encoder.h): an integer is its prediction plus a corrector,
// coded as the corrector's bit length k (one model per context) and then its
// k bits (models for the high ones, raw for the rest). Arithmetic wraps
// modulo 2^bits as LASzip's does.
class IntegerModels {
 public:
  explicit IntegerModels(std::uint32_t bits, std::uint32_t contexts, std::uint32_t bitsHigh, std::uint32_t range)
      : bitsHigh(bitsHigh) {
    if (range != 0) {
      // The corrector's significant bits for an explicit range.
      correctorRange = range;
      while (range != 0) {
        range >>= 1;
        ++correctorBits;
      }
      if (correctorRange == (1U << (correctorBits - 1))) --correctorBits;
      correctorMin = -static_cast<std::int32_t>(correctorRange / 2);
      correctorMax = static_cast<std::int32_t>(static_cast<std::uint32_t>(correctorMin) + correctorRange - 1);
    } else if (bits != 0 && bits < 32) {
      correctorBits = bits;
      correctorRange = 1U << bits;
      correctorMin = -static_cast<std::int32_t>(correctorRange / 2);
      correctorMax = static_cast<std::int32_t>(static_cast<std::uint32_t>(correctorMin) + correctorRange - 1);
    } else {
      correctorBits = 32;
      correctorRange = 0;
      correctorMin = INT32_MIN;
      correctorMax = INT32_MAX;
    }
    kModels_ = LazySymbolModels(contexts, correctorBits + 1);
    std::vector<std::uint32_t> correctorSymbols;
    for (std::uint32_t k = 1; k <= correctorBits; ++k) correctorSymbols.push_back(1U << std::min(k, bitsHigh));
    correctorModels_ = LazySymbolModels(std::move(correctorSymbols));
  }

  // All models back to their start (a new chunk). The symbol models are
  // made or reset on their first use after this: a small chunk (COPC's) uses
  // few of the dozens an integer coder has.
  void reset() {
    kModels_.startChunk();
    correctorModels_.startChunk();
    corrector0.reset();
  }

  // The model of k in a context, and of a k-bit corrector's high bits.
  SymbolModel& kModel(std::uint32_t context) { return kModels_[context]; }
  SymbolModel& correctorModel(std::uint32_t k) { return correctorModels_[k - 1]; }

  std::uint32_t bitsHigh;
  std::uint32_t correctorBits = 0, correctorRange = 0;
  std::int32_t correctorMin = 0, correctorMax = 0;
  BitModel corrector0;  // k = 0: the corrector is 0 or 1

 private:
  LazySymbolModels kModels_{0, 0};
  LazySymbolModels correctorModels_{0, 0};  // [k - 1] for k = 1 .. correctorBits
};

// LASzip's IntegerCompressor, decoding side.
class IntegerDecoder {
 public:
  explicit IntegerDecoder(std::uint32_t bits = 16, std::uint32_t contexts = 1, std::uint32_t bitsHigh = 8,
                          std::uint32_t range = 0)
      : models_(bits, contexts, bitsHigh, range) {}

  // All models back to their start (a new chunk).
  void reset() { models_.reset(); }

  std::int32_t decode(ArithmeticDecoder& decoder, std::int32_t predicted, std::uint32_t context = 0) {
    std::uint32_t real = static_cast<std::uint32_t>(predicted) +
                         static_cast<std::uint32_t>(readCorrector(decoder, context));
    if (static_cast<std::int32_t>(real) < 0) real += models_.correctorRange;
    else if (real >= models_.correctorRange) real -= models_.correctorRange;
    return static_cast<std::int32_t>(real);
  }

  // The bit length of the last corrector (LASzip uses it as a context).
  std::uint32_t k() const { return k_; }

 private:
  std::int32_t readCorrector(ArithmeticDecoder& decoder, std::uint32_t context) {
    k_ = decoder.decodeSymbol(models_.kModel(context));
    if (k_ == 0) return static_cast<std::int32_t>(decoder.decodeBit(models_.corrector0));
    if (k_ >= 32) return models_.correctorMin;
    std::uint32_t c = decoder.decodeSymbol(models_.correctorModel(k_));
    // Above bitsHigh bits, the low k - bitsHigh come raw.
    if (k_ > models_.bitsHigh) {
      const std::uint32_t lowBits = k_ - models_.bitsHigh;
      c = (c << lowBits) | decoder.readBits(lowBits);
    }
    // Back from [0, 2^k) to [-(2^k - 1), -2^(k-1)] or [2^(k-1) + 1, 2^k].
    if (c >= (1U << (k_ - 1))) return static_cast<std::int32_t>(c + 1);
    return static_cast<std::int32_t>(c - ((1U << k_) - 1));
  }

  IntegerModels models_;
  std::uint32_t k_ = 0;
};

}  // namespace apo::laz
