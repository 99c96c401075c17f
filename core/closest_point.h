// The closest-point seam: the bake's fallback when both rays of a sample
// miss M asks for M's nearest point through this interface. FLANN implements
// it in adapters/flann, brute force in the tests.
#pragma once

#include "core/error.h"
#include "core/geometry.h"

#include <optional>

namespace apo {

// A point of a surface with the surface's unit normal there.
struct SurfacePoint {
  Vec3f position = Vec3f::Zero();
  Vec3f normal = Vec3f::Zero();
};

class ClosestPointFinder {
 public:
  virtual ~ClosestPointFinder() = default;
  // The surface's point nearest `query`. Thread-safe and never throws; empty
  // only when the search could not be made (its adapter says why).
  virtual std::optional<SurfacePoint> closest(const Vec3f& query) const = 0;
  // Returns once the finder can answer, or why it never will: a finder may
  // still be building its structure (the bake builds a point scan's k-d tree
  // beside its projection onto m). Call it before the first query.
  virtual Status ready() const { return okStatus(); }
};

}  // namespace apo
