// Unit normals on three bytes (format.h). xyz8 quantises each coordinate to 8
// bits. oct24 is the octahedral map of Cigolle et al. 2014, "A Survey of
// Efficient Representations for Independent Unit Vectors" (JCGT 3(2)),
// with 12 bits per coordinate and their "precise" encoder, which tries the
// four floor/ceil neighbours and keeps the one that decodes closest in angle:
// it costs four decodes per normal at bake time and nothing at render time.
// docs/apo-format.md gives the decoding formulas a shader must use.
#include "format/format.h"
#include "format/octahedral.h"
#include "format/texel_layout.h"

#include <algorithm>
#include <cmath>

namespace apo {
namespace {

using texel::kOctBits;
using texel::kOctMaxLevel;
using texel::kXyzMaxLevel;

// The direction to encode. A zero or non-finite vector (an internal cell
// whose children's normals cancel) has no direction; it encodes as +z so the
// decoded normal is still unit length.
Vec3f directionOf(const Vec3f& normal) {
  const float length = normal.norm();
  if (!(length > 0.0f) || !std::isfinite(length)) return Vec3f::UnitZ();
  return normal / length;
}

// sign() with sign(0) = +1, as the octahedral fold needs: without it points
// on the axes planes would fold onto the origin.
template <class T>
T signNotZero(T x) {
  return x >= T(0) ? T(1) : T(-1);
}

// Octahedral coordinates in [-1, 1]^2 of a unit vector: project onto the
// octahedron |x| + |y| + |z| = 1, then fold the lower half over the upper.
std::array<float, 2> octahedralOf(const Vec3f& n) {
  const float l1 = std::abs(n.x()) + std::abs(n.y()) + std::abs(n.z());
  float u = n.x() / l1, v = n.y() / l1;
  if (n.z() < 0.0f) {
    const float foldedU = (1.0f - std::abs(v)) * signNotZero(u);
    v = (1.0f - std::abs(u)) * signNotZero(v);
    u = foldedU;
  }
  return {u, v};
}

// The point of the octahedron for coordinates (u, v), not normalised; T is
// float for decodeNormal and double to compare candidates precisely.
template <class T>
Eigen::Matrix<T, 3, 1> unfoldOctahedral(T u, T v) {
  Eigen::Matrix<T, 3, 1> p(u, v, T(1) - std::abs(u) - std::abs(v));
  if (p.z() < T(0)) {
    p.x() = (T(1) - std::abs(v)) * signNotZero(u);
    p.y() = (T(1) - std::abs(u)) * signNotZero(v);
  }
  return p;
}

// Coordinate of quantisation level q: q / 4095 * 2 - 1.
template <class T>
T octCoordinate(int q) {
  return static_cast<T>(q) / static_cast<T>(kOctMaxLevel) * T(2) - T(1);
}

// Fractional level of a coordinate in [-1, 1]: (u + 1) / 2 * 4095.
float octLevel(float u) { return (u + 1.0f) / 2.0f * static_cast<float>(kOctMaxLevel); }

int clampLevel(long level, int maxLevel) { return static_cast<int>(std::clamp(level, 0L, long{maxLevel})); }

// 24 bits = qu | qv << 12, bytes in little-endian order.
std::array<std::uint8_t, 3> packOct24(int qu, int qv) {
  const std::uint32_t bits = static_cast<std::uint32_t>(qu) | static_cast<std::uint32_t>(qv) << kOctBits;
  return {static_cast<std::uint8_t>(bits & 0xFF), static_cast<std::uint8_t>((bits >> 8) & 0xFF),
          static_cast<std::uint8_t>(bits >> 16)};
}

// Cosine of the angle between `n` (unit) and the direction levels (qu, qv)
// decode to, in double: at 12 bits the candidates' cosines differ by about
// 1e-9, below float resolution near 1.
double cosineToLevels(const Eigen::Vector3d& n, int qu, int qv) {
  const Eigen::Vector3d p = unfoldOctahedral(octCoordinate<double>(qu), octCoordinate<double>(qv));
  return n.dot(p) / p.norm();
}

std::array<std::uint8_t, 3> encodeOct24Precise(const Vec3f& normal) {
  const Vec3f n = directionOf(normal);
  const auto [u, v] = octahedralOf(n);
  const float levelU = octLevel(u), levelV = octLevel(v);
  const int floorU = clampLevel(std::lround(std::floor(levelU)), kOctMaxLevel);
  const int floorV = clampLevel(std::lround(std::floor(levelV)), kOctMaxLevel);
  const Eigen::Vector3d target = n.cast<double>().normalized();
  int bestU = floorU, bestV = floorV;
  double bestCosine = -2.0;
  // Ties keep the first candidate, so the bytes are deterministic.
  for (int du = 0; du <= 1; ++du) {
    for (int dv = 0; dv <= 1; ++dv) {
      const int qu = std::min(floorU + du, kOctMaxLevel), qv = std::min(floorV + dv, kOctMaxLevel);
      const double cosine = cosineToLevels(target, qu, qv);
      if (cosine > bestCosine) {
        bestCosine = cosine;
        bestU = qu;
        bestV = qv;
      }
    }
  }
  // (4095, 0) decodes to -z like (4095, 4095): it is kept for version 3's
  // "m's own normal" (texel_layout.h).
  if (bestU == kOctMaxLevel && bestV == 0) bestV = kOctMaxLevel;
  return packOct24(bestU, bestV);
}

Vec3f decodeOct24(const std::array<std::uint8_t, 3>& bytes) {
  const std::uint32_t bits =
      std::uint32_t{bytes[0]} | std::uint32_t{bytes[1]} << 8 | std::uint32_t{bytes[2]} << 16;
  const int qu = static_cast<int>(bits & kOctMaxLevel), qv = static_cast<int>(bits >> kOctBits);
  // Never zero: |x| + |y| + |z| >= 1 on the octahedron.
  return unfoldOctahedral(octCoordinate<float>(qu), octCoordinate<float>(qv)).normalized();
}

std::array<std::uint8_t, 3> encodeXyz8(const Vec3f& normal) {
  const Vec3f n = directionOf(normal);
  std::array<std::uint8_t, 3> bytes{};
  for (int axis = 0; axis < 3; ++axis) {
    const float level = (n[axis] + 1.0f) / 2.0f * static_cast<float>(kXyzMaxLevel);
    bytes[axis] = static_cast<std::uint8_t>(clampLevel(std::lround(level), kXyzMaxLevel));
  }
  return bytes;
}

Vec3f decodeXyz8(const std::array<std::uint8_t, 3>& bytes) {
  Vec3f n;
  for (int axis = 0; axis < 3; ++axis)
    n[axis] = static_cast<float>(bytes[axis]) / static_cast<float>(kXyzMaxLevel) * 2.0f - 1.0f;
  // Never zero: 255 is odd, so no byte decodes to 0.
  return n.normalized();
}

}  // namespace

std::string normalEncodingName(NormalEncoding encoding) {
  switch (encoding) {
    case NormalEncoding::Xyz8: return "xyz8";
    case NormalEncoding::Oct24: return "oct24";
  }
  return fmt::format("unknown({})", static_cast<int>(encoding));
}

std::array<std::uint8_t, 3> encodeNormal(const Vec3f& normal, NormalEncoding encoding) {
  switch (encoding) {
    case NormalEncoding::Xyz8: return encodeXyz8(normal);
    case NormalEncoding::Oct24: return encodeOct24Precise(normal);
  }
  APO_CHECK(!"unknown NormalEncoding");
  return {};
}

Vec3f decodeNormal(const std::array<std::uint8_t, 3>& bytes, NormalEncoding encoding) {
  switch (encoding) {
    case NormalEncoding::Xyz8: return decodeXyz8(bytes);
    case NormalEncoding::Oct24: return decodeOct24(bytes);
  }
  APO_CHECK(!"unknown NormalEncoding");
  return Vec3f::UnitZ();
}

namespace octahedral {

std::array<std::uint8_t, 3> encodeRounded(const Vec3f& normal) {
  const auto [u, v] = octahedralOf(directionOf(normal));
  return packOct24(clampLevel(std::lround(octLevel(u)), kOctMaxLevel),
                   clampLevel(std::lround(octLevel(v)), kOctMaxLevel));
}

}  // namespace octahedral
}  // namespace apo
