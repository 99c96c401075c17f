// render/metrics.cpp against analytic ground truth: normals rotated by known
// angles, images offset by known amounts (MAE, PSNR and the SSIM luminance
// term in closed form), rectangles whose overlap is known, the published
// viridis colours, and a PNG decoded by stb_image.
#include "render/render.h"
#include "tests/test_support.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <numeric>
#include <random>

#define STB_IMAGE_STATIC
#define STB_IMAGE_IMPLEMENTATION
#include <stb/stb_image.h>

namespace apo {
namespace {

namespace fs = std::filesystem;

constexpr double kInfinity = std::numeric_limits<double>::infinity();
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
// Wang et al. 2004 with L = 255.
constexpr double kC1 = 6.5025, kC2 = 58.5225;

NormalBuffer emptyBuffer(int width, int height) {
  NormalBuffer buffer;
  buffer.width = width;
  buffer.height = height;
  buffer.data.assign(static_cast<std::size_t>(width) * height * 4, 0.0f);
  return buffer;
}

void setNormal(NormalBuffer& buffer, std::size_t pixel, const Eigen::Vector3d& normal, bool covered = true) {
  for (int c = 0; c < 3; ++c) buffer.data[4 * pixel + c] = static_cast<float>(normal[c]);
  buffer.data[4 * pixel + 3] = covered ? 1.0f : 0.0f;
}

// Coverage of the pixels (x, y) with x0 <= x < x1 and y0 <= y < y1.
NormalBuffer rectangleCoverage(int width, int height, int x0, int y0, int x1, int y1) {
  NormalBuffer buffer = emptyBuffer(width, height);
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x) setNormal(buffer, static_cast<std::size_t>(y) * width + x, {0, 0, 1});
  return buffer;
}

NormalBuffer fullCoverage(int width, int height) { return rectangleCoverage(width, height, 0, 0, width, height); }

Image uniformImage(int width, int height, std::array<std::uint8_t, 3> rgb) {
  Image image;
  image.width = width;
  image.height = height;
  image.rgba.resize(static_cast<std::size_t>(width) * height * 4);
  for (std::size_t p = 0; p < image.rgba.size() / 4; ++p) {
    std::copy(rgb.begin(), rgb.end(), image.rgba.begin() + static_cast<std::ptrdiff_t>(4 * p));
    image.rgba[4 * p + 3] = 255;
  }
  return image;
}

Image randomImage(int width, int height, int low, int high, std::uint32_t seed) {
  std::mt19937 random(seed);
  std::uniform_int_distribution<int> value(low, high);
  Image image = uniformImage(width, height, {0, 0, 0});
  for (auto& byte : image.rgba) byte = static_cast<std::uint8_t>(value(random));
  return image;
}

Eigen::Vector3d randomUnitVector(std::mt19937& random) {
  std::normal_distribution<double> gauss;
  const Eigen::Vector3d v(gauss(random), gauss(random), gauss(random));
  return v.normalized();
}

double degreesToRadians(double degrees) { return degrees * std::numbers::pi / 180.0; }

// The SSIM of two constant windows x = mean, y = mean + offset: both
// variances and the covariance vanish, so the structure term is C2 / C2 and
// only the luminance term (2 mx my + C1) / (mx^2 + my^2 + C1) remains.
double constantOffsetSsim(double mean, double offset) {
  const double other = mean + offset;
  return (2.0 * mean * other + kC1) / (mean * mean + other * other + kC1);
}

// ---- Angular error ----------------------------------------------------------

// Pixel k (1..40, in shuffled order over an 8 x 5 buffer) holds a random unit
// reference normal and the test normal rotated from it by k^2/20 degrees
// about a random perpendicular axis, both at random non-unit lengths.
TEST(AngularErrors, KnownRotationsGiveExactStatistics) {
  constexpr int kWidth = 8, kHeight = 5, kCount = kWidth * kHeight;
  std::mt19937 random(5);
  std::vector<int> rank(kCount);
  std::iota(rank.begin(), rank.end(), 1);
  std::shuffle(rank.begin(), rank.end(), random);
  std::uniform_real_distribution<double> length(0.1, 10.0);
  NormalBuffer test = emptyBuffer(kWidth, kHeight), reference = emptyBuffer(kWidth, kHeight);
  std::vector<double> expected(kCount);
  for (std::size_t p = 0; p < kCount; ++p) {
    expected[p] = rank[p] * rank[p] / 20.0;
    const Eigen::Vector3d normal = randomUnitVector(random);
    const Eigen::Vector3d axis = normal.cross(randomUnitVector(random)).normalized();
    const Eigen::Vector3d rotated = Eigen::AngleAxisd(degreesToRadians(expected[p]), axis) * normal;
    setNormal(reference, p, normal * length(random));
    setNormal(test, p, rotated * length(random));
  }

  std::vector<float> perPixel;
  const AngularStats stats = angularErrors(test, reference, &perPixel);
  // k^2/20 over k = 1..40: the sum of squares 40*41*81/6 = 22140.
  EXPECT_EQ(stats.pixels, 40u);
  EXPECT_NEAR(stats.mean, 22140.0 / 20.0 / 40.0, 1e-5);
  EXPECT_NEAR(stats.median, (20.0 * 20.0 + 21.0 * 21.0) / 2.0 / 20.0, 1e-5);
  EXPECT_NEAR(stats.p95, 38.0 * 38.0 / 20.0, 1e-5);  // rank ceil(0.95 * 40) = 38
  EXPECT_NEAR(stats.max, 40.0 * 40.0 / 20.0, 1e-5);
  ASSERT_EQ(perPixel.size(), static_cast<std::size_t>(kCount));
  for (std::size_t p = 0; p < kCount; ++p) EXPECT_NEAR(perPixel[p], expected[p], 1e-5) << "pixel " << p;
}

TEST(AngularErrors, ComparesOnlyPixelsCoveredByBoth) {
  // Test covers columns 0..2, reference rows 0..2 of a 4 x 4 buffer: 9 shared.
  NormalBuffer test = emptyBuffer(4, 4), reference = emptyBuffer(4, 4);
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 4; ++x) {
      const std::size_t p = static_cast<std::size_t>(y) * 4 + x;
      // Uncovered pixels hold opposite normals: counted, they would read 180.
      setNormal(test, p, {0, 0, 1}, x < 3);
      setNormal(reference, p, x < 3 && y < 3 ? Eigen::Vector3d(0, 1, 1) : Eigen::Vector3d(0, 0, -1), y < 3);
    }
  std::vector<float> perPixel;
  const AngularStats stats = angularErrors(test, reference, &perPixel);
  EXPECT_EQ(stats.pixels, 9u);
  EXPECT_NEAR(stats.mean, 45.0, 1e-5);
  EXPECT_NEAR(stats.max, 45.0, 1e-5);
  for (int y = 0; y < 4; ++y)
    for (int x = 0; x < 4; ++x) {
      const float angle = perPixel[static_cast<std::size_t>(y) * 4 + x];
      if (x < 3 && y < 3)
        EXPECT_NEAR(angle, 45.0, 1e-5);
      else
        EXPECT_TRUE(std::isnan(angle)) << x << ", " << y;
    }
}

