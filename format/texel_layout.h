// Internal to format/: the limits and texel accessors of the APO texture layout
// (docs/apo-format.md), shared by the encoder, the decoder, the
// lookups, the file reader and the GLSL definitions, so none can disagree.
#pragma once

#include "core/error.h"

#include <array>
#include <cstdint>
#include <vector>

namespace apo::texel {

// A grid entry for a cell that holds no node.
inline constexpr std::uint32_t kEmptyCell = 0xFFFFFFFFu;
// Relative offsets to a child brood are stored on 3 bytes (paper section 4).
inline constexpr std::uint64_t kMaxBroodOffset = (std::uint64_t{1} << 24) - 1;
// Texel indices are stored on 4 bytes, kEmptyCell excluded.
inline constexpr std::uint64_t kMaxUsedTexels = kEmptyCell;
// 8^10 grid entries is already 4 GiB of texture.
inline constexpr int kMaxCompleteDepth = 10;
// Cell centres stay exact in float down to depth 23; 20 keeps a margin.
inline constexpr int kMaxDepth = 20;
// The usual limit of a 2D texture's side on GPUs.
inline constexpr std::uint32_t kMaxWidth = 16384;

// Normal encodings (docs/apo-format.md): xyz8 stores (n + 1) / 2 * 255 per
// axis; oct24 stores the octahedral coordinates' levels qu | qv << 12.
inline constexpr int kXyzMaxLevel = 255;
inline constexpr int kOctBits = 12;
inline constexpr int kOctMaxLevel = (1 << kOctBits) - 1;

// Format version 3: the normal bytes that mean "m's own interpolated normal"
// (OctreeNode::coarseNormal). Codes no unit normal is encoded to: xyz8
// (128, 128, 128) would need every coordinate within 0.01 of 0; oct24
// (qu 4095, qv 0) decodes to -z, which the encoder writes as (4095, 4095).
inline constexpr std::uint32_t kCoarseXyz8 = 0x808080u;
inline constexpr std::uint32_t kCoarseOct24 = 0x000FFFu;
inline std::uint32_t coarseCode(bool xyz8) { return xyz8 ? kCoarseXyz8 : kCoarseOct24; }

// A walk visits the grid's node and at most one node per level below it.
inline constexpr int kMaxWalkSteps = kMaxDepth + 1;

// Texture width for `usedTexels`: 2^K with K = ceil(log2(sqrt(used))), at
// least 1, so the texture is close to square; capped at kMaxWidth.
std::uint32_t textureWidthFor(std::uint64_t usedTexels);
// Rows needed for `usedTexels` at `width`.
inline std::uint64_t rowsFor(std::uint64_t usedTexels, std::uint32_t width) {
  return (usedTexels + width - 1) / width;
}

// The relative offset from an internal node's first texel to its children's
// brood, or a Usage error when it does not fit the 3 bytes of the layout.
Result<std::uint32_t> broodOffset(std::uint64_t nodeTexel, std::uint64_t broodTexel);

// Channel access to texel `index` of a row-major RGBA8 buffer. The caller
// checks that the texel lies inside the buffer.
inline std::uint8_t alpha(const std::vector<std::uint8_t>& texels, std::uint64_t index) {
  return texels[4 * index + 3];
}
inline std::array<std::uint8_t, 3> rgb(const std::vector<std::uint8_t>& texels, std::uint64_t index) {
  return {texels[4 * index], texels[4 * index + 1], texels[4 * index + 2]};
}
// RGB as a 24-bit little-endian integer (R lowest byte).
inline std::uint32_t rgb24(const std::vector<std::uint8_t>& texels, std::uint64_t index) {
  const std::uint64_t at = 4 * index;
  return std::uint32_t{texels[at]} | std::uint32_t{texels[at + 1]} << 8 | std::uint32_t{texels[at + 2]} << 16;
}
// RGBA as a 32-bit little-endian integer (R lowest byte): a grid entry.
inline std::uint32_t rgba32(const std::vector<std::uint8_t>& texels, std::uint64_t index) {
  return rgb24(texels, index) | std::uint32_t{alpha(texels, index)} << 24;
}

}  // namespace apo::texel
