// The ray-casting seam: algorithms (virtual scanner, bake sampling) cast rays
// through this interface; Embree implements it in one adapter file and a
// brute-force version can stand in for tests.
#pragma once

#include "core/error.h"
#include "core/geometry.h"

#include <cstdint>
#include <limits>
#include <vector>

namespace apo {

struct Ray {
  Vec3f origin = Vec3f::Zero();
  Vec3f direction = Vec3f::UnitZ();  // need not be unit; t is in its units
  float tNear = 0.0f;
  float tFar = std::numeric_limits<float>::infinity();
};

struct RayHit {
  static constexpr std::uint32_t kNone = ~0u;
  std::uint32_t primitive = kNone;  // triangle index, kNone when missed
  float t = std::numeric_limits<float>::infinity();
  float u = 0.0f, v = 0.0f;  // barycentrics: point = (1-u-v) a + u b + v c
  Vec3f geometricNormal = Vec3f::Zero();  // unnormalised, (b-a) x (c-a)

  bool hit() const { return primitive != kNone; }
};

class RayCaster {
 public:
  virtual ~RayCaster() = default;
  // Nearest hit of each ray; hits[i] answers rays[i]. Deterministic.
  virtual void intersect(const std::vector<Ray>& rays, std::vector<RayHit>& hits) const = 0;
  // Returns once the caster can answer, or why it never will: a caster may
  // still have its structure to build (the bake builds M's when the sampling
  // first asks). Call it before the first intersect.
  virtual Status ready() const { return okStatus(); }
};

}  // namespace apo