TEST(AngularErrors, IdenticalPerpendicularAndOppositeNormals) {
  NormalBuffer test = emptyBuffer(3, 1), reference = emptyBuffer(3, 1);
  setNormal(test, 0, {0.3, -2.0, 0.7});
  setNormal(reference, 0, {0.6, -4.0, 1.4});  // the same direction, twice as long
  setNormal(test, 1, {5, 0, 0});
  setNormal(reference, 1, {0, 0, 0.2});
  setNormal(test, 2, {1, 2, 3});
  setNormal(reference, 2, {-2, -4, -6});
  std::vector<float> perPixel;
  const AngularStats stats = angularErrors(test, reference, &perPixel);
  EXPECT_NEAR(perPixel[0], 0.0, 1e-5);
  EXPECT_NEAR(perPixel[1], 90.0, 1e-5);
  EXPECT_NEAR(perPixel[2], 180.0, 1e-5);
  EXPECT_NEAR(stats.median, 90.0, 1e-5);
  EXPECT_NEAR(stats.max, 180.0, 1e-5);
}

// 1e-5 degrees: acos of the (double) dot product would be off by about
// 0.4 % here, 1e-16 / sin(angle) radians.
TEST(AngularErrors, KeepsRelativePrecisionAtTinyAngles) {
  NormalBuffer test = emptyBuffer(1, 1), reference = emptyBuffer(1, 1);
  const double angle = degreesToRadians(1e-5);
  setNormal(reference, 0, {0, 0, 1});
  setNormal(test, 0, {std::sin(angle), 0, std::cos(angle)});
  EXPECT_NEAR(angularErrors(test, reference).max, 1e-5, 1e-11);
}

