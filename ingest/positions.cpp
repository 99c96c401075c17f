#include "ingest/positions.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace apo::readers {

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

void LocalFrame::fixInto(Scan& scan) {
  origin_ = lo_[0] <= hi_[0] ? localOrigin(lo_, hi_) : std::array<double, 3>{0.0, 0.0, 0.0};
  scan.origin = origin_;
  if (scan.isGeoreferenced())
    scan.readNotes.push_back(fmt::format("coordinates far from zero for their extent: moved by ({}, {}, {}) into a "
                                         "local frame, in double precision (the origin is recorded)",
                                         -origin_[0], -origin_[1], -origin_[2]));
}

void PositionCollector::finishInto(Scan& scan) {
  LocalFrame frame;
  for (const auto& p : positions_) frame.include(p[0], p[1], p[2]);
  frame.fixInto(scan);
  scan.points.positions.resize(positions_.size());
  for (std::size_t i = 0; i < positions_.size(); ++i) {
    const auto& p = positions_[i];
    scan.points.positions[i] = frame.local(p[0], p[1], p[2]);
  }
  positions_.clear();
  positions_.shrink_to_fit();
}

}  // namespace apo::readers
