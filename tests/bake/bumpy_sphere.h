// The bake's ground truth: the unit sphere with smooth analytic bumps,
// r(d) = 1 + a sum_k exp(-|d - c_k|^2 / s^2) over unit directions d, whose
// exact normal is known everywhere: n ~ r d - grad_S r, grad_S r the
// gradient of r along the sphere.
#pragma once

#include "core/geometry.h"
#include "tests/test_support.h"

#include <vector>
#include <cmath>

namespace apo::test {

// Angle between two directions in degrees (any lengths).
inline double degreesBetween(const Vec3f& a, const Vec3f& b) {
  return std::atan2(static_cast<double>(a.cross(b).norm()), static_cast<double>(a.dot(b))) * 180.0 / 3.14159265358979323846;
}

struct BumpySphere {
  float amplitude = 0.04f;
  float width = 0.3f;  // s, in radians of the unit sphere (about)
  std::vector<Vec3f> centres = {Vec3f(0, 0, 1), Vec3f(1, 0, 0), Vec3f(0, -1, 0), Vec3f(-0.6f, 0.48f, -0.64f)};

  // Fine relief all over: 42 lower, narrower bumps, one towards each vertex
  // of a once-subdivided icosahedron, so that every view sees many.
  static BumpySphere allOver() {
    BumpySphere shape;
    shape.centres = makeIcosphere(1).points.positions;
    shape.amplitude = 0.02f;
    shape.width = 0.15f;
    return shape;
  }

  float radius(const Vec3f& d) const {
    float r = 1.0f;
    for (const Vec3f& c : centres) r += amplitude * std::exp(-(d - c).squaredNorm() / (width * width));
    return r;
  }

  Vec3f surfacePoint(const Vec3f& direction) const {
    const Vec3f d = direction.normalized();
    return radius(d) * d;
  }

  Vec3f normal(const Vec3f& direction) const {
    const Vec3f d = direction.normalized();
    Vec3f gradient = Vec3f::Zero();  // of r in 3D, restricted to the sphere below
    for (const Vec3f& c : centres)
      gradient += amplitude * std::exp(-(d - c).squaredNorm() / (width * width)) * (-2.0f / (width * width)) * (d - c);
    const Vec3f tangential = gradient - gradient.dot(d) * d;
    return (radius(d) * d - tangential).normalized();
  }

  // Whether a direction is within `reach` (radians, about) of a bump centre.
  bool nearBump(const Vec3f& direction, float reach) const {
    const Vec3f d = direction.normalized();
    for (const Vec3f& c : centres)
      if (d.dot(c.normalized()) > std::cos(reach)) return true;
    return false;
  }

  // The dense mesh M: an icosphere displaced onto the bumps, with the exact
  // normals as vertex normals.
  Scan mesh(int subdivisions) const {
    Scan sphere = makeIcosphere(subdivisions);
    sphere.points.normals.clear();
    for (Vec3f& p : sphere.points.positions) {
      sphere.points.normals.push_back(normal(p));
      p = surfacePoint(p);
    }
    return sphere;
  }
};

}  // namespace apo::test