TEST(AngularErrors, BrokenNormalsCountAsTheWorstError) {
  NormalBuffer test = emptyBuffer(3, 1), reference = emptyBuffer(3, 1);
  for (std::size_t p = 0; p < 3; ++p) setNormal(reference, p, {0, 0, 1});
  setNormal(test, 0, {0, 0, 0});
  setNormal(test, 1, {std::nan(""), 0, 1});
  setNormal(test, 2, {0, kInfinity, 1});
  std::vector<float> perPixel;
  const AngularStats stats = angularErrors(test, reference, &perPixel);
  EXPECT_EQ(stats.pixels, 3u);
  EXPECT_EQ(stats.mean, 180.0);
  for (float angle : perPixel) EXPECT_EQ(angle, 180.0f);
}

TEST(AngularErrors, NothingCoveredGivesZeros) {
  NormalBuffer test = emptyBuffer(2, 2), reference = fullCoverage(2, 2);
  std::vector<float> perPixel;
  const AngularStats stats = angularErrors(test, reference, &perPixel);
  EXPECT_EQ(stats.pixels, 0u);
  EXPECT_EQ(stats.mean, 0.0);
  EXPECT_EQ(stats.max, 0.0);
  EXPECT_TRUE(std::all_of(perPixel.begin(), perPixel.end(), [](float a) { return std::isnan(a); }));
}

TEST(AngularErrorsDeathTest, DifferentSizesAreABug) {
  EXPECT_DEATH(angularErrors(emptyBuffer(2, 2), emptyBuffer(2, 3)), "check failed");
}

// ---- Statistics of a list of angles ------------------------------------------

// The nearest rank of the 95th percentile by its definition: the smallest k
// with k / n >= 0.95.
std::size_t nearestRank95(std::size_t n) {
  std::size_t k = 1;
  while (100 * k < 95 * n) ++k;
  return k;
}

TEST(StatsOfAngles, MedianAndNearestRankPercentileOfOneToN) {
  for (std::size_t n : {1u, 2u, 3u, 19u, 20u, 21u, 99u, 100u, 101u, 1000u}) {
    std::vector<float> degrees(n);
    std::iota(degrees.begin(), degrees.end(), 1.0f);
    std::reverse(degrees.begin(), degrees.end());
    const AngularStats stats = statsOfAngles(degrees);
    EXPECT_EQ(stats.pixels, n);
    EXPECT_DOUBLE_EQ(stats.mean, (n + 1) / 2.0) << n;
    EXPECT_DOUBLE_EQ(stats.median, (n + 1) / 2.0) << n;  // 1..n: middle value, or mean of the two middle ones
    EXPECT_EQ(stats.p95, static_cast<double>(nearestRank95(n))) << n;
    EXPECT_EQ(stats.max, static_cast<double>(n));
  }
}

TEST(StatsOfAngles, EvenCountMedianIsTheMeanOfTheTwoMiddleValues) {
  const AngularStats stats = statsOfAngles({9.0f, 1.0f, 4.0f, 2.0f});
  EXPECT_DOUBLE_EQ(stats.median, 3.0);
  EXPECT_DOUBLE_EQ(stats.mean, 4.0);
  EXPECT_EQ(stats.p95, 9.0);
}

