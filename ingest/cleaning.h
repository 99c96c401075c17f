// Internal to ingest: cleaning steps over a Scan. Each returns how many points
// (or triangles) it removed, keeps the relative order of what remains, and
// keeps every per-point attribute and the triangles' indices consistent
// (core/mesh_edit.h holds the steps that reconstruct shares).
#pragma once

#include "core/geometry.h"

#include <cstddef>
#include <cstdint>
#include <vector>

namespace apo::cleaning {

// Points with a NaN or infinite coordinate.
std::size_t dropNonFinitePoints(Scan& scan);

// Points at exactly the same position as an earlier one; the first keeps its
// attributes and, for a mesh, the triangles of the others are re-pointed to it.
std::size_t mergeDuplicatePoints(Scan& scan);

// Triangles over the same three vertices as an earlier one (any order).
std::size_t dropDuplicateTriangles(Scan& scan);

// Normalises normals to unit length; returns how many were zero or
// non-finite (left as they are, for the caller to decide).
std::size_t normaliseNormals(PointSet& points);

}  // namespace apo::cleaning

namespace apo::cleaning {

// Voxel downsampling that keeps real samples: of the points in each cubic
// voxel of side `voxelSize` (grid anchored at the bounding box minimum), the
// one closest to the voxel's centroid is kept, with all its attributes.
// Ties go to the lower index, so the result is deterministic.
std::vector<char> voxelRepresentativeMask(const std::vector<Vec3f>& positions, double voxelSize);

}  // namespace apo::cleaning
