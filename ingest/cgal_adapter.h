// Internal to ingest: the only door to CGAL in this stage.
#pragma once

#include "core/geometry.h"

#include <cstddef>
#include <cstdint>
#include <vector>

namespace apo::cgal_adapter {

// CGAL::mst_orient_normals over a k-nearest-neighbour Riemannian graph:
// flips normals so that neighbours agree, seeded at the highest point (whose
// normal is turned to +z). Points outside the seed's connected component are
// left as they were; returns their indices, ascending.
std::vector<std::uint32_t> orientNormalsMst(const std::vector<Vec3f>& positions, std::vector<Vec3f>& normals, int k);

}  // namespace apo::cgal_adapter
