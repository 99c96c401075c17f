// The unit cube the bake places around m.
#include "bake/bake.h"

#include <algorithm>

namespace apo {

UnitCubeTransform unitCubeAround(const Aabb& box) {
  const Eigen::Vector3d lo = box.min.cast<double>(), hi = box.max.cast<double>();
  const double side = std::max((hi - lo).maxCoeff(), 1e-30);
  UnitCubeTransform transform;
  transform.scale = 1.0 / (side * (1.0 + 2.0 * kCubeMargin));
  const Eigen::Vector3d centre = 0.5 * (lo + hi);
  for (int axis = 0; axis < 3; ++axis) transform.offset[axis] = 0.5 - centre[axis] * transform.scale;
  return transform;
}

}  // namespace apo
