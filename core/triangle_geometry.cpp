#include "core/triangle_geometry.h"

#include <algorithm>
#include <utility>

namespace apo {
namespace {

TrianglePoint pointWithWeights(const Vec3f& p, const Vec3f& a, const Vec3f& b, const Vec3f& c, const Vec3f& weights) {
  const Vec3f position = weights.x() * a + weights.y() * b + weights.z() * c;
  return {position, weights, (p - position).squaredNorm()};
}

// Closest point to p on the segment from `from` to `to`, as the weights of
// (from, to); a zero-length segment is its first end.
std::pair<float, float> segmentWeights(const Vec3f& p, const Vec3f& from, const Vec3f& to) {
  const Vec3f edge = to - from;
  const float length2 = edge.squaredNorm();
  const float s = length2 > 0.0f ? std::clamp(edge.dot(p - from) / length2, 0.0f, 1.0f) : 0.0f;
  return {1.0f - s, s};
}

// A triangle without area is its three edges.
TrianglePoint closestOnEdges(const Vec3f& p, const Vec3f& a, const Vec3f& b, const Vec3f& c) {
  const auto [ab0, ab1] = segmentWeights(p, a, b);
  const auto [bc0, bc1] = segmentWeights(p, b, c);
  const auto [ca0, ca1] = segmentWeights(p, c, a);
  TrianglePoint best = pointWithWeights(p, a, b, c, Vec3f(ab0, ab1, 0.0f));
  for (const Vec3f& weights : {Vec3f(0.0f, bc0, bc1), Vec3f(ca1, 0.0f, ca0)}) {
    const TrianglePoint candidate = pointWithWeights(p, a, b, c, weights);
    if (candidate.squaredDistance < best.squaredDistance) best = candidate;
  }
  return best;
}

}  // namespace

TrianglePoint closestPointOnTriangle(const Vec3f& p, const Vec3f& a, const Vec3f& b, const Vec3f& c) {
  const Vec3f ab = b - a, ac = c - a, ap = p - a;
  // Ericson divides by squared edge lengths and the squared area: degenerate
  // triangles take the edge route instead of dividing by zero.
  if (ab.cross(ac).squaredNorm() == 0.0f) return closestOnEdges(p, a, b, c);
  const float d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0.0f && d2 <= 0.0f) return pointWithWeights(p, a, b, c, Vec3f(1, 0, 0));
  const Vec3f bp = p - b;
  const float d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0.0f && d4 <= d3) return pointWithWeights(p, a, b, c, Vec3f(0, 1, 0));
  const float vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0f && d1 >= 0.0f && d3 <= 0.0f) {
    const float v = d1 / (d1 - d3);
    return pointWithWeights(p, a, b, c, Vec3f(1 - v, v, 0));
  }
  const Vec3f cp = p - c;
  const float d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0.0f && d5 <= d6) return pointWithWeights(p, a, b, c, Vec3f(0, 0, 1));
  const float vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0f && d2 >= 0.0f && d6 <= 0.0f) {
    const float w = d2 / (d2 - d6);
    return pointWithWeights(p, a, b, c, Vec3f(1 - w, 0, w));
  }
  const float va = d3 * d6 - d5 * d4;
  if (va <= 0.0f && (d4 - d3) >= 0.0f && (d5 - d6) >= 0.0f) {
    const float w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return pointWithWeights(p, a, b, c, Vec3f(0, 1 - w, w));
  }
  // Inside the face. The sum is the squared doubled area up to rounding; a
  // sliver whose rounding leaves it non-positive is treated as its edges.
  const float sum = va + vb + vc;
  if (!(sum > 0.0f)) return closestOnEdges(p, a, b, c);
  const float v = vb / sum, w = vc / sum;
  return pointWithWeights(p, a, b, c, Vec3f(1 - v - w, v, w));
}

}  // namespace apo
