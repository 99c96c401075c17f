// Internal to ingest: positions as the readers read them, in double, until a
// reader is done; then the local frame (Scan::origin) is chosen and the
// positions stored as floats in it. Coordinates near zero keep origin 0 and
// the exact floats a direct cast gives; coordinates far from zero for their
// extent (georeferenced lidar in UTM metres: x about 5e5, y about 5e6) are
// moved near zero first, so that float keeps their detail.
#pragma once

#include "core/geometry.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
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

// The local frame of positions read in double, for readers that can go over
// their positions twice: include() every position on the first pass, fixInto()
// the scan, then local() every position on the second. The same frame and the
// same floats as PositionCollector, without holding every position in double
// meanwhile (24 bytes a point: 480 MB for a 20-million-point E57 file).
class LocalFrame {
 public:
  void include(double x, double y, double z) {
    if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z)) return;
    lo_ = {std::min(lo_[0], x), std::min(lo_[1], y), std::min(lo_[2], z)};
    hi_ = {std::max(hi_[0], x), std::max(hi_[1], y), std::max(hi_[2], z)};
  }
  // The frame's origin into scan.origin, with a note when the frame moved.
  void fixInto(Scan& scan);
  // A position in the frame, as float (non-finite values stay non-finite;
  // beyond float's range, infinite).
  Vec3f local(double x, double y, double z) const {
    return Vec3f(toFloat(x - origin_[0]), toFloat(y - origin_[1]), toFloat(z - origin_[2]));
  }

 private:
  // Doubles beyond float range become infinities (a plain cast would be
  // undefined), so that cleaning drops them like other non-finite values.
  static float toFloat(double value) {
    constexpr double kMax = std::numeric_limits<float>::max();
    if (value > kMax) return std::numeric_limits<float>::infinity();
    if (value < -kMax) return -std::numeric_limits<float>::infinity();
    return static_cast<float>(value);
  }

  std::array<double, 3> lo_{kInfinity, kInfinity, kInfinity}, hi_{-kInfinity, -kInfinity, -kInfinity};
  std::array<double, 3> origin_{0.0, 0.0, 0.0};
  static constexpr double kInfinity = std::numeric_limits<double>::infinity();
};

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