TEST(StatsOfAngles, IndependentOfInputOrder) {
  std::mt19937 random(11);
  std::uniform_real_distribution<float> angle(0.0f, 30.0f);
  std::vector<float> degrees(1001);
  for (float& d : degrees) d = angle(random);
  const AngularStats first = statsOfAngles(degrees);
  for (int trial = 0; trial < 5; ++trial) {
    std::shuffle(degrees.begin(), degrees.end(), random);
    const AngularStats again = statsOfAngles(degrees);
    EXPECT_EQ(again.mean, first.mean);  // bit for bit
    EXPECT_EQ(again.median, first.median);
    EXPECT_EQ(again.p95, first.p95);
    EXPECT_EQ(again.max, first.max);
  }
}

TEST(StatsOfAngles, IgnoresNaNAndHandlesEmpty) {
  const AngularStats stats = statsOfAngles({kNaN, 2.0f, kNaN, 4.0f});
  EXPECT_EQ(stats.pixels, 2u);
  EXPECT_DOUBLE_EQ(stats.mean, 3.0);
  EXPECT_DOUBLE_EQ(stats.median, 3.0);
  EXPECT_EQ(stats.max, 4.0);
  const AngularStats empty = statsOfAngles({});
  EXPECT_EQ(empty.pixels, 0u);
  EXPECT_EQ(empty.mean, 0.0);
  EXPECT_EQ(empty.p95, 0.0);
}

// ---- Image metrics -------------------------------------------------------------

TEST(CompareImages, IdenticalImages) {
  const Image image = randomImage(32, 24, 0, 255, 3);
  const NormalBuffer coverage = rectangleCoverage(32, 24, 4, 3, 27, 20);
  const ImageMetrics metrics = compareImages(image, image, coverage, coverage);
  EXPECT_EQ(metrics.pixels, 23u * 17u);
  EXPECT_EQ(metrics.meanAbsoluteError, 0.0);
  EXPECT_EQ(metrics.psnr, kInfinity);
  EXPECT_EQ(metrics.ssim, 1.0);
  EXPECT_EQ(metrics.silhouetteMismatch, 0.0);
}

// Every RGB channel of every covered pixel off by d: MAE = d and
// MSE = d^2. Uncovered pixels and alpha differ wildly and must not count.
TEST(CompareImages, UniformOffsetGivesExactMaeAndPsnr) {
  const NormalBuffer coverage = rectangleCoverage(20, 16, 2, 3, 15, 12);
  const Image reference = randomImage(20, 16, 0, 200, 4);
  for (int d : {1, 3, 10, 55}) {
    Image test = randomImage(20, 16, 0, 255, 5);
    for (std::size_t p = 0; p < 20 * 16; ++p) {
      if (!coverage.covered(p)) continue;
      for (int c = 0; c < 3; ++c) test.rgba[4 * p + c] = static_cast<std::uint8_t>(reference.rgba[4 * p + c] + d);
    }
    const ImageMetrics metrics = compareImages(test, reference, coverage, coverage);
    EXPECT_EQ(metrics.pixels, 13u * 9u);
    EXPECT_DOUBLE_EQ(metrics.meanAbsoluteError, d);
    EXPECT_NEAR(metrics.psnr, 10.0 * std::log10(255.0 * 255.0 / (d * d)), 1e-12) << d;
    EXPECT_EQ(metrics.silhouetteMismatch, 0.0);
  }
}

