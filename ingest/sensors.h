// Internal to ingest: where a scan's points were seen from, and whether
// they were in sight of it.
#pragma once

#include "core/geometry.h"

#include <cstdint>
#include <vector>

namespace apo {

// One position for every point (a viewpoint, a depth camera), or one per
// scan station, each point naming its own (PointSet::stations).
struct Sensors {
  std::vector<Vec3f> positions;
  std::vector<std::uint16_t> ofPoint;  // empty: positions[0] for every point

  static Sensors single(const Vec3f& position) { return {{position}, {}}; }
  const Vec3f& of(std::size_t point) const { return ofPoint.empty() ? positions.front() : positions[ofPoint[point]]; }
};

namespace line_of_sight {

// Points sampled, and of those, how many have another part of the cloud on
// the straight line to their sensor.
struct Sight {
  std::uint64_t sampled = 0, hidden = 0;
  double share() const { return sampled == 0 ? 0.0 : static_cast<double>(hidden) / static_cast<double>(sampled); }
};

// About `samples` points, evenly strided, each tested along its line to its
// sensor through a grid of `cell`-sized cells holding the cloud: hidden when
// the line enters an occupied cell once it is more than two cells above
// the point's own surface (its normal, facing the sensor, gives the
// surface); points seen at a grazing angle (under kMinSightCosine) are
// skipped, as their own surface hides them from any test this coarse.
inline constexpr float kMinSightCosine = 0.1f;
Sight measure(const std::vector<Vec3f>& points, const std::vector<Vec3f>& facingNormals, const Sensors& sensors,
              float cell, std::size_t samples);

}  // namespace line_of_sight
}  // namespace apo
