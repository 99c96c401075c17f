// CGAL point set processing: average spacing and grid subsampling, both over
// an index vector read through a property map so that our arrays stay put.
#include "adapters/cgal/cgal_jobs.h"

#include "adapters/cgal/cgal_index_maps.h"

#include <CGAL/compute_average_spacing.h>
#include <CGAL/grid_simplify_point_set.h>

#include <algorithm>
#include <cstdint>
#include <numeric>

namespace apo::cgal_adapter {

// Note CGAL's definition: the query point itself is one of the k + 1 points
// averaged, so the value is (sum of the k nearest distances) / (k + 1). We
// keep it as is because CGAL's size parameters (Poisson's sm_distance, ...)
// are expressed in this unit.
// CGAL requires k >= 2 (a debug-build precondition), so k = 1 counts as 2.
Result<double> averageSpacing(const std::vector<Vec3f>& points, int k) {
  if (points.size() < 2) return 0.0;
  return catchLibraryErrors("CGAL average spacing", [&] {
    const auto indices = cgal_maps::allIndices(points.size());
    return CGAL::compute_average_spacing<CGAL::Parallel_if_available_tag>(
        indices, static_cast<unsigned int>(std::max(k, 2)), CGAL::parameters::point_map(cgal_maps::PositionMap{&points}));
  });
}

// CGAL keeps the first index of each cell it meets; std::partition visits the
// indices in a fixed order, so the mask is deterministic. Cells are
// floor(coordinate / cellSize), anchored at the origin. A cell of no size
// (spacing of duplicated points) merges nothing.
Result<std::vector<char>> gridSubsampleMask(const std::vector<Vec3f>& points, double cellSize) {
  if (!(cellSize > 0.0)) return std::vector<char>(points.size(), 1);
  return catchLibraryErrors("CGAL grid subsampling", [&] {
    auto indices = cgal_maps::allIndices(points.size());
    const auto firstRemoved =
        CGAL::grid_simplify_point_set(indices, cellSize, CGAL::parameters::point_map(cgal_maps::PositionMap{&points}));
    std::vector<char> keep(points.size(), 0);
    for (auto it = indices.begin(); it != firstRemoved; ++it) keep[*it] = 1;
    return keep;
  });
}

}  // namespace apo::cgal_adapter
