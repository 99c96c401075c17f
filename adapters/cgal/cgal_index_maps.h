// CGAL property maps that read (or write) our arrays through a point index,
// so that CGAL's algorithms permute only a vector of indices, never our data.
// Internal to the CGAL adapter, shared by its files.
#pragma once

#include "core/geometry.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/property_map.h>

#include <cstdint>
#include <numeric>
#include <vector>

namespace apo::cgal_maps {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;

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
  using category = boost::readable_property_map_tag;
  const std::vector<Vec3f>* normals;
  friend value_type get(const NormalMap& map, key_type i) {
    const Vec3f& n = (*map.normals)[i];
    return {n.x(), n.y(), n.z()};
  }
};

// For algorithms that write normals back (orientation).
struct WritableNormalMap {
  using key_type = std::uint32_t;
  using value_type = Kernel::Vector_3;
  using reference = value_type;
  using category = boost::read_write_property_map_tag;
  std::vector<Vec3f>* normals;
  friend value_type get(const WritableNormalMap& map, key_type i) {
    const Vec3f& n = (*map.normals)[i];
    return {n.x(), n.y(), n.z()};
  }
  friend void put(const WritableNormalMap& map, key_type i, const value_type& n) {
    (*map.normals)[i] = Vec3f(static_cast<float>(n.x()), static_cast<float>(n.y()), static_cast<float>(n.z()));
  }
};

// 0, 1, ..., count - 1: the index range handed to CGAL.
inline std::vector<std::uint32_t> allIndices(std::size_t count) {
  std::vector<std::uint32_t> indices(count);
  std::iota(indices.begin(), indices.end(), 0u);
  return indices;
}

}  // namespace apo::cgal_maps