TEST(CompareImages, SsimOfAConstantOffsetIsTheLuminanceTerm) {
  const std::array<std::uint8_t, 3> colour = {120, 64, 200};
  const double luma = 0.299 * 120 + 0.587 * 64 + 0.114 * 200;  // the offset shifts it by d (weights sum to 1)
  const Image reference = uniformImage(16, 16, colour);
  const NormalBuffer coverage = fullCoverage(16, 16);
  for (int d : {1, 5, 20, 50}) {
    const Image test = uniformImage(16, 16, {static_cast<std::uint8_t>(colour[0] + d),
                                             static_cast<std::uint8_t>(colour[1] + d),
                                             static_cast<std::uint8_t>(colour[2] + d)});
    const ImageMetrics metrics = compareImages(test, reference, coverage, coverage);
    EXPECT_NEAR(metrics.ssim, constantOffsetSsim(luma, d), 1e-12) << d;
    EXPECT_LT(metrics.ssim, 1.0);
  }
}

// A 12 x 8 image has two windows, at x = 0 and x = 4. Reference 80
// everywhere, test 80 + d from column 4 on. Window x = 0: x constant, y half
// 80 and half 80 + d, so my = 80 + d/2, var y = d^2/4 (weights 1/64), no
// covariance. Window x = 4: a constant offset.
TEST(CompareImages, SsimOfTwoWindowsWithStrideFour) {
  constexpr double kD = 40.0;
  const Image reference = uniformImage(12, 8, {80, 80, 80});
  Image test = reference;
  for (std::size_t p = 0; p < 12 * 8; ++p)
    if (p % 12 >= 4)
      for (int c = 0; c < 3; ++c) test.rgba[4 * p + c] = 80 + static_cast<std::uint8_t>(kD);
  const NormalBuffer coverage = fullCoverage(12, 8);
  const double halfWindow =
      (2.0 * 80.0 * (80.0 + kD / 2) + kC1) / (80.0 * 80.0 + (80.0 + kD / 2) * (80.0 + kD / 2) + kC1) *
      (kC2 / (kD * kD / 4 + kC2));
  const double expected = (halfWindow + constantOffsetSsim(80.0, kD)) / 2.0;
  EXPECT_NEAR(compareImages(test, reference, coverage, coverage).ssim, expected, 1e-12);
}

// A 5 x 3 image has one window, as large as itself.
TEST(CompareImages, ImageSmallerThanAWindowIsOneWindow) {
  const Image reference = uniformImage(5, 3, {90, 90, 90});
  const Image test = uniformImage(5, 3, {100, 100, 100});
  const NormalBuffer coverage = fullCoverage(5, 3);
  EXPECT_NEAR(compareImages(test, reference, coverage, coverage).ssim, constantOffsetSsim(90.0, 10.0), 1e-12);
}

// 16 x 16 has windows at x, y in {0, 4, 8}. Only pixel (1, 1) is covered, so
// only the window at (0, 0) counts: constant 80 against 80 + 30 there, noise
// everywhere outside it.
TEST(CompareImages, SsimAveragesOnlyWindowsHoldingACoveredPixel) {
  Image reference = randomImage(16, 16, 0, 255, 6);
  Image test = randomImage(16, 16, 0, 255, 7);
  for (int y = 0; y < 8; ++y)
    for (int x = 0; x < 8; ++x)
      for (int c = 0; c < 3; ++c) {
        const std::size_t at = 4 * (static_cast<std::size_t>(y) * 16 + x) + c;
        reference.rgba[at] = 80;
        test.rgba[at] = 110;
      }
  const NormalBuffer testCoverage = rectangleCoverage(16, 16, 1, 1, 2, 2), referenceCoverage = emptyBuffer(16, 16);
  const ImageMetrics metrics = compareImages(test, reference, testCoverage, referenceCoverage);
  EXPECT_NEAR(metrics.ssim, constantOffsetSsim(80.0, 30.0), 1e-12);
  EXPECT_EQ(metrics.pixels, 1u);
  EXPECT_DOUBLE_EQ(metrics.meanAbsoluteError, 30.0);
  EXPECT_EQ(metrics.silhouetteMismatch, 1.0);
}

