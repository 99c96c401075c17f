// Closest point of a triangle, shared by the bake's sampling (ray origins)
// and the FLANN closest-point adapter (the candidate triangles).
#pragma once

#include "core/geometry.h"

#include <limits>

namespace apo {

struct TrianglePoint {
  Vec3f position = Vec3f::Zero();
  Vec3f weights = Vec3f::Zero();  // barycentrics of a, b, c
  float squaredDistance = std::numeric_limits<float>::infinity();  // to the query
};

// The point of triangle abc closest to p (Ericson, Real-Time Collision
// Detection, 5.1.5): the Voronoi region (vertex, edge or face) that holds p's
// projection. A triangle without area, or a sliver whose rounding leaves its
// doubled area non-positive, is treated as its three edges.
TrianglePoint closestPointOnTriangle(const Vec3f& p, const Vec3f& a, const Vec3f& b, const Vec3f& c);

}  // namespace apo
