// The layout's constants as GLSL, from texel_layout.h: the one source of
// truth for the encoder, the CPU walks and every shader that walks the
// texture (render/'s OSMesa shaders today, the report's WebGL viewer next).
#include "format/format.h"
#include "format/texel_layout.h"

#include <fmt/format.h>

#include <bit>

namespace apo {

std::string glslLayoutDefinitions() {
  return fmt::format(
      "// The APO texture layout (format/texel_layout.h, generated).\n"
      "const uint APO_EMPTY_CELL = 0x{:X}u;\n"
      "const uint APO_ENCODING_XYZ8 = {}u;\n"
      "const uint APO_ENCODING_OCT24 = {}u;\n"
      "const float APO_XYZ_MAX_LEVEL = {}.0;\n"
      "const int APO_OCT_BITS = {};\n"
      "const uint APO_OCT_MASK = 0x{:X}u;\n"
      "const float APO_OCT_MAX_LEVEL = {}.0;\n"
      "const int APO_MAX_WALK_STEPS = {};\n"
      "const uint APO_COARSE_XYZ8 = 0x{:X}u;\n"
      "const uint APO_COARSE_OCT24 = 0x{:X}u;\n",
      texel::kEmptyCell, static_cast<int>(NormalEncoding::Xyz8), static_cast<int>(NormalEncoding::Oct24),
      texel::kXyzMaxLevel, texel::kOctBits, texel::kOctMaxLevel, texel::kOctMaxLevel, texel::kMaxWalkSteps,
      texel::kCoarseXyz8, texel::kCoarseOct24);
}

std::string glslN3TreeDefinitions() {
  return fmt::format(
      "// The N^3-tree's cell kinds (format/format.h N3Tree, generated).\n"
      "const uint N3_EMPTY = {}u;\n"
      "const uint N3_POINTER = {}u;\n"
      "const uint N3_TWO_SIDED = {}u;\n"
      "const uint N3_DATA = {}u;\n"
      "const int N3_SIDES_WIDTH_SHIFT = {};\n"
      "const int N3_MAX_LEVELS = {};\n",
      N3Tree::kEmpty, N3Tree::kPointer, N3Tree::kTwoSided, N3Tree::kData, std::countr_zero(unsigned{N3Tree::kSidesWidth}),
      texel::kMaxDepth);
}

}  // namespace apo
