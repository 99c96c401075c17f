// Orientation accuracy of estimated normals against the true normals of a
// simulated scan (docs/benchmarks.md, "Raw acquisitions"):
//
//   orientation_accuracy TRUTH.ply ESTIMATED.ply
//
// TRUTH is `apo simulate-scan MESH -o TRUTH.ply` (normals of the surface the
// scanner hit, on the side it saw), ESTIMATED is `apo ingest TRUTH_WITHOUT_NORMALS`'s
// scan.ply. Points are matched by their exact position (ingest keeps
// positions); prints the matched count, the fraction whose normal points
// away from the truth (flipped), and the mean angle to the truth in degrees
// (flipped ones included as they are).
#include "ingest/ingest.h"

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <unordered_map>

namespace {

struct PositionKey {
  std::uint32_t x, y, z;
  bool operator==(const PositionKey&) const = default;
};

struct PositionHash {
  std::size_t operator()(const PositionKey& k) const {
    return (std::size_t{k.x} * 73856093u) ^ (std::size_t{k.y} * 19349663u) ^ (std::size_t{k.z} * 83492791u);
  }
};

PositionKey keyOf(const apo::Vec3f& p) {
  return {std::bit_cast<std::uint32_t>(p.x()), std::bit_cast<std::uint32_t>(p.y()), std::bit_cast<std::uint32_t>(p.z())};
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) {
    fmt::print(stderr, "usage: orientation_accuracy TRUTH.ply ESTIMATED.ply\n");
    return 1;
  }
  const auto truth = apo::readScan(argv[1]);
  const auto estimated = apo::readScan(argv[2]);
  if (!truth || !estimated) {
    fmt::print(stderr, "{}\n", !truth ? truth.error().message : estimated.error().message);
    return 2;
  }
  if (!truth->points.hasNormals() || !estimated->points.hasNormals()) {
    fmt::print(stderr, "both files need normals\n");
    return 2;
  }
  std::unordered_map<PositionKey, std::size_t, PositionHash> index;
  for (std::size_t i = 0; i < truth->points.size(); ++i) index.emplace(keyOf(truth->points.positions[i]), i);
  std::size_t matched = 0, flipped = 0;
  double angleSum = 0.0;
  for (std::size_t i = 0; i < estimated->points.size(); ++i) {
    const auto found = index.find(keyOf(estimated->points.positions[i]));
    if (found == index.end()) continue;
    const double dot = std::clamp(
        static_cast<double>(estimated->points.normals[i].normalized().dot(truth->points.normals[found->second].normalized())),
        -1.0, 1.0);
    ++matched;
    flipped += dot < 0.0;
    angleSum += std::acos(dot) * 180.0 / std::numbers::pi;
  }
  fmt::print("matched {} of {} points; flipped {:.4f}; mean angle {:.2f} deg\n", matched, estimated->points.size(),
             matched ? static_cast<double>(flipped) / static_cast<double>(matched) : 0.0,
             matched ? angleSum / static_cast<double>(matched) : 0.0);
  return 0;
}
