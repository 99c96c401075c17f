#include "format/format.h"
#include "format/octahedral.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>

namespace apo {
namespace {

using Bytes = std::array<std::uint8_t, 3>;

// Uniform on the sphere: z uniform in [-1, 1] and a uniform longitude
// (Archimedes' hat-box theorem), computed in double.
std::vector<Eigen::Vector3d> randomDirections(std::size_t count, std::uint64_t seed) {
  std::mt19937_64 random(seed);
  std::uniform_real_distribution<double> zDist(-1.0, 1.0), phiDist(0.0, 2.0 * std::numbers::pi);
  std::vector<Eigen::Vector3d> directions(count);
  for (Eigen::Vector3d& d : directions) {
    const double z = zDist(random), phi = phiDist(random), r = std::sqrt(std::max(0.0, 1.0 - z * z));
    d = {r * std::cos(phi), r * std::sin(phi), z};
  }
  return directions;
}

// Angle in radians, accurate for tiny angles (atan2 of |cross| and dot).
double angleBetween(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

double roundTripAngle(const Eigen::Vector3d& n, NormalEncoding encoding) {
  return angleBetween(n, decodeNormal(encodeNormal(n.cast<float>(), encoding), encoding).cast<double>());
}

std::vector<Eigen::Vector3d> axes() { return {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}}; }

// xyz8: each coordinate is off by at most half a step (1/255), so the stored
// point is within half a cell diagonal, sqrt(3)/255, of the unit normal, and
// the angle it subtends from the centre is at most asin(sqrt(3)/255).
const double kXyz8Bound = std::asin(std::sqrt(3.0) / 255.0);
// oct24: (u, v) is off by at most half a cell diagonal, sqrt(2)/4095. The
// unfolding moves the octahedron point by at most sqrt(3) times the (u, v)
// displacement (its z changes by |du| + |dv| <= sqrt(2) |d|), and the
// octahedron point is at least 1/sqrt(3) from the origin, so normalising
// turns a displacement e into an angle of at most sqrt(3) e: 3 sqrt(2)/4095.
const double kOct24Bound = 3.0 * std::sqrt(2.0) / 4095.0;

TEST(NormalEncoding, Names) {
  EXPECT_EQ(normalEncodingName(NormalEncoding::Xyz8), "xyz8");
  EXPECT_EQ(normalEncodingName(NormalEncoding::Oct24), "oct24");
}

TEST(NormalEncoding, Xyz8BytesByHand) {
  // round((n + 1) / 2 * 255): -1 -> 0, 0 -> round(127.5) = 128, 1 -> 255.
  EXPECT_EQ(encodeNormal({0, 0, 1}, NormalEncoding::Xyz8), (Bytes{128, 128, 255}));
  EXPECT_EQ(encodeNormal({-1, 0, 0}, NormalEncoding::Xyz8), (Bytes{0, 128, 128}));
  // 0.28 -> 163.2 -> 163, -0.96 -> 5.1 -> 5 (no ties, so float rounding
  // cannot flip them).
  EXPECT_EQ(encodeNormal({0.28f, -0.96f, 0}, NormalEncoding::Xyz8), (Bytes{163, 5, 128}));
}

TEST(NormalEncoding, Oct24BytesByHand) {
  // -z folds to the corner (1, 1): levels (4095, 4095), all 24 bits set.
  EXPECT_EQ(encodeNormal({0, 0, -1}, NormalEncoding::Oct24), (Bytes{0xFF, 0xFF, 0xFF}));
  // (1, 1, 1)/sqrt(3) projects to (1/3, 1/3): level (4/3) / 2 * 4095 = 2730
  // = 0xAAA; bits 0xAAA | 0xAAA << 12 = 0xAAAAAA.
  const Vec3f diagonal = Vec3f(1, 1, 1).normalized();
  EXPECT_EQ(encodeNormal(diagonal, NormalEncoding::Oct24), (Bytes{0xAA, 0xAA, 0xAA}));
  EXPECT_EQ(octahedral::encodeRounded(diagonal), (Bytes{0xAA, 0xAA, 0xAA}));
  // u = 1 (level 4095, bits 0-11), v = -1 (level 0, bits 12-23): B = 0, the
  // top nibble of G = 0. (1, -1) is a corner: -z again.
  const Vec3f decoded = decodeNormal({0xFF, 0x0F, 0x00}, NormalEncoding::Oct24);
  EXPECT_NEAR(decoded.z(), -1.0f, 1e-6f);
  // Level 2730 in u only, 0x800 = 2048 in v: u = 1/3, v = 1/4095.
  const Vec3f mixed = decodeNormal({0xAA, 0x0A, 0x80}, NormalEncoding::Oct24);
  const Vec3f expected = Vec3f(1.0f / 3.0f, 1.0f / 4095.0f, 1.0f - 1.0f / 3.0f - 1.0f / 4095.0f).normalized();
  EXPECT_LT((mixed - expected).norm(), 1e-6f);
}

TEST(NormalEncoding, AxesRoundTripWithinTheQuantisationBound) {
  for (NormalEncoding encoding : {NormalEncoding::Xyz8, NormalEncoding::Oct24}) {
    const double bound = encoding == NormalEncoding::Xyz8 ? kXyz8Bound : kOct24Bound;
    for (const Eigen::Vector3d& axis : axes()) {
      const Bytes bytes = encodeNormal(axis.cast<float>(), encoding);
      EXPECT_LT(roundTripAngle(axis, encoding), bound) << normalEncodingName(encoding) << " " << axis.transpose();
      // Re-encoding the decoded normal is stable.
      EXPECT_EQ(encodeNormal(decodeNormal(bytes, encoding), encoding), bytes) << axis.transpose();
    }
  }
}

TEST(NormalEncoding, EveryCodeDecodesToAUnitVector) {
  // All 2^24 byte triples, for both encodings.
  for (NormalEncoding encoding : {NormalEncoding::Xyz8, NormalEncoding::Oct24}) {
    float worst = 0.0f;
    for (std::uint32_t bits = 0; bits < (1u << 24); ++bits) {
      const Vec3f n = decodeNormal({static_cast<std::uint8_t>(bits), static_cast<std::uint8_t>(bits >> 8),
                                    static_cast<std::uint8_t>(bits >> 16)},
                                   encoding);
      const float error = std::abs(n.norm() - 1.0f);
      if (!(error <= worst)) worst = error;  // NaN propagates into worst
    }
    EXPECT_LT(worst, 1e-6f) << normalEncodingName(encoding);
  }
}

TEST(NormalEncoding, RandomDirectionsStayWithinTheQuantisationBounds) {
  double worstXyz8 = 0, worstRounded = 0, worstPrecise = 0, sumRounded = 0, sumPrecise = 0;
  const std::vector<Eigen::Vector3d> directions = randomDirections(200000, 7);
  for (const Eigen::Vector3d& n : directions) {
    const double rounded = angleBetween(
        n, decodeNormal(octahedral::encodeRounded(n.cast<float>()), NormalEncoding::Oct24).cast<double>());
    const double precise = roundTripAngle(n, NormalEncoding::Oct24);
    // The precise encoder tries the rounded levels among its candidates and
    // ranks them by their exact decoding, so against the float direction it
    // was given it is never worse, up to the float decode's own error (the
    // levels' coordinates are rounded to ~6e-8, up to ~2.5e-7 rad per vector).
    const Eigen::Vector3d given = n.cast<float>().normalized().cast<double>();
    ASSERT_LE(roundTripAngle(given, NormalEncoding::Oct24),
              angleBetween(given, decodeNormal(octahedral::encodeRounded(n.cast<float>()), NormalEncoding::Oct24)
                                      .cast<double>()) +
                  5e-7)
        << n.transpose();
    worstXyz8 = std::max(worstXyz8, roundTripAngle(n, NormalEncoding::Xyz8));
    worstRounded = std::max(worstRounded, rounded);
    worstPrecise = std::max(worstPrecise, precise);
    sumRounded += rounded;
    sumPrecise += precise;
  }
  EXPECT_LT(worstXyz8, kXyz8Bound);
  EXPECT_LT(worstRounded, kOct24Bound);
  EXPECT_LE(worstPrecise, worstRounded);
  EXPECT_LT(sumPrecise, sumRounded);
  // 4096 levels on [-1, 1] against 256: "well below" is a factor 4 here.
  EXPECT_LT(worstPrecise, worstXyz8 / 4);
}

TEST(NormalEncoding, NearTheFoldAndTheEquator) {
  // The fold of the lower hemisphere and the octahedron's edges are where
  // sign(0) and the clamping matter.
  for (const float z : {0.0f, 1e-7f, -1e-7f, 1e-3f, -1e-3f}) {
    for (int i = 0; i < 360; ++i) {
      const double phi = i * std::numbers::pi / 180.0;
      const Eigen::Vector3d n = Eigen::Vector3d(std::cos(phi), std::sin(phi), z).normalized();
      EXPECT_LT(roundTripAngle(n, NormalEncoding::Oct24), kOct24Bound) << n.transpose();
      EXPECT_LT(roundTripAngle(n, NormalEncoding::Xyz8), kXyz8Bound) << n.transpose();
    }
  }
}

TEST(NormalEncoding, OnlyTheDirectionIsEncoded) {
  const Vec3f n = Vec3f(0.3f, -0.5f, 0.8f).normalized();
  for (NormalEncoding encoding : {NormalEncoding::Xyz8, NormalEncoding::Oct24}) {
    EXPECT_EQ(encodeNormal(3.0f * n, encoding), encodeNormal(n, encoding));
    // No direction (a cell whose normals cancel): +z, still unit on decode.
    const Vec3f none = decodeNormal(encodeNormal(Vec3f::Zero(), encoding), encoding);
    EXPECT_GT(none.z(), 0.999f);
    EXPECT_NEAR(none.norm(), 1.0f, 1e-6f);
  }
}

}  // namespace
}  // namespace apo