// The same noise field (fixed seed) scaled by growing amplitudes on a
// textured image kept away from 0 and 255, so nothing clips.
TEST(CompareImages, SsimFallsAsNoiseGrows) {
  constexpr int kSize = 48;
  Image reference = uniformImage(kSize, kSize, {0, 0, 0});
  for (int y = 0; y < kSize; ++y)
    for (int x = 0; x < kSize; ++x)
      for (int c = 0; c < 3; ++c)
        reference.rgba[4 * (static_cast<std::size_t>(y) * kSize + x) + c] =
            static_cast<std::uint8_t>(125 + 30 * std::sin(0.4 * x + c) * std::cos(0.3 * y));
  std::mt19937 random(17);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::vector<double> noise(reference.rgba.size());
  for (double& n : noise) n = unit(random);
  const NormalBuffer coverage = fullCoverage(kSize, kSize);

  double previous = 1.0;
  for (double amplitude : {1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0}) {
    Image test = reference;
    for (std::size_t i = 0; i < test.rgba.size(); ++i)
      if (i % 4 != 3) test.rgba[i] = static_cast<std::uint8_t>(std::lround(reference.rgba[i] + amplitude * noise[i]));
    const double ssim = compareImages(test, reference, coverage, coverage).ssim;
    EXPECT_LT(ssim, previous) << "amplitude " << amplitude;
    EXPECT_GT(ssim, 0.0);
    previous = ssim;
  }
}

// Test covers [5, 25) x [4, 20) (320 pixels), reference [15, 40) x [10, 30)
// (500); they share [15, 25) x [10, 20) (100): 720 covered by either, 620 by
// exactly one.
TEST(CompareImages, SilhouetteMismatchOfTwoRectangles) {
  const NormalBuffer testCoverage = rectangleCoverage(48, 40, 5, 4, 25, 20);
  const NormalBuffer referenceCoverage = rectangleCoverage(48, 40, 15, 10, 40, 30);
  const Image image = randomImage(48, 40, 0, 255, 8);
  const ImageMetrics metrics = compareImages(image, image, testCoverage, referenceCoverage);
  EXPECT_EQ(metrics.pixels, 720u);
  EXPECT_DOUBLE_EQ(metrics.silhouetteMismatch, 620.0 / 720.0);
  const ImageMetrics swapped = compareImages(image, image, referenceCoverage, testCoverage);
  EXPECT_EQ(swapped.silhouetteMismatch, metrics.silhouetteMismatch);
}

TEST(CompareImages, InsideErrorLeavesOutTheSilhouetteMismatch) {
  // Test covers [5,25)x[4,20), reference [15,40)x[10,30): they share 100
  // pixels. The test image is 100 everywhere, the reference 110 on the shared
  // pixels and 200 elsewhere.
  const NormalBuffer testCoverage = rectangleCoverage(48, 40, 5, 4, 25, 20);
  const NormalBuffer referenceCoverage = rectangleCoverage(48, 40, 15, 10, 40, 30);
  const Image test = uniformImage(48, 40, {100, 100, 100});
  Image reference = uniformImage(48, 40, {200, 200, 200});
  for (int y = 10; y < 20; ++y)
    for (int x = 15; x < 25; ++x)
      for (int c = 0; c < 3; ++c) reference.rgba[4 * (static_cast<std::size_t>(y) * 48 + x) + c] = 110;
  const ImageMetrics metrics = compareImages(test, reference, testCoverage, referenceCoverage);
  EXPECT_EQ(metrics.insidePixels, 100u);
  EXPECT_DOUBLE_EQ(metrics.meanAbsoluteErrorInside, 10.0);
  EXPECT_DOUBLE_EQ(metrics.meanAbsoluteError, (100.0 * 10.0 + 620.0 * 100.0) / 720.0);
  EXPECT_DOUBLE_EQ(metrics.meanSquaredError, (100.0 * 100.0 + 620.0 * 10000.0) / 720.0);
}

