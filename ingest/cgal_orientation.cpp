#include "ingest/cgal_adapter.h"

#include "ingest/cgal_index_maps.h"

#include <CGAL/mst_orient_normals.h>

#include <algorithm>
#include <cstdint>

namespace apo::cgal_adapter {

std::vector<std::uint32_t> orientNormalsMst(const std::vector<Vec3f>& positions, std::vector<Vec3f>& normals, int k) {
  auto indices = cgal_maps::allIndices(positions.size());
  const auto firstUnoriented = CGAL::mst_orient_normals(
      indices, static_cast<unsigned int>(k),
      CGAL::parameters::point_map(cgal_maps::PositionMap{&positions})
          .normal_map(cgal_maps::WritableNormalMap{&normals}));
  std::vector<std::uint32_t> unoriented(firstUnoriented, indices.end());
  std::sort(unoriented.begin(), unoriented.end());
  return unoriented;
}

}  // namespace apo::cgal_adapter
