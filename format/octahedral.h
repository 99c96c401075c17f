// Internal to format/: the octahedral map behind NormalEncoding::Oct24, exposed
// so the quantisation benchmark (bench/normal_quantization.cpp) can compare
// the plain-rounding encoder with the precise one encodeNormal uses.
#pragma once

#include "core/geometry.h"

#include <array>
#include <cstdint>

namespace apo::octahedral {

// Oct24 bytes of `normal` with each coordinate rounded to the nearest of the
// 4096 levels (Cigolle et al. 2014's plain encoder).
std::array<std::uint8_t, 3> encodeRounded(const Vec3f& normal);

}  // namespace apo::octahedral
