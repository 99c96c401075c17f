// CGAL normal orientation by minimum spanning tree.
#include "adapters/cgal/cgal_jobs.h"

#include "adapters/cgal/cgal_index_maps.h"

#include <CGAL/mst_orient_normals.h>

#include <algorithm>
#include <cstdint>
#include <utility>

namespace apo::cgal_adapter {

// CGAL writes the normals as it goes: they are restored when it throws, so
// that a failure leaves them as they were.
Result<std::vector<std::uint32_t>> orientNormalsMst(const std::vector<Vec3f>& positions, std::vector<Vec3f>& normals,
                                                    int k) {
  std::vector<Vec3f> oriented = normals;
  auto unoriented = catchLibraryErrors("CGAL MST normal orientation", [&] {
    auto indices = cgal_maps::allIndices(positions.size());
    const auto firstUnoriented = CGAL::mst_orient_normals(
        indices, static_cast<unsigned int>(k),
        CGAL::parameters::point_map(cgal_maps::PositionMap{&positions})
            .normal_map(cgal_maps::WritableNormalMap{&oriented}));
    std::vector<std::uint32_t> left(firstUnoriented, indices.end());
    std::sort(left.begin(), left.end());
    return left;
  });
  if (unoriented) normals = std::move(oriented);
  return unoriented;
}

}  // namespace apo::cgal_adapter
