// Internal to ingest: LASzip's per-item point decoders (the "items" of the
// LASzip VLR), each turning compressed bytes back into its part of a raw LAS
// point record. Ported from LASzip's lasreaditemcompressed_v1.cpp, _v2.cpp
// and _v3.cpp; they must match LASzip bit for bit.
#pragma once

#include "ingest/laz_arithmetic.h"

#include <cstdint>
#include <memory>
#include <span>
#include <stdexcept>
#include <string_view>

namespace apo::laz {

// Item types of the LASzip VLR (laszip.hpp, LASitem::Type).
enum class ItemType : std::uint16_t {
  Byte = 0,           // extra bytes, compressors 1 and 2
  Point10 = 6,        // the 20 bytes of point formats 0 to 5
  GpsTime11 = 7,      // 8 bytes
  Rgb12 = 8,          // 6 bytes
  WavePacket13 = 9,   // 29 bytes
  Point14 = 10,       // the 30 bytes of point formats 6 to 10 (GPS time inside)
  Rgb14 = 11,         // 6 bytes
  RgbNir14 = 12,      // 8 bytes
  WavePacket14 = 13,  // 29 bytes
  Byte14 = 14,        // extra bytes, compressor 3
};

struct Item {
  ItemType type;
  std::uint16_t size;     // bytes of the record it decodes
  std::uint16_t version;  // its coding's version
};

// The item's name in LASzip's terms ("POINT10", "BYTE14"; "type N" if unknown).
std::string_view itemName(std::uint16_t type);

// Compressed data whose symbols cannot come from any LASzip writer; the chunk
// decoder adds where it happened.
struct CorruptStream : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// One item of compressors 1 and 2: all the items of a point share one
// arithmetic decoder, which starts after the chunk's first point (stored raw).
class PointwiseItemDecoder {
 public:
  virtual ~PointwiseItemDecoder() = default;
  // A new chunk whose first point holds `first` (item.size raw bytes).
  virtual void startChunk(const std::uint8_t* first) = 0;
  // The next point's item.size bytes into `out`.
  virtual void decode(ArithmeticDecoder& decoder, std::uint8_t* out) = 0;
};

// Whether we decode the item's type and version: for compressors 1 and 2
// (pointwise) POINT10, GPSTIME11, RGB12 and BYTE, versions 1 and 2; for
// compressor 3 (layered) POINT14, RGB14, RGBNIR14 and BYTE14 version 3.
// Cheap, unlike building the decoder, whose models a BYTE item of 65,535
// bytes makes by the thousand.
bool decodable(const Item& item, bool layered);

// Null unless decodable(item, false).
std::unique_ptr<PointwiseItemDecoder> makePointwiseItemDecoder(const Item& item);

// One item of compressor 3 (LAS 1.4 layered chunks): its fields are split in
// layers of their own, each with its own arithmetic decoder; POINT14 reads the
// scanner channel into `channel` and the items after it code per channel.
class LayeredItemDecoder {
 public:
  virtual ~LayeredItemDecoder() = default;
  // How many layers (and byte counts in the chunk's header) the item has.
  virtual std::size_t layerCount() const = 0;
  // A new chunk: `first` is the item's raw bytes of the chunk's first point,
  // `layers` its layers' bytes (layerCount() spans, each possibly empty).
  virtual void startChunk(const std::uint8_t* first, std::span<const std::span<const std::uint8_t>> layers,
                          unsigned& channel) = 0;
  virtual void decode(std::uint8_t* out, unsigned& channel) = 0;
  // Whether a layer's decoder read past the layer's bytes.
  virtual bool overran() const = 0;
};

// Null unless decodable(item, true).
std::unique_ptr<LayeredItemDecoder> makeLayeredItemDecoder(const Item& item);

}  // namespace apo::laz