// Two buffers of the same size side by side, `left` on the left.
template <class Buffer, class Values>
Buffer sideBySide(const Buffer& left, const Buffer& right, Values Buffer::*values) {
  Buffer joined = left;
  joined.width = 2 * left.width;
  const std::size_t row = (left.*values).size() / static_cast<std::size_t>(left.height);
  (joined.*values).clear();
  for (std::size_t y = 0; y < static_cast<std::size_t>(left.height); ++y)
    for (const Buffer* half : {&left, &right})
      (joined.*values).insert((joined.*values).end(), (half->*values).begin() + y * row, (half->*values).begin() + (y + 1) * row);
  return joined;
}

// Two views pooled are the two images side by side, for every pixel-additive
// figure; SSIM (a mean over windows) is the mean of the views'.
TEST(PoolImageMetrics, PixelFiguresEqualThoseOfTheViewsSideBySide) {
  const Image testA = randomImage(16, 12, 0, 255, 21), referenceA = randomImage(16, 12, 0, 255, 22);
  const Image testB = randomImage(16, 12, 0, 255, 23), referenceB = randomImage(16, 12, 0, 255, 24);
  const NormalBuffer coverTestA = rectangleCoverage(16, 12, 2, 2, 12, 10), coverReferenceA = rectangleCoverage(16, 12, 4, 1, 14, 11);
  const NormalBuffer coverTestB = rectangleCoverage(16, 12, 0, 0, 8, 12), coverReferenceB = rectangleCoverage(16, 12, 0, 0, 16, 6);
  const ImageMetrics a = compareImages(testA, referenceA, coverTestA, coverReferenceA);
  const ImageMetrics b = compareImages(testB, referenceB, coverTestB, coverReferenceB);

  const ImageMetrics joined = compareImages(
      sideBySide(testA, testB, &Image::rgba), sideBySide(referenceA, referenceB, &Image::rgba),
      sideBySide(coverTestA, coverTestB, &NormalBuffer::data), sideBySide(coverReferenceA, coverReferenceB, &NormalBuffer::data));
  const ImageMetrics pooled = poolImageMetrics({a, b});
  EXPECT_EQ(pooled.pixels, joined.pixels);
  EXPECT_EQ(pooled.insidePixels, joined.insidePixels);
  EXPECT_NEAR(pooled.meanAbsoluteError, joined.meanAbsoluteError, 1e-12);
  EXPECT_NEAR(pooled.meanSquaredError, joined.meanSquaredError, 1e-9);
  EXPECT_NEAR(pooled.psnr, joined.psnr, 1e-12);
  EXPECT_NEAR(pooled.silhouetteMismatch, joined.silhouetteMismatch, 1e-12);
  EXPECT_NEAR(pooled.meanAbsoluteErrorInside, joined.meanAbsoluteErrorInside, 1e-12);
  EXPECT_DOUBLE_EQ(pooled.ssim, (a.ssim + b.ssim) / 2.0);
}

TEST(CompareImages, NothingCovered) {
  const NormalBuffer none = emptyBuffer(12, 10);
  const ImageMetrics metrics =
      compareImages(randomImage(12, 10, 0, 255, 9), randomImage(12, 10, 0, 255, 10), none, none);
  EXPECT_EQ(metrics.pixels, 0u);
  EXPECT_EQ(metrics.meanAbsoluteError, 0.0);
  EXPECT_EQ(metrics.psnr, kInfinity);
  EXPECT_EQ(metrics.ssim, 1.0);
  EXPECT_EQ(metrics.silhouetteMismatch, 0.0);
}

TEST(CompareImagesDeathTest, DifferentSizesAreABug) {
  const Image image = uniformImage(8, 8, {1, 2, 3});
  const NormalBuffer coverage = fullCoverage(8, 8), wrong = fullCoverage(8, 9);
  EXPECT_DEATH(compareImages(image, uniformImage(9, 8, {1, 2, 3}), coverage, coverage), "check failed");
  EXPECT_DEATH(compareImages(image, image, coverage, wrong), "check failed");
}

// ---- Heat map ----------------------------------------------------------------------

std::array<int, 4> pixelOf(const Image& image, std::size_t pixel) {
  return {image.rgba[4 * pixel], image.rgba[4 * pixel + 1], image.rgba[4 * pixel + 2], image.rgba[4 * pixel + 3]};
}

