// Edits of a Scan that keep it consistent: every per-point attribute
// compacted with the points, triangle indices renumbered. Shared by ingest's
// cleaning and reconstruct's clean-up of M and m. Each returns how many
// points (or triangles) it removed and keeps the relative order of the rest.
#pragma once

#include "core/geometry.h"

#include <cstddef>
#include <vector>

namespace apo {

// Keeps the points whose flag is non-zero (`keep` has one flag per point);
// for a mesh, drops the triangles that use a removed point and renumbers the
// rest. Returns the number of points removed.
std::size_t keepPoints(Scan& scan, const std::vector<char>& keep);

// Triangles with a repeated vertex or zero area.
std::size_t dropDegenerateTriangles(Scan& mesh);

// Mesh vertices used by no triangle.
std::size_t dropUnreferencedVertices(Scan& mesh);

}  // namespace apo
