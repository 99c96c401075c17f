// The meshoptimizer adapter (target apo_meshopt): its quadric edge collapse
// as a fast first pass of simplification. It keeps no manifold guarantee of
// its own (CGAL's collapses, which do, finish the job), but removes a million
// triangles in a second where CGAL's take thirty.
#pragma once

#include "core/error.h"
#include "core/geometry.h"

#include <cstdint>
#include <vector>

namespace apo::meshopt_adapter {

struct QuickCollapse {
  Scan mesh;                  // the input's vertices that remain, with their attributes
  std::vector<std::uint32_t> sourceVertex;  // per vertex of `mesh`: its index in the input
  double relativeError = 0.0; // meshoptimizer's error, a fraction of the mesh's extent
  std::uint64_t coincidentTriangles = 0;  // back-to-back pairs ("fins") removed
  std::uint64_t pockets = 0;              // small pieces pinched off at a vertex, removed
};

// Collapses edges of `mesh` (quadric cost, border vertices moved along their
// border only) until it has at most `targetFaces` triangles or a collapse
// would move the surface by more than `maxRelativeError` of its extent.
// Triangles left over the same three vertices as another (back-to-back
// "fins" the collapses fold) and pieces of at most 64 triangles joined to
// the rest only through a vertex or a non-manifold edge (pockets it pinches
// off) are removed. Deterministic (meshoptimizer is
// single-threaded). BadInput when a triangle names a vertex out of range.
Result<QuickCollapse> quickCollapse(const Scan& mesh, std::uint64_t targetFaces, double maxRelativeError);

}  // namespace apo::meshopt_adapter
