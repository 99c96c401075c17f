// The unit cube's transform and the child-cell conventions shared by the
// build, the encoding, the CPU lookups and the shaders.
#include "format/format.h"

namespace apo {

Vec3f UnitCubeTransform::toUnit(const Vec3f& world) const {
  return {static_cast<float>(world.x() * scale + offset[0]), static_cast<float>(world.y() * scale + offset[1]),
          static_cast<float>(world.z() * scale + offset[2])};
}

Vec3f UnitCubeTransform::toWorld(const Vec3f& unit) const {
  return {static_cast<float>((unit.x() - offset[0]) / scale), static_cast<float>((unit.y() - offset[1]) / scale),
          static_cast<float>((unit.z() - offset[2]) / scale)};
}

int childIndex(const Vec3f& centre, const Vec3f& point) {
  return (point.x() <= centre.x() ? 4 : 0) | (point.y() <= centre.y() ? 2 : 0) | (point.z() <= centre.z() ? 1 : 0);
}

Vec3f childCentre(const Vec3f& centre, float width, int child) {
  const float quarter = width * 0.25f;
  return {centre.x() + ((child & 4) ? -quarter : quarter), centre.y() + ((child & 2) ? -quarter : quarter),
          centre.z() + ((child & 1) ? -quarter : quarter)};
}

}  // namespace apo
