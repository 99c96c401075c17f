// Triangles against the octree's cells (cell_clip.h): the separating-axis
// overlap tests and the clip of a triangle to a cell.
#include "bake/cell_clip.h"

#include <algorithm>
#include <array>
#include <utility>

namespace apo::octree {
namespace {

// Projections of the three corners on `axis` against the box's radius on it.
bool separatedOn(const Vec3f& axis, const Vec3f& v0, const Vec3f& v1, const Vec3f& v2, const Vec3f& half) {
  const float p0 = axis.dot(v0), p1 = axis.dot(v1), p2 = axis.dot(v2);
  const float radius = half.dot(axis.cwiseAbs());
  return std::min({p0, p1, p2}) > radius || std::max({p0, p1, p2}) < -radius;
}

// The part of the triangle inside the cell, in its (u, v) coordinates.
// Only the faces the triangle crosses cut: most triangles filed into a child
// cross one or two of its six faces.
ParameterPolygon clipInParameters(const TriangleFrame& frame, const Cell& cell) {
  std::array<ParameterPolygon, 2> buffers;
  ParameterPolygon* polygon = &buffers[0];
  ParameterPolygon* scratch = &buffers[1];
  polygon->corners = {Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(1.0, 0.0), Eigen::Vector2d(0.0, 1.0)};
  polygon->size = 3;
  const Vec3f lower = cell.lower(), upper = cell.upper();
  // Keeps sign * (p[axis] - bound) <= 0.
  const auto clip = [&](int axis, float bound, double sign) {
    clipAgainstLine(*polygon, sign * (frame.origin[axis] - bound), sign * frame.alongU[axis], sign * frame.alongV[axis],
                    *scratch);
    std::swap(polygon, scratch);
  };
  for (int axis = 0; axis < 3 && polygon->size > 0; ++axis) {
    if (frame.hi[axis] > upper[axis]) clip(axis, upper[axis], 1.0);
    if (frame.lo[axis] < lower[axis] && polygon->size > 0) clip(axis, lower[axis], -1.0);
  }
  return *polygon;
}

}  // namespace

bool triangleOverlapsBox(const Vec3f& a, const Vec3f& b, const Vec3f& c, const Cell& cell) {
  const Vec3f half = Vec3f::Constant(0.5f * cell.width);
  const Vec3f v0 = a - cell.centre, v1 = b - cell.centre, v2 = c - cell.centre;
  for (int axis = 0; axis < 3; ++axis)
    if (std::min({v0[axis], v1[axis], v2[axis]}) > half[axis] || std::max({v0[axis], v1[axis], v2[axis]}) < -half[axis])
      return false;
  const std::array<Vec3f, 3> edges = {v1 - v0, v2 - v1, v0 - v2};
  if (separatedOn(edges[0].cross(edges[1]), v0, v1, v2, half)) return false;
  for (const Vec3f& edge : edges)
    for (int axis = 0; axis < 3; ++axis)
      if (separatedOn(Vec3f::Unit(axis).cross(edge), v0, v1, v2, half)) return false;
  return true;
}

// One projection of the corners per axis for the eight children: a child's
// centre shifts it by its offset along the axis (a child's half width and
// its centre's offset on each axis are both a quarter of the cell's width).
// Where a child's gap on an axis is within rounding of zero (m touching the
// child's box: CAD models whose faces pass through cells' corners), the
// child is tested apart, so that every answer is triangleOverlapsBox's.
std::uint8_t childrenMeeting(const Vec3f& a, const Vec3f& b, const Vec3f& c, const Cell& cell, std::uint8_t wanted) {
  // Far above either computation's rounding (float's epsilon is 1.2e-7),
  // relative to the magnitudes the projections are made of.
  constexpr float kRounding = 1e-5f;
  const float quarter = 0.25f * cell.width;
  const Vec3f v0 = a - cell.centre, v1 = b - cell.centre, v2 = c - cell.centre;
  const float reach = v0.cwiseAbs().cwiseMax(v1.cwiseAbs()).cwiseMax(v2.cwiseAbs()).maxCoeff() + 2.0f * quarter;
  unsigned meeting = wanted, unsure = 0;
  // `gap` > 0: the children and the triangle are apart along the axis.
  const auto judge = [&](unsigned children, float gap, float tolerance) {
    if (gap > tolerance)
      meeting &= ~children;
    else if (gap >= -tolerance)
      unsure |= children;
  };
  // Box axes: the lower children on an axis (bit 1, childCentre) span
  // [-2 quarter, 0] from the centre, the upper ones [0, 2 quarter].
  constexpr std::array<unsigned, 3> kLowerOn{0xF0, 0xCC, 0xAA};
  for (int axis = 0; axis < 3; ++axis) {
    const float lo = std::min({v0[axis], v1[axis], v2[axis]}), hi = std::max({v0[axis], v1[axis], v2[axis]});
    judge(kLowerOn[axis], std::max(lo, -2.0f * quarter - hi), kRounding * reach);
    judge(~kLowerOn[axis] & 0xFFu, std::max(lo - 2.0f * quarter, -hi), kRounding * reach);
  }
  const auto separate = [&](const Vec3f& axis) {
    const float p0 = axis.dot(v0), p1 = axis.dot(v1), p2 = axis.dot(v2);
    const float lo = std::min({p0, p1, p2}), hi = std::max({p0, p1, p2});
    const Vec3f shift = quarter * axis;
    const float radius = quarter * axis.cwiseAbs().sum();
    const float tolerance = kRounding * axis.cwiseAbs().sum() * reach;
    // All eight children judged at once, without a branch per child (with
    // the sampling's clip in place, 4% of the bunny's CPU time less than a
    // loop skipping those already apart: docs/bake.md, "A faster build"); a
    // child already apart is judged again to no effect.
    std::array<float, 8> gap;
    for (unsigned child = 0; child < 8; ++child) {
      const float offset = ((child & 4) ? -shift.x() : shift.x()) + ((child & 2) ? -shift.y() : shift.y()) +
                           ((child & 1) ? -shift.z() : shift.z());
      gap[child] = std::max(lo - offset - radius, -radius - (hi - offset));
    }
    unsigned apart = 0, near = 0;
    for (unsigned child = 0; child < 8; ++child) {
      apart |= static_cast<unsigned>(gap[child] > tolerance) << child;
      near |= static_cast<unsigned>(gap[child] >= -tolerance) << child;
    }
    meeting &= ~apart;
    unsure |= near & ~apart;
  };
  const std::array<Vec3f, 3> edges = {v1 - v0, v2 - v1, v0 - v2};
  if (meeting != 0) separate(edges[0].cross(edges[1]));
  for (const Vec3f& edge : edges)
    for (int axis = 0; axis < 3 && meeting != 0; ++axis) separate(Vec3f::Unit(axis).cross(edge));
  for (unsigned child = 0; child < 8; ++child)
    if ((meeting & unsure & (1u << child)) && !triangleOverlapsBox(a, b, c, cell.child(static_cast<int>(child))))
      meeting &= ~(1u << child);
  return static_cast<std::uint8_t>(meeting);
}

CellPolygon clipTriangleToCell(const Vec3f& a, const Vec3f& b, const Vec3f& c, const Cell& cell) {
  const TriangleFrame frame(a, b, c);
  const ParameterPolygon part = clipInParameters(frame, cell);
  CellPolygon polygon;
  for (int k = 0; k < part.size; ++k)
    polygon.corners[polygon.size++] =
        (frame.origin + part.corners[k].x() * frame.alongU + part.corners[k].y() * frame.alongV).cast<float>();
  return polygon;
}

double polygonArea(std::span<const Vec3f> polygon) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (std::size_t i = 1; i + 1 < polygon.size(); ++i)
    sum += (polygon[i] - polygon[0]).cast<double>().cross((polygon[i + 1] - polygon[0]).cast<double>());
  return 0.5 * sum.norm();
}

Eigen::Vector3f barycentricsOf(const Vec3f& p, const Vec3f& a, const Vec3f& b, const Vec3f& c) {
  const Vec3f v0 = b - a, v1 = c - a, v2 = p - a;
  const double d00 = v0.dot(v0), d01 = v0.dot(v1), d11 = v1.dot(v1), d20 = v2.dot(v0), d21 = v2.dot(v1);
  const double denominator = d00 * d11 - d01 * d01;
  if (!(denominator > 0.0)) return {1.0f, 0.0f, 0.0f};
  const double v = (d11 * d20 - d01 * d21) / denominator, w = (d00 * d21 - d01 * d20) / denominator;
  Eigen::Vector3f weights(static_cast<float>(1.0 - v - w), static_cast<float>(v), static_cast<float>(w));
  weights = weights.cwiseMax(0.0f);  // the point is on the triangle up to rounding
  return weights / weights.sum();
}

}  // namespace apo::octree
