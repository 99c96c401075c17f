// Internal to ingest: positions as the readers read them, in double, until a
// reader is done; then the local frame (Scan::origin) is chosen and the
// positions stored as floats in it. Coordinates near zero keep origin 0 and
// the exact floats a direct cast gives; coordinates far from zero for their
// extent (georeferenced lidar in UTM metres: x about 5e5, y about 5e6) are
// moved near zero first, so that float keeps their detail.
#pragma once

#include "core/geometry.h"

#include <array>
#include <cstddef>
#include <vector>

namespace apo::readers {

// A bounding-box centre farther from zero than this many diagonals is moved
// to the origin: beyond it, float's 24 bits at the coordinates' magnitude are
// coarser than a millionth of the scan's extent.
inline constexpr double kFarFromZero = 16.0;

// The origin of the local frame for points spanning [lo, hi]: their centre
// rounded to whole units when it is farther than kFarFromZero diagonals from
// zero, else zero. Rounding makes shifted copies of a scan (by whole units)
// land on the same local coordinates.
std::array<double, 3> localOrigin(const std::array<double, 3>& lo, const std::array<double, 3>& hi);

class PositionCollector {
 public:
  void reserve(std::size_t count) { positions_.reserve(count); }
  void push(double x, double y, double z) { positions_.push_back({x, y, z}); }
  std::size_t size() const { return positions_.size(); }

  // The positions into scan.points.positions (float, in the local frame:
  // non-finite values stay non-finite, for cleaning to count) and the frame's
  // origin into scan.origin, with a note when the frame moved.
  void finishInto(Scan& scan);

 private:
  std::vector<std::array<double, 3>> positions_;
};

}  // namespace apo::readers
