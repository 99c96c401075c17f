// The scan's colours for the GLB's base colour map: the coloured points of
// the scan file, and the colour at any point of m from its nearest ones.
#include "pipeline/pipeline.h"

#include "adapters/flann/flann_search.h"

#include <algorithm>
#include <cmath>

namespace apo {

void moveToFrame(Scan& scan, const std::array<double, 3>& origin) {
  const Eigen::Vector3d shift(scan.origin[0] - origin[0], scan.origin[1] - origin[1], scan.origin[2] - origin[2]);
  for (Vec3f& p : scan.points.positions) p = (p.cast<double>() + shift).cast<float>();
  scan.origin = origin;
}

Result<ScanColors> readScanColors(const std::filesystem::path& scanPath, const std::array<double, 3>& runOrigin) {
  auto scan = readScan(scanPath);
  if (!scan) return scan.error();
  ScanColors found;
  if (!scan->points.hasColors()) return found;
  moveToFrame(*scan, runOrigin);
  const PointSet& points = scan->points;
  for (std::size_t i = 0; i < points.size(); ++i)
    if (points.positions[i].allFinite()) {
      found.positions.push_back(points.positions[i]);
      found.colors.push_back(points.colors[i]);
    }
  return found;
}

ColorField nearestScanColors(const ScanColors& colors) {
  return [&colors](const std::vector<Vec3f>& points) -> Result<std::vector<Rgb8>> {
    if (colors.positions.empty()) return badInput("the scan has no coloured point to take colours from");
    auto nearest = flann_adapter::nearestOf(colors.positions, points, kScanColorNeighbours);
    if (!nearest) return nearest.error();
    std::vector<Rgb8> answers;
    answers.reserve(points.size());
    for (std::size_t q = 0; q < points.size(); ++q) {
      Eigen::Vector3d sum = Eigen::Vector3d::Zero();
      double total = 0.0;
      for (std::size_t j = 0; j < nearest->k; ++j) {
        const std::size_t at = q * nearest->k + j;
        // A point on a coloured point takes its colour (the 1e-30 only keeps the division finite).
        const double weight = 1.0 / (static_cast<double>(nearest->squaredDistances[at]) + 1e-30);
        const Rgb8& c = colors.colors[nearest->indices[at]];
        sum += weight * Eigen::Vector3d(c.r, c.g, c.b);
        total += weight;
      }
      const Eigen::Vector3d mean = sum / total;
      const auto byte = [](double v) { return static_cast<std::uint8_t>(std::lround(std::clamp(v, 0.0, 255.0))); };
      answers.push_back({byte(mean.x()), byte(mean.y()), byte(mean.z())});
    }
    return answers;
  };
}

}  // namespace apo
