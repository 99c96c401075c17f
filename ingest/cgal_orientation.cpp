#include "ingest/cgal_adapter.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/mst_orient_normals.h>
#include <CGAL/property_map.h>

#include <algorithm>
#include <cstdint>
#include <numeric>

namespace apo::cgal_adapter {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;

// Property maps reading our arrays through an index, so CGAL reorders only the
// index vector, never our data.
struct PositionMap {
  using key_type = std::uint32_t;
  using value_type = Kernel::Point_3;
  using reference = value_type;
  using category = boost::readable_property_map_tag;
  const std::vector<Vec3f>* positions;
  friend value_type get(const PositionMap& map, key_type i) {
    const Vec3f& p = (*map.positions)[i];
    return {p.x(), p.y(), p.z()};
  }
};

struct NormalMap {
  using key_type = std::uint32_t;
  using value_type = Kernel::Vector_3;
  using reference = value_type;
  using category = boost::read_write_property_map_tag;
  std::vector<Vec3f>* normals;
  friend value_type get(const NormalMap& map, key_type i) {
    const Vec3f& n = (*map.normals)[i];
    return {n.x(), n.y(), n.z()};
  }
  friend void put(const NormalMap& map, key_type i, const value_type& n) {
    (*map.normals)[i] = Vec3f(static_cast<float>(n.x()), static_cast<float>(n.y()), static_cast<float>(n.z()));
  }
};

}  // namespace

std::vector<std::uint32_t> orientNormalsMst(const std::vector<Vec3f>& positions, std::vector<Vec3f>& normals, int k) {
  std::vector<std::uint32_t> indices(positions.size());
  std::iota(indices.begin(), indices.end(), 0u);
  const auto firstUnoriented = CGAL::mst_orient_normals(
      indices, static_cast<unsigned int>(k),
      CGAL::parameters::point_map(PositionMap{&positions}).normal_map(NormalMap{&normals}));
  std::vector<std::uint32_t> unoriented(firstUnoriented, indices.end());
  std::sort(unoriented.begin(), unoriented.end());
  return unoriented;
}

}  // namespace apo::cgal_adapter
