#include "ingest/positions.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace apo::readers {
namespace {

// Doubles beyond float range become infinities (a plain cast would be
// undefined), so that cleaning drops them like other non-finite values.
float toFloat(double value) {
  constexpr double kMax = std::numeric_limits<float>::max();
  if (value > kMax) return std::numeric_limits<float>::infinity();
  if (value < -kMax) return -std::numeric_limits<float>::infinity();
  return static_cast<float>(value);
}

}  // namespace

std::array<double, 3> localOrigin(const std::array<double, 3>& lo, const std::array<double, 3>& hi) {
  double diagonal2 = 0.0, farthest = 0.0;
  std::array<double, 3> centre{};
  for (int axis = 0; axis < 3; ++axis) {
    centre[axis] = 0.5 * (lo[axis] + hi[axis]);
    diagonal2 += (hi[axis] - lo[axis]) * (hi[axis] - lo[axis]);
    farthest = std::max(farthest, std::abs(centre[axis]));
  }
  // A single point (or all on one spot) has no extent to keep: no move.
  const double diagonal = std::sqrt(diagonal2);
  if (!std::isfinite(farthest) || !(diagonal > 0.0) || !(farthest > kFarFromZero * diagonal)) return {0.0, 0.0, 0.0};
  return {std::round(centre[0]), std::round(centre[1]), std::round(centre[2])};
}

void PositionCollector::finishInto(Scan& scan) {
  std::array<double, 3> lo, hi;
  lo.fill(std::numeric_limits<double>::infinity());
  hi.fill(-std::numeric_limits<double>::infinity());
  for (const auto& p : positions_) {
    if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2])) continue;
    for (int axis = 0; axis < 3; ++axis) {
      lo[axis] = std::min(lo[axis], p[axis]);
      hi[axis] = std::max(hi[axis], p[axis]);
    }
  }
  scan.origin = lo[0] <= hi[0] ? localOrigin(lo, hi) : std::array<double, 3>{0.0, 0.0, 0.0};
  const auto& o = scan.origin;
  scan.points.positions.resize(positions_.size());
  for (std::size_t i = 0; i < positions_.size(); ++i) {
    const auto& p = positions_[i];
    scan.points.positions[i] = Vec3f(toFloat(p[0] - o[0]), toFloat(p[1] - o[1]), toFloat(p[2] - o[2]));
  }
  if (scan.isGeoreferenced())
    scan.readNotes.push_back(fmt::format("coordinates far from zero for their extent: moved by ({}, {}, {}) into a "
                                         "local frame, in double precision (the origin is recorded)",
                                         -o[0], -o[1], -o[2]));
  positions_.clear();
  positions_.shrink_to_fit();
}

}  // namespace apo::readers
