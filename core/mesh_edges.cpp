#include "core/mesh_edges.h"

#include <algorithm>
#include <numeric>
#include <tuple>

namespace apo {

std::vector<TriangleSide> sortedSides(const std::vector<Triangle>& triangles) {
  std::vector<TriangleSide> sides;
  sides.reserve(3 * triangles.size());
  for (std::uint32_t t = 0; t < triangles.size(); ++t)
    for (std::uint32_t c = 0; c < 3; ++c) {
      const std::uint32_t a = triangles[t][c], b = triangles[t][(c + 1) % 3];
      if (a == b) continue;
      sides.push_back({(std::uint64_t{std::min(a, b)} << 32) | std::max(a, b), t, c});
    }
  std::sort(sides.begin(), sides.end(), [](const TriangleSide& x, const TriangleSide& y) {
    return std::tie(x.edge, x.triangle, x.corner) < std::tie(y.edge, y.triangle, y.corner);
  });
  return sides;
}

DisjointSets::DisjointSets(std::size_t count) : parent_(count) { std::iota(parent_.begin(), parent_.end(), 0u); }

std::uint32_t DisjointSets::find(std::uint32_t i) {
  while (parent_[i] != i) i = parent_[i] = parent_[parent_[i]];
  return i;
}

void DisjointSets::unite(std::uint32_t a, std::uint32_t b) {
  a = find(a);
  b = find(b);
  if (a < b) parent_[b] = a;
  if (b < a) parent_[a] = b;
}

}  // namespace apo
