// A thin part with known normals: two parallel bumpy sheets facing away
// from each other (the two sides of a leaf, a blade, sheet metal), closer
// than the octree's finest cells, tilted so that cell boundaries cross them
// every way. M's sheets are z = +-h + a f(u, v) over the unit square, f =
// sin(2 pi k u) sin(2 pi k v); m's are the flat planes z = +-h.
#pragma once

#include "core/geometry.h"
#include "tests/test_support.h"

#include <Eigen/Geometry>

#include <cmath>
#include <numbers>

namespace apo::test {

struct ThinShell {
  float halfThickness = 0.0015f;  // 0.003 apart: under half a cell of depth 7 (1/128)
  float amplitude = 0.0012f;      // below h: each sheet's rays meet their own sheet first
  int waves = 5;
  Eigen::Matrix3f rotation =
      (Eigen::AngleAxisf(0.5f, Vec3f::UnitX()) * Eigen::AngleAxisf(0.35f, Vec3f::UnitY())).toRotationMatrix();

  float height(float u, float v) const {
    const float w = 2.0f * std::numbers::pi_v<float> * static_cast<float>(waves);
    return amplitude * std::sin(w * u) * std::sin(w * v);
  }

  // The side's outward normal of M at (u, v): side 0 the upper sheet (+z
  // before the rotation), side 1 the lower.
  Vec3f normal(float u, float v, int side) const {
    const float w = 2.0f * std::numbers::pi_v<float> * static_cast<float>(waves);
    const float du = amplitude * w * std::cos(w * u) * std::sin(w * v);
    const float dv = amplitude * w * std::sin(w * u) * std::cos(w * v);
    const Vec3f up = Vec3f(-du, -dv, 1.0f).normalized();
    return rotation * (side == 0 ? up : Vec3f(-up));
  }
  Vec3f coarseNormal(int side) const { return rotation * (side == 0 ? Vec3f::UnitZ() : Vec3f(-Vec3f::UnitZ())); }

  Vec3f detailPoint(float u, float v, int side) const {
    return rotation * Vec3f(u, v, (side == 0 ? halfThickness : -halfThickness) + height(u, v));
  }
  Vec3f coarsePoint(float u, float v, int side) const {
    return rotation * Vec3f(u, v, side == 0 ? halfThickness : -halfThickness);
  }

  // M (gridSize x gridSize quads per sheet, exact vertex normals) or m
  // (flat sheets, their normals).
  Scan mesh(int gridSize, bool detail) const {
    Scan both;
    for (int side = 0; side < 2; ++side) {
      const Scan grid = makeSquareGrid(gridSize);
      const auto first = static_cast<std::uint32_t>(both.points.size());
      for (const Vec3f& p : grid.points.positions) {
        both.points.positions.push_back(detail ? detailPoint(p.x(), p.y(), side) : coarsePoint(p.x(), p.y(), side));
        both.points.normals.push_back(detail ? normal(p.x(), p.y(), side) : coarseNormal(side));
      }
      for (const Triangle& t : grid.triangles)  // the lower sheet wound the other way: facing -z
        both.triangles.push_back(side == 0 ? Triangle{first + t[0], first + t[1], first + t[2]}
                                           : Triangle{first + t[0], first + t[2], first + t[1]});
    }
    return both;
  }
};

}  // namespace apo::test
