// The metrics of render.h: angular error of the normal buffers, MAE / PSNR /
// SSIM / silhouette mismatch of the shaded images, the error heat map.
// Pure functions over CPU buffers, no GL. docs/render.md ("Metrics") states
// every formula; SSIM follows Wang, Bovik, Sheikh and Simoncelli, "Image
// quality assessment: from error visibility to structural similarity",
// IEEE TIP 13(4), 2004.
#include "render/render.h"

#include "core/image_io.h"
#include "render/shaders.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <numbers>

namespace apo {
namespace {

constexpr double kMaxByte = 255.0;
// Wang et al. 2004, eq. (7) and (9): C1 = (K1 L)^2, C2 = (K2 L)^2 with
// K1 = 0.01, K2 = 0.03 and the dynamic range L = 255.
constexpr double kSsimC1 = (0.01 * kMaxByte) * (0.01 * kMaxByte);
constexpr double kSsimC2 = (0.03 * kMaxByte) * (0.03 * kMaxByte);
constexpr int kSsimWindow = 8;
constexpr int kSsimStride = 4;

std::size_t pixelCount(int width, int height) {
  APO_CHECK(width >= 0 && height >= 0);
  return static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
}

void checkBuffer(const NormalBuffer& buffer) {
  APO_CHECK_OP(buffer.data.size(), ==, 4 * pixelCount(buffer.width, buffer.height));
}

void checkImage(const Image& image) {
  APO_CHECK_OP(image.rgba.size(), ==, 4 * pixelCount(image.width, image.height));
}

double luminance(const Image& image, std::size_t pixel) {
  const std::uint8_t* rgb = &image.rgba[4 * pixel];
  return 0.299 * rgb[0] + 0.587 * rgb[1] + 0.114 * rgb[2];
}

std::vector<double> luminances(const Image& image) {
  std::vector<double> y(pixelCount(image.width, image.height));
  for (std::size_t p = 0; p < y.size(); ++p) y[p] = luminance(image, p);
  return y;
}

// SSIM of one window (eq. (13) of Wang et al.) with uniform weights 1/N: the
// means, variances and covariance of eq. (14) with w_i = 1/N. Two passes, so
// identical windows give exactly 1.
double windowSsim(const std::vector<double>& x, const std::vector<double>& y, int width, int x0, int y0,
                  int windowWidth, int windowHeight) {
  const double n = static_cast<double>(windowWidth) * windowHeight;
  double meanX = 0.0, meanY = 0.0;
  for (int row = y0; row < y0 + windowHeight; ++row)
    for (int col = x0; col < x0 + windowWidth; ++col) {
      const std::size_t p = static_cast<std::size_t>(row) * width + col;
      meanX += x[p];
      meanY += y[p];
    }
  meanX /= n;
  meanY /= n;
  double varX = 0.0, varY = 0.0, covXY = 0.0;
  for (int row = y0; row < y0 + windowHeight; ++row)
    for (int col = x0; col < x0 + windowWidth; ++col) {
      const std::size_t p = static_cast<std::size_t>(row) * width + col;
      const double dx = x[p] - meanX, dy = y[p] - meanY;
      varX += dx * dx;
      varY += dy * dy;
      covXY += dx * dy;
    }
  varX /= n;
  varY /= n;
  covXY /= n;
  return ((2.0 * meanX * meanY + kSsimC1) * (2.0 * covXY + kSsimC2)) /
         ((meanX * meanX + meanY * meanY + kSsimC1) * (varX + varY + kSsimC2));
}

bool windowHoldsCovered(const std::vector<std::uint8_t>& covered, int width, int x0, int y0, int windowWidth,
                        int windowHeight) {
  for (int row = y0; row < y0 + windowHeight; ++row)
    for (int col = x0; col < x0 + windowWidth; ++col)
      if (covered[static_cast<std::size_t>(row) * width + col]) return true;
  return false;
}

// Mean SSIM over the 8x8 windows at multiples of 4 that lie inside the image
// and hold a covered pixel. An image narrower or lower than 8 gets windows
// as wide or as high as itself. No such window: nothing on the object
// differs, 1.
double meanSsim(const Image& test, const Image& reference, const std::vector<std::uint8_t>& covered) {
  const int width = test.width, height = test.height;
  const int windowWidth = std::min(kSsimWindow, width), windowHeight = std::min(kSsimWindow, height);
  const std::vector<double> x = luminances(test), y = luminances(reference);
  double sum = 0.0;
  std::uint64_t windows = 0;
  for (int y0 = 0; windowHeight > 0 && y0 + windowHeight <= height; y0 += kSsimStride)
    for (int x0 = 0; windowWidth > 0 && x0 + windowWidth <= width; x0 += kSsimStride) {
      if (!windowHoldsCovered(covered, width, x0, y0, windowWidth, windowHeight)) continue;
      sum += windowSsim(x, y, width, x0, y0, windowWidth, windowHeight);
      ++windows;
    }
  return windows == 0 ? 1.0 : sum / static_cast<double>(windows);
}

// Matplotlib's viridis (van der Walt and Smith, CC0), perceptually uniform
// with monotonically rising lightness, so the heat map reads as an ordered
// scale also in grey and for colour-blind readers. Sampled at t = k/32 from
// matplotlib's 256-entry table (_cm_listed.py, entry i at t = i/255,
// interpolated); piecewise-linear interpolation of these 33 samples stays
// within 1.7/255 of the full table.
constexpr std::array<std::array<float, 3>, 33> kViridis = {{
    {0.2670f, 0.0049f, 0.3294f}, {0.2770f, 0.0502f, 0.3755f}, {0.2823f, 0.0946f, 0.4170f},
    {0.2829f, 0.1354f, 0.4530f}, {0.2789f, 0.1749f, 0.4830f}, {0.2708f, 0.2133f, 0.5066f},
    {0.2593f, 0.2507f, 0.5244f}, {0.2454f, 0.2867f, 0.5370f}, {0.2302f, 0.3213f, 0.5455f},
    {0.2148f, 0.3545f, 0.5510f}, {0.2000f, 0.3864f, 0.5545f}, {0.1861f, 0.4173f, 0.5567f},
    {0.1733f, 0.4474f, 0.5579f}, {0.1613f, 0.4770f, 0.5581f}, {0.1497f, 0.5064f, 0.5573f},
    {0.1384f, 0.5358f, 0.5551f}, {0.1281f, 0.5651f, 0.5509f}, {0.1209f, 0.5945f, 0.5442f},
    {0.1203f, 0.6238f, 0.5343f}, {0.1310f, 0.6529f, 0.5208f}, {0.1554f, 0.6815f, 0.5032f},
    {0.1930f, 0.7096f, 0.4812f}, {0.2415f, 0.7366f, 0.4545f}, {0.2986f, 0.7624f, 0.4230f},
    {0.3629f, 0.7867f, 0.3866f}, {0.4330f, 0.8091f, 0.3453f}, {0.5081f, 0.8292f, 0.2992f},
    {0.5873f, 0.8470f, 0.2489f}, {0.6694f, 0.8622f, 0.1954f}, {0.7529f, 0.8751f, 0.1427f},
    {0.8359f, 0.8861f, 0.1025f}, {0.9166f, 0.8961f, 0.1008f}, {0.9932f, 0.9062f, 0.1439f},
}};

// Viridis at t in [0, 1] as opaque 8-bit RGBA.
std::array<std::uint8_t, 4> viridis(double t) {
  const double scaled = std::clamp(t, 0.0, 1.0) * (kViridis.size() - 1);
  const std::size_t i = std::min(static_cast<std::size_t>(scaled), kViridis.size() - 2);
  const double f = scaled - static_cast<double>(i);
  std::array<std::uint8_t, 4> rgba = {0, 0, 0, 255};
  for (int c = 0; c < 3; ++c) {
    const double value = (1.0 - f) * kViridis[i][c] + f * kViridis[i + 1][c];
    rgba[c] = static_cast<std::uint8_t>(std::lround(std::clamp(value, 0.0, 1.0) * kMaxByte));
  }
  return rgba;
}

double psnrOf(double meanSquaredError) {
  return meanSquaredError == 0.0 ? std::numeric_limits<double>::infinity()
                                 : 10.0 * std::log10(kMaxByte * kMaxByte / meanSquaredError);
}

}  // namespace

std::string shaders::glslViridis() {
  std::string table = fmt::format("const vec3 VIRIDIS[{}] = vec3[{}](", kViridis.size(), kViridis.size());
  for (std::size_t i = 0; i < kViridis.size(); ++i)
    table += fmt::format("{}vec3({:.4f}, {:.4f}, {:.4f})", i ? ", " : "", kViridis[i][0], kViridis[i][1], kViridis[i][2]);
  return table + ");\n";
}

// atan2(|a x b|, a . b) rather than acos of the normalised dot product: it is
// scale-invariant (no normalisation), lies in [0, 180] with no clamp that
// could hide a NaN, and keeps its relative precision at any angle, where
// acos near 1 has an absolute error of about 1e-16 / sin(angle) radians.
// A covered pixel without a usable normal (zero length or not finite) is a
// broken pass: it counts as the worst error, 180 degrees, so it cannot make
// the result look better.
double angleDegrees(const Vec3f& testNormal, const Vec3f& referenceNormal) {
  const Eigen::Vector3d a = testNormal.cast<double>(), b = referenceNormal.cast<double>();
  if (!a.allFinite() || !b.allFinite() || a.squaredNorm() == 0.0 || b.squaredNorm() == 0.0) return 180.0;
  return std::atan2(a.cross(b).norm(), a.dot(b)) * (180.0 / std::numbers::pi);
}

AngularStats statsOfAngles(std::vector<float> degrees) {
  // NaN marks an uncompared pixel (angularErrors' perPixel): not an angle.
  std::erase_if(degrees, [](float d) { return std::isnan(d); });
  // Sorting first makes every figure, the floating-point sum included,
  // independent of the input order.
  std::sort(degrees.begin(), degrees.end());
  AngularStats stats;
  const std::size_t n = degrees.size();
  stats.pixels = n;
  if (n == 0) return stats;
  double sum = 0.0;
  for (float d : degrees) sum += d;
  stats.mean = sum / static_cast<double>(n);
  stats.median = n % 2 == 1 ? degrees[n / 2] : 0.5 * (static_cast<double>(degrees[n / 2 - 1]) + degrees[n / 2]);
  // Nearest rank ceil(0.95 n), in integers so 0.95 n never rounds up a rank.
  stats.p95 = degrees[(95 * static_cast<std::uint64_t>(n) + 99) / 100 - 1];
  stats.max = degrees.back();
  return stats;
}

AngularStats angularErrors(const NormalBuffer& test, const NormalBuffer& reference, std::vector<float>* perPixel) {
  checkBuffer(test);
  checkBuffer(reference);
  APO_CHECK(test.width == reference.width && test.height == reference.height);
  const std::size_t pixels = pixelCount(test.width, test.height);
  if (perPixel) perPixel->assign(pixels, std::numeric_limits<float>::quiet_NaN());
  std::vector<float> degrees;
  for (std::size_t p = 0; p < pixels; ++p) {
    if (!test.covered(p) || !reference.covered(p)) continue;
    const auto angle = static_cast<float>(angleDegrees(test.normal(p), reference.normal(p)));
    degrees.push_back(angle);
    if (perPixel) (*perPixel)[p] = angle;
  }
  return statsOfAngles(std::move(degrees));
}

ImageMetrics compareImages(const Image& test, const Image& reference, const NormalBuffer& testCoverage,
                           const NormalBuffer& referenceCoverage) {
  checkImage(test);
  checkImage(reference);
  checkBuffer(testCoverage);
  checkBuffer(referenceCoverage);
  const int width = test.width, height = test.height;
  APO_CHECK(reference.width == width && reference.height == height);
  APO_CHECK(testCoverage.width == width && testCoverage.height == height);
  APO_CHECK(referenceCoverage.width == width && referenceCoverage.height == height);

  // Silhouettes, and the RGB errors over their union.
  const std::size_t pixels = pixelCount(width, height);
  std::vector<std::uint8_t> either(pixels, 0);
  std::uint64_t eitherCount = 0, exactlyOneCount = 0;
  double absoluteSum = 0.0, squaredSum = 0.0, insideAbsoluteSum = 0.0;
  for (std::size_t p = 0; p < pixels; ++p) {
    const bool inTest = testCoverage.covered(p), inReference = referenceCoverage.covered(p);
    if (!inTest && !inReference) continue;
    either[p] = 1;
    ++eitherCount;
    if (inTest != inReference) ++exactlyOneCount;
    double pixelAbsolute = 0.0;
    for (int c = 0; c < 3; ++c) {
      const int difference = int{test.rgba[4 * p + c]} - int{reference.rgba[4 * p + c]};
      pixelAbsolute += std::abs(difference);
      squaredSum += difference * difference;
    }
    absoluteSum += pixelAbsolute;
    if (inTest == inReference) insideAbsoluteSum += pixelAbsolute;
  }

  ImageMetrics metrics;
  metrics.pixels = eitherCount;
  const double samples = 3.0 * static_cast<double>(eitherCount);
  metrics.meanSquaredError = eitherCount == 0 ? 0.0 : squaredSum / samples;
  metrics.meanAbsoluteError = eitherCount == 0 ? 0.0 : absoluteSum / samples;
  metrics.psnr = psnrOf(metrics.meanSquaredError);
  metrics.insidePixels = eitherCount - exactlyOneCount;
  metrics.meanAbsoluteErrorInside =
      metrics.insidePixels == 0 ? 0.0 : insideAbsoluteSum / (3.0 * static_cast<double>(metrics.insidePixels));
  metrics.ssim = meanSsim(test, reference, either);
  metrics.silhouetteMismatch =
      eitherCount == 0 ? 0.0 : static_cast<double>(exactlyOneCount) / static_cast<double>(eitherCount);
  return metrics;
}

ImageMetrics poolImageMetrics(const std::vector<ImageMetrics>& views) {
  ImageMetrics pooled;
  double absoluteSum = 0.0, squaredSum = 0.0, mismatched = 0.0, insideSum = 0.0, ssimSum = 0.0;
  for (const ImageMetrics& v : views) {
    const auto pixels = static_cast<double>(v.pixels), inside = static_cast<double>(v.insidePixels);
    pooled.pixels += v.pixels;
    pooled.insidePixels += v.insidePixels;
    absoluteSum += v.meanAbsoluteError * pixels;
    squaredSum += v.meanSquaredError * pixels;
    mismatched += v.silhouetteMismatch * pixels;
    insideSum += v.meanAbsoluteErrorInside * inside;
    ssimSum += v.ssim;
  }
  const auto pixels = static_cast<double>(pooled.pixels);
  if (pooled.pixels > 0) {
    pooled.meanAbsoluteError = absoluteSum / pixels;
    pooled.meanSquaredError = squaredSum / pixels;
    pooled.silhouetteMismatch = mismatched / pixels;
  }
  if (pooled.insidePixels > 0) pooled.meanAbsoluteErrorInside = insideSum / static_cast<double>(pooled.insidePixels);
  pooled.psnr = psnrOf(pooled.meanSquaredError);
  pooled.ssim = views.empty() ? 1.0 : ssimSum / static_cast<double>(views.size());
  return pooled;
}

Image errorHeatMap(const std::vector<float>& degrees, int width, int height, float maxDegrees) {
  const std::size_t pixels = pixelCount(width, height);
  APO_CHECK_OP(degrees.size(), ==, pixels);
  APO_CHECK(std::isfinite(maxDegrees) && maxDegrees > 0.0f);
  Image image;
  image.width = width;
  image.height = height;
  image.rgba.assign(4 * pixels, 0);  // transparent black where not compared
  for (std::size_t p = 0; p < pixels; ++p) {
    if (std::isnan(degrees[p])) continue;
    const std::array<std::uint8_t, 4> colour = viridis(static_cast<double>(degrees[p]) / maxDegrees);
    std::copy(colour.begin(), colour.end(), image.rgba.begin() + static_cast<std::ptrdiff_t>(4 * p));
  }
  return image;
}

Status writeImagePng(const std::filesystem::path& path, const Image& image) {
  if (image.width <= 0 || image.height <= 0)
    return internalError("{}: cannot write a {} x {} PNG", path.string(), image.width, image.height);
  return writePngRgba8(path, static_cast<std::uint32_t>(image.width), static_cast<std::uint32_t>(image.height),
                       image.rgba);
}

}  // namespace apo
