#include "core/geometry.h"

namespace apo {

Aabb boundingBox(const std::vector<Vec3f>& positions) {
  Aabb box;
  for (const Vec3f& p : positions) box.extend(p);
  return box;
}

}  // namespace apo
