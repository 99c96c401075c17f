#include "ingest/range_grid.h"

#include <algorithm>
#include <cmath>

namespace apo::range_grid {

GridTriangles triangulate(const std::vector<std::uint32_t>& index, std::size_t width, std::size_t height,
                          const Vec3f& sensor, float angularStep, float maxEdgeInSpacings, Scan& mesh) {
  GridTriangles counts;
  const auto& p = mesh.points.positions;
  auto acceptable = [&](std::uint32_t a, std::uint32_t b, std::uint32_t c) {
    const Vec3f centroid = (p[a] + p[b] + p[c]) / 3.0f;
    const float spacing = angularStep * (centroid - sensor).norm();
    const float longest = std::max({(p[a] - p[b]).norm(), (p[b] - p[c]).norm(), (p[c] - p[a]).norm()});
    const Vec3f normal = (p[b] - p[a]).cross(p[c] - p[a]);
    const float facing = normal.norm() > 0.0f ? normal.normalized().dot((sensor - centroid).normalized()) : 0.0f;
    return longest <= maxEdgeInSpacings * spacing && std::abs(facing) >= kMinFacingCosine;
  };
  auto add = [&](std::uint32_t a, std::uint32_t b, std::uint32_t c) {
    if (a == kNoReturn || b == kNoReturn || c == kNoReturn) return;
    ++counts.candidates;
    if (!acceptable(a, b, c)) {
      ++counts.refused;
      return;
    }
    const Vec3f normal = (p[b] - p[a]).cross(p[c] - p[a]);
    if (normal.dot(sensor - p[a]) < 0.0f) mesh.triangles.push_back({a, c, b});
    else mesh.triangles.push_back({a, b, c});
    ++counts.triangles;
  };
  for (std::size_t row = 0; row + 1 < height; ++row)
    for (std::size_t column = 0; column + 1 < width; ++column) {
      const std::uint32_t a = index[row * width + column], b = index[row * width + column + 1],
                          c = index[(row + 1) * width + column], d = index[(row + 1) * width + column + 1];
      // A cell with a corner missing still gets the triangle of the other
      // three (depth cameras lose single pixels all over): split along the
      // diagonal that avoids the missing corner.
      if (a == kNoReturn || d == kNoReturn) {
        add(a, b, c);
        add(b, d, c);
      } else {
        add(a, b, d);
        add(a, d, c);
      }
    }
  return counts;
}

GridSpacing measureSpacing(const std::vector<Vec3f>& positions, std::size_t width, const Vec3f& sensor) {
  std::vector<float> steps;
  auto measure = [&](std::size_t i, std::size_t j) {
    const Vec3f &a = positions[i], &b = positions[j];
    if (!a.allFinite() || !b.allFinite()) return;
    const float range = (0.5f * (a + b) - sensor).norm();
    if (range > 0.0f) steps.push_back((a - b).norm() / range);
  };
  for (std::size_t i = 0; i < positions.size(); ++i) {
    if ((i + 1) % width != 0) measure(i, i + 1);
    if (i + width < positions.size()) measure(i, i + width);
  }
  GridSpacing spacing;
  if (steps.empty()) return spacing;
  const auto quantile = [&](double q) {
    const auto at = steps.begin() + static_cast<std::ptrdiff_t>(q * static_cast<double>(steps.size() - 1));
    std::nth_element(steps.begin(), at, steps.end());
    return *at;
  };
  spacing.angularStep = quantile(0.5);
  if (spacing.angularStep > 0.0f)
    spacing.maxEdgeInSpacings = std::clamp(kJumpOverSpread * quantile(0.95) / spacing.angularStep, kMaxEdgeInSpacings,
                                           kMaxEdgeInSpacingsCap);
  return spacing;
}

}  // namespace apo::range_grid
