// A flat grid of M's triangles with known sizes, for the tests of the sum
// depth (l21_metric_test.cpp) and of M in a cell's face (octree_build_test.cpp).
#pragma once

#include "bake/octree_build.h"

#include <cstdint>
#include <vector>

namespace apo::octree {

// A flat grid of n x n squares of side `leg`, two right triangles each, at
// height z, plus M's normals (all +z).
inline DetailPrimitives flatGrid(int n, float leg, float z, DetailPrimitives grid = {}) {
  std::vector<Vec3f> positions, normals;
  std::vector<Triangle> triangles;
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j <= n; ++j) {
      positions.emplace_back(0.25f + leg * static_cast<float>(i), 0.25f + leg * static_cast<float>(j), z);
      normals.emplace_back(0.0f, 0.0f, 1.0f);
    }
  const auto at = [&](int i, int j) { return static_cast<std::uint32_t>(i * (n + 1) + j); };
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      triangles.push_back({at(i, j), at(i + 1, j), at(i + 1, j + 1)});
      triangles.push_back({at(i, j), at(i + 1, j + 1), at(i, j + 1)});
    }
  DetailPrimitives added = DetailPrimitives::ofMesh(positions, triangles, normals, 1.0);
  grid.triangles.insert(grid.triangles.end(), added.triangles.begin(), added.triangles.end());
  return grid;
}


}  // namespace apo::octree
