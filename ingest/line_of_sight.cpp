#include "ingest/sensors.h"

#include <algorithm>
#include <cmath>
#include <unordered_set>

namespace apo::line_of_sight {
namespace {

// Occupied cells, by their integer coordinates packed in 63 bits.
class Occupancy {
 public:
  Occupancy(const std::vector<Vec3f>& points, float cell) : inverse_(1.0f / cell) {
    cells_.reserve(points.size() / 4 + 16);
    for (const Vec3f& p : points)
      if (p.allFinite()) cells_.insert(key(p));
  }
  bool occupied(const Vec3f& p) const { return cells_.count(key(p)) != 0; }

 private:
  std::uint64_t key(const Vec3f& p) const {
    const auto coordinate = [&](float v) {
      return static_cast<std::uint64_t>(static_cast<std::int64_t>(std::floor(v * inverse_)) + (1 << 20)) & 0x1FFFFF;
    };
    return coordinate(p.x()) << 42 | coordinate(p.y()) << 21 | coordinate(p.z());
  }
  float inverse_;
  std::unordered_set<std::uint64_t> cells_;
};

// Whether the segment from `point` to `sensor` meets an occupied cell once
// it is two cells above the point's surface, within the cloud's box (beyond
// it nothing can hide the point). Steps of half a cell.
bool hidden(const Vec3f& point, const Vec3f& normal, const Vec3f& sensor, const Occupancy& occupancy, const Aabb& box,
            float cell) {
  const Vec3f toSensor = sensor - point;
  const float length = toSensor.norm();
  if (!(length > 0.0f)) return false;
  const Vec3f direction = toSensor / length;
  const float rise = direction.dot(normal);  // > kMinSightCosine: checked by the caller
  const float start = 2.0f * cell / rise;
  const float step = 0.5f * cell;
  for (float t = start; t < length; t += step) {
    const Vec3f at = point + t * direction;
    if ((at.array() < box.min.array()).any() || (at.array() > box.max.array()).any()) return false;
    if (occupancy.occupied(at)) return true;
  }
  return false;
}

}  // namespace

Sight measure(const std::vector<Vec3f>& points, const std::vector<Vec3f>& facingNormals, const Sensors& sensors,
              float cell, std::size_t samples) {
  Sight sight;
  if (points.empty() || !(cell > 0.0f) || !std::isfinite(cell)) return sight;
  const Occupancy occupancy(points, cell);
  const Aabb box = boundingBox(points);
  const std::size_t stride = std::max<std::size_t>(1, points.size() / std::max<std::size_t>(samples, 1));
  for (std::size_t i = 0; i < points.size(); i += stride) {
    const Vec3f& normal = facingNormals[i];
    if (!normal.allFinite() || !points[i].allFinite()) continue;
    const Vec3f& sensor = sensors.of(i);
    const Vec3f toSensor = sensor - points[i];
    if (!(normal.dot(toSensor) > kMinSightCosine * toSensor.norm())) continue;
    ++sight.sampled;
    sight.hidden += hidden(points[i], normal, sensor, occupancy, box, cell);
  }
  return sight;
}

}  // namespace apo::line_of_sight
