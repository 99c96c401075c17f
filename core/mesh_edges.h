// The edges of a triangle soup without a hash table: every side of every
// triangle sorted by the undirected edge it lies on, so that the sides of
// one edge are adjacent, in a deterministic order; and the union-find the
// edge walks feed. Shared by ingest (closed pieces, overlapping scans),
// reconstruct (mesh figures, components) and the meshoptimizer adapter
// (pinched pockets).
#pragma once

#include "core/geometry.h"

#include <cstdint>
#include <vector>

namespace apo {

// One side of one triangle: the undirected edge it lies on and where it is.
struct TriangleSide {
  std::uint64_t edge = 0;  // smaller vertex << 32 | larger vertex
  std::uint32_t triangle = 0;
  std::uint32_t corner = 0;  // the side runs from corner to corner + 1 (mod 3)
  std::uint32_t from() const { return static_cast<std::uint32_t>(edge >> 32); }
  std::uint32_t to() const { return static_cast<std::uint32_t>(edge & 0xFFFFFFFFu); }
};

// Every side of every triangle but collapsed ones (both ends at one vertex:
// on no edge), sorted by edge, then triangle, then corner.
std::vector<TriangleSide> sortedSides(const std::vector<Triangle>& triangles);

// Calls visit(first, last) for each run [first, last) of sides on one edge.
template <class Visit>
void forEachEdge(const std::vector<TriangleSide>& sides, Visit&& visit) {
  for (std::size_t first = 0; first < sides.size();) {
    std::size_t last = first + 1;
    while (last < sides.size() && sides[last].edge == sides[first].edge) ++last;
    visit(first, last);
    first = last;
  }
}

// Union-find whose roots are the smallest index of each set, so that every
// answer depends on the input order only (not on the order of the unions).
class DisjointSets {
 public:
  explicit DisjointSets(std::size_t count);
  std::uint32_t find(std::uint32_t i);
  void unite(std::uint32_t a, std::uint32_t b);

 private:
  std::vector<std::uint32_t> parent_;
};

}  // namespace apo
