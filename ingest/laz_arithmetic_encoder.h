// Internal to ingest: the entropy coding under LAZ (LASzip) point
// compression, encoding side: the exact mirror of laz_arithmetic.h's
// ArithmeticDecoder and IntegerDecoder, bit-exact with LASzip's
// arithmeticencoder.cpp and integercompressor.cpp (compress), on the same
// models (BitModel, SymbolModel, IntegerModels).
//
// Unlike LASzip's, this encoder appends to a string instead of a ring buffer
// flushed to a stream: a carry then runs back over the bytes already
// appended, never past the first byte of the encoder's span (the interval
// never leaves [0, 2^32) of the span's value).
#pragma once

#include "ingest/laz_arithmetic.h"

#include <cstdint>
#include <string>

namespace apo::laz {

class ArithmeticEncoder {
 public:
  // Starts a new span of compressed bytes at the end of `out`.
  void start(std::string& out) {
    out_ = &out;
    begin_ = out.size();
    base_ = 0;
    length_ = kMaxLength;
  }

  // Ends the span: the bytes that pin the final interval, then the two or
  // three zeros that make the decoder's reads end exactly at the span's end
  // (LASzip's done(), so chunks can be read one after another without a table).
  void finish() {
    const std::uint32_t initBase = base_;
    bool anotherByte = true;
    if (length_ > 2 * kMinLength) {
      base_ += kMinLength;
      length_ = kMinLength >> 1;  // one more byte
    } else {
      base_ += kMinLength >> 1;
      length_ = kMinLength >> 9;  // two more bytes
      anotherByte = false;
    }
    if (initBase > base_) propagateCarry();
    renormalize();
    out_->append(anotherByte ? 3 : 2, '\0');
    out_ = nullptr;
  }

  void encodeBit(BitModel& m, std::uint32_t bit) {
    const std::uint32_t x = m.bit0Probability_ * (length_ >> kBitLengthShift);
    if (bit == 0) {
      length_ = x;
      ++m.bit0Count_;
    } else {
      addToBase(x);
      length_ -= x;
    }
    if (length_ < kMinLength) renormalize();
    if (--m.bitsUntilUpdate_ == 0) m.update();
  }

  void encodeSymbol(SymbolModel& m, std::uint32_t symbol) {
    std::uint32_t x;
    if (symbol == m.lastSymbol_) {
      // The last symbol takes the rest of the interval (no product).
      x = m.distribution_[symbol] * (length_ >> kSymbolLengthShift);
      addToBase(x);
      length_ -= x;
    } else {
      x = m.distribution_[symbol] * (length_ >>= kSymbolLengthShift);
      addToBase(x);
      length_ = m.distribution_[symbol + 1] * length_ - x;
    }
    if (length_ < kMinLength) renormalize();
    ++m.symbolCount_[symbol];
    if (--m.symbolsUntilUpdate_ == 0) m.update();
  }

  // Raw bits (no model): the low `bits` (1 to 32) of `value`.
  void writeBits(std::uint32_t bits, std::uint32_t value) {
    if (bits > 19) {
      writeShort(value & 0xFFFF);
      value >>= 16;
      bits -= 16;
    }
    addToBase(value * (length_ >>= bits));
    if (length_ < kMinLength) renormalize();
  }
  void writeShort(std::uint32_t value) {
    addToBase(value * (length_ >>= 16));
    if (length_ < kMinLength) renormalize();
  }
  void writeInt(std::uint32_t value) {
    writeShort(value & 0xFFFF);
    writeShort(value >> 16);
  }

 private:
  // base += x, carrying into the bytes already out when it wraps.
  void addToBase(std::uint32_t x) {
    const std::uint32_t initBase = base_;
    base_ += x;
    if (initBase > base_) propagateCarry();
  }

  void propagateCarry() {
    std::size_t at = out_->size();
    while (at > begin_ && static_cast<std::uint8_t>((*out_)[at - 1]) == 0xFF) (*out_)[--at] = '\0';
    if (at > begin_) ++(*out_)[at - 1];
  }

  // Outputs the top byte while the interval is too short.
  void renormalize() {
    do {
      out_->push_back(static_cast<char>(base_ >> 24));
      base_ <<= 8;
    } while ((length_ <<= 8) < kMinLength);
  }

  std::string* out_ = nullptr;
  std::size_t begin_ = 0;
  std::uint32_t base_ = 0, length_ = 0;
};

// LASzip's IntegerCompressor, encoding side.
class IntegerEncoder {
 public:
  explicit IntegerEncoder(std::uint32_t bits = 16, std::uint32_t contexts = 1, std::uint32_t bitsHigh = 8,
                          std::uint32_t range = 0)
      : models_(bits, contexts, bitsHigh, range) {}

  // All models back to their start (a new chunk).
  void reset() { models_.reset(); }

  void encode(ArithmeticEncoder& encoder, std::int32_t predicted, std::int32_t real, std::uint32_t context = 0) {
    // The corrector, folded into [correctorMin, correctorMax] (modulo 2^bits).
    auto corrector = static_cast<std::int32_t>(static_cast<std::uint32_t>(real) - static_cast<std::uint32_t>(predicted));
    if (corrector < models_.correctorMin)
      corrector = static_cast<std::int32_t>(static_cast<std::uint32_t>(corrector) + models_.correctorRange);
    else if (corrector > models_.correctorMax)
      corrector = static_cast<std::int32_t>(static_cast<std::uint32_t>(corrector) - models_.correctorRange);
    writeCorrector(encoder, corrector, context);
  }

  // The bit length of the last corrector (LASzip uses it as a context).
  std::uint32_t k() const { return k_; }

 private:
  void writeCorrector(ArithmeticEncoder& encoder, std::int32_t c, std::uint32_t context) {
    // The tightest [-(2^k - 1), 2^k] holding c.
    const auto c32 = static_cast<std::uint32_t>(c);
    std::uint32_t magnitude = c <= 0 ? 0U - c32 : c32 - 1;
    k_ = 0;
    while (magnitude != 0) {
      magnitude >>= 1;
      ++k_;
    }
    encoder.encodeSymbol(models_.kModel(context), k_);
    if (k_ == 0) {
      encoder.encodeBit(models_.corrector0, c32);
      return;
    }
    if (k_ >= 32) return;
    // To [0, 2^k): [-(2^k - 1), -2^(k-1)] up by 2^k - 1, [2^(k-1) + 1, 2^k] down by 1.
    const std::uint32_t shifted = c < 0 ? c32 + ((1U << k_) - 1) : c32 - 1;
    if (k_ <= models_.bitsHigh) {
      encoder.encodeSymbol(models_.correctorModel(k_), shifted);
      return;
    }
    // Above bitsHigh bits, the high ones modelled and the low k - bitsHigh raw.
    const std::uint32_t lowBits = k_ - models_.bitsHigh;
    encoder.encodeSymbol(models_.correctorModel(k_), shifted >> lowBits);
    encoder.writeBits(lowBits, shifted & ((1U << lowBits) - 1));
  }

  IntegerModels models_;
  std::uint32_t k_ = 0;
};

}  // namespace apo::laz
