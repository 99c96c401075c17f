// The layout helpers of texel_layout.h, and the texel count of a texture.
#include "format/texel_layout.h"

#include "format/format.h"

namespace apo {
namespace texel {

std::uint32_t textureWidthFor(std::uint64_t usedTexels) {
  // Smallest 2^K, K >= 1, with (2^K)^2 >= used: K = ceil(log2(sqrt(used)))
  // in integers, so no rounding of a floating-point log decides the width.
  std::uint64_t width = 2;
  while (width < kMaxWidth && width * width < usedTexels) width *= 2;
  return static_cast<std::uint32_t>(width);
}

Result<std::uint32_t> broodOffset(std::uint64_t nodeTexel, std::uint64_t broodTexel) {
  APO_CHECK_OP(broodTexel, >, nodeTexel);
  const std::uint64_t offset = broodTexel - nodeTexel;
  if (offset > kMaxBroodOffset)
    return usageError(
        "the internal node at texel {} has its children at texel {}: the offset {} does not fit the 24 bits "
        "of the APO layout (at most {}); the octree is too large, lower --max-depth or raise --error",
        nodeTexel, broodTexel, offset, kMaxBroodOffset);
  return static_cast<std::uint32_t>(offset);
}

}  // namespace texel

std::uint64_t ApoTexture::usedTexels() const { return gridTexels() + leafNodes + twoSidedLeaves + 2 * internalNodes; }

}  // namespace apo