void expectColourNear(const std::array<int, 4>& actual, std::array<int, 3> rgb) {
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(actual[c], rgb[c], 1) << "channel " << c;
  EXPECT_EQ(actual[3], 255);
}

// Viridis at 0, 1/2 and 1 as matplotlib publishes them: #440154, #21918c,
// #fde725.
TEST(ErrorHeatMap, ViridisFromZeroToMaxClampedBeyond) {
  const std::vector<float> degrees = {0.0f, 5.0f, 10.0f, 20.0f, static_cast<float>(kInfinity), -3.0f, kNaN};
  const Image map = errorHeatMap(degrees, 7, 1, 10.0f);
  ASSERT_EQ(map.width, 7);
  ASSERT_EQ(map.height, 1);
  expectColourNear(pixelOf(map, 0), {0x44, 0x01, 0x54});
  expectColourNear(pixelOf(map, 1), {0x21, 0x91, 0x8c});
  expectColourNear(pixelOf(map, 2), {0xfd, 0xe7, 0x25});
  EXPECT_EQ(pixelOf(map, 3), pixelOf(map, 2));
  EXPECT_EQ(pixelOf(map, 4), pixelOf(map, 2));
  EXPECT_EQ(pixelOf(map, 5), pixelOf(map, 0));
  EXPECT_EQ(pixelOf(map, 6), (std::array<int, 4>{0, 0, 0, 0}));
}

// The scale is ordered for the eye: luma rises along it.
TEST(ErrorHeatMap, LumaRisesWithTheError) {
  std::vector<float> degrees(33);
  for (std::size_t k = 0; k < degrees.size(); ++k) degrees[k] = static_cast<float>(k) / 32.0f * 45.0f;
  const Image map = errorHeatMap(degrees, 33, 1, 45.0f);
  double previous = -1.0;
  for (std::size_t k = 0; k < degrees.size(); ++k) {
    const std::array<int, 4> rgba = pixelOf(map, k);
    const double luma = 0.299 * rgba[0] + 0.587 * rgba[1] + 0.114 * rgba[2];
    EXPECT_GT(luma, previous) << k;
    previous = luma;
  }
}

TEST(ErrorHeatMap, ColourDependsOnlyOnTheFractionOfTheMax) {
  const Image a = errorHeatMap({1.5f, 7.0f}, 1, 2, 10.0f);
  const Image b = errorHeatMap({15.0f, 70.0f}, 1, 2, 100.0f);
  EXPECT_EQ(a.rgba, b.rgba);
}

// ---- PNG output --------------------------------------------------------------------------

TEST(WriteImagePng, RoundTripsThroughStbImage) {
  const Image image = randomImage(7, 5, 0, 255, 12);  // alpha random too
  const fs::path path = test::freshTempDir() / "image.png";
  const Status written = writeImagePng(path, image);
  ASSERT_TRUE(written.ok()) << written.error().message;
  int width = 0, height = 0, channels = 0;
  stbi_uc* pixels = stbi_load(path.c_str(), &width, &height, &channels, 4);
  ASSERT_NE(pixels, nullptr) << stbi_failure_reason();
  EXPECT_EQ(width, 7);
  EXPECT_EQ(height, 5);
  EXPECT_EQ(channels, 4);
  EXPECT_TRUE(std::equal(image.rgba.begin(), image.rgba.end(), pixels));
  stbi_image_free(pixels);
}

TEST(WriteImagePng, EmptyImageIsAnErrorNamingThePath) {
  const fs::path path = test::freshTempDir() / "empty.png";
  const Status written = writeImagePng(path, Image{});
  ASSERT_FALSE(written.ok());
  EXPECT_EQ(written.error().kind, ErrorKind::Internal);
  EXPECT_NE(written.error().message.find(path.string()), std::string::npos);
  EXPECT_FALSE(fs::exists(path));
}

}  // namespace
}  // namespace apo
