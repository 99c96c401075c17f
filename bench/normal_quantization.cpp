// Angular error of the three-byte normal encodings (bake.h) on 1,000,000
// directions uniform on the sphere (fixed seed): xyz8, oct24 with plain
// rounding, and oct24 with the precise encoder encodeNormal uses. Prints a
// markdown table for docs/benchmarks.md.
#include "format/format.h"
#include "format/octahedral.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <numbers>
#include <random>
#include <vector>

namespace {

using apo::NormalEncoding;
using apo::Vec3f;

constexpr std::size_t kDirections = 1000000;
constexpr std::uint64_t kSeed = 20070101;

// Uniform on the sphere: z uniform in [-1, 1] and a uniform longitude.
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

// Degrees; atan2 of |cross| and dot stays accurate for tiny angles.
double degreesBetween(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b)) * 180.0 / std::numbers::pi;
}

struct Row {
  const char* name;
  std::function<std::array<std::uint8_t, 3>(const Vec3f&)> encode;
  NormalEncoding decodeAs;
  double boundRadians;  // the analytic bound of tests/format/normal_encoding_test.cpp
};

void printRow(const Row& row, const std::vector<Eigen::Vector3d>& directions) {
  double sum = 0, worst = 0;
  for (const Eigen::Vector3d& n : directions) {
    const Vec3f decoded = apo::decodeNormal(row.encode(n.cast<float>()), row.decodeAs);
    const double error = degreesBetween(n, decoded.cast<double>());
    sum += error;
    worst = std::max(worst, error);
  }
  fmt::print("| {} | {:.5f} | {:.5f} | {:.5f} |\n", row.name, sum / static_cast<double>(directions.size()), worst,
             row.boundRadians * 180.0 / std::numbers::pi);
}

}  // namespace

int main() {
  const std::vector<Eigen::Vector3d> directions = randomDirections(kDirections, kSeed);
  const Row rows[] = {
      {"xyz8", [](const Vec3f& n) { return apo::encodeNormal(n, NormalEncoding::Xyz8); }, NormalEncoding::Xyz8,
       std::asin(std::sqrt(3.0) / 255.0)},
      {"oct24, rounded", [](const Vec3f& n) { return apo::octahedral::encodeRounded(n); }, NormalEncoding::Oct24,
       3.0 * std::sqrt(2.0) / 4095.0},
      {"oct24, precise (used)", [](const Vec3f& n) { return apo::encodeNormal(n, NormalEncoding::Oct24); },
       NormalEncoding::Oct24, 3.0 * std::sqrt(2.0) / 4095.0},
  };
  fmt::print("{} directions uniform on the sphere (seed {}), angular error in degrees\n\n", kDirections, kSeed);
  fmt::print("| encoding | mean | worst | bound |\n|---|---|---|---|\n");
  for (const Row& row : rows) printRow(row, directions);
  return 0;
}
