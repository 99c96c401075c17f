// CGAL advancing front surface reconstruction with its default parameters.
#include "adapters/cgal/cgal_jobs.h"

#include "core/deterministic_heap.h"

#include <CGAL/Advancing_front_surface_reconstruction.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

#include <algorithm>
#include <array>
#include <cstddef>
#include <iterator>

namespace apo::cgal_adapter {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;

// CGAL's defaults, named: a candidate triangle folding against its
// neighbour by more than the angle beta (radians) is refused when its radius
// exceeds this multiple of the neighbour's.
constexpr double kRadiusRatioBound = 5.0;
constexpr double kBeta = 0.52;

std::vector<Kernel::Point_3> toCgal(const std::vector<Vec3f>& points) {
  std::vector<Kernel::Point_3> converted;
  converted.reserve(points.size());
  for (const Vec3f& p : points) converted.emplace_back(p.x(), p.y(), p.z());
  return converted;
}

// Each triangle starting at its smallest index, triangles in lexicographic
// order: CGAL lists the triangles in the order of its containers.
void sortCanonically(std::vector<Triangle>& triangles) {
  for (Triangle& t : triangles) std::rotate(t.begin(), std::min_element(t.begin(), t.end()), t.end());
  std::sort(triangles.begin(), triangles.end());
}

Result<Scan> reconstruct(const std::vector<Vec3f>& points) {
  const auto cgalPoints = toCgal(points);
  // CGAL breaks ties between candidate edges by their records' addresses:
  // made in a deterministic heap, the surface depends on the points alone.
  const auto facets = madeInDeterministicHeap([&] {
    std::vector<std::array<std::size_t, 3>> made;
    CGAL::advancing_front_surface_reconstruction(cgalPoints.begin(), cgalPoints.end(), std::back_inserter(made),
                                                 kRadiusRatioBound, kBeta);
    return made;
  });
  if (facets.empty()) return badInput("advancing front reconstruction produced no surface from {} points", points.size());
  Scan mesh;
  mesh.points.positions = points;  // facets index the input order
  mesh.triangles.reserve(facets.size());
  for (const auto& f : facets)
    mesh.triangles.push_back({static_cast<std::uint32_t>(f[0]), static_cast<std::uint32_t>(f[1]),
                              static_cast<std::uint32_t>(f[2])});
  sortCanonically(mesh.triangles);
  return mesh;
}

}  // namespace

// The vertices are all the input points, in input order; those on no
// triangle stay in (the caller drops unreferenced vertices).
Result<Scan> advancingFrontReconstruct(const std::vector<Vec3f>& points) {
  if (points.size() < 4) return badInput("advancing front reconstruction needs at least 4 points, got {}", points.size());
  try {
    return reconstruct(points);
  } catch (const CGAL::Failure_exception& e) {
    return internalError("advancing front reconstruction failed: CGAL {}", e.what());
  } catch (const std::exception& e) {
    return internalError("advancing front reconstruction failed: {}", e.what());
  }
}

}  // namespace apo::cgal_adapter
