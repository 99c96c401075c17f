// CGAL scale-space surface reconstruction: smooth a copy of the points with
// weighted PCA, mesh the smoothed copy with the advancing front, and put the
// triangles back on the original points.
#include "adapters/cgal/cgal_jobs.h"

#include "core/deterministic_heap.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Scale_space_reconstruction_3/Advancing_front_mesher.h>
#include <CGAL/Scale_space_reconstruction_3/Weighted_PCA_smoother.h>
#include <CGAL/Scale_space_surface_reconstruction_3.h>

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace apo::cgal_adapter {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Reconstruction = CGAL::Scale_space_surface_reconstruction_3<Kernel>;
using Smoother = CGAL::Scale_space_reconstruction_3::Weighted_PCA_smoother<Kernel>;
using Mesher = CGAL::Scale_space_reconstruction_3::Advancing_front_mesher<Kernel>;

constexpr double kDefaultScaleSpacings = 4.0;
constexpr std::size_t kSmoothingIterations = 4;
// The mesher refuses triangles with an edge longer than this many average
// spacings: longer ones bridge holes of the scan.
constexpr double kMaxEdgeSpacings = 5.0;

Status validate(const std::vector<Vec3f>& points, double averageSpacing) {
  if (points.size() < 4) return badInput("scale-space reconstruction needs at least 4 points, got {}", points.size());
  if (!(averageSpacing > 0.0) || !std::isfinite(averageSpacing))
    return badInput("scale-space reconstruction failed: average spacing {} is not positive", averageSpacing);
  return okStatus();
}

// Each triangle starting at its smallest index, triangles in lexicographic
// order: CGAL lists the triangles in the order of its containers.
void sortCanonically(std::vector<Triangle>& triangles) {
  for (Triangle& t : triangles) std::rotate(t.begin(), std::min_element(t.begin(), t.end()), t.end());
  std::sort(triangles.begin(), triangles.end());
}

Result<Scan> reconstruct(const std::vector<Vec3f>& points, double averageSpacing, double scaleSpacings) {
  // The mesher is CGAL's advancing front, which breaks ties between
  // candidate edges by their records' addresses: made in a deterministic
  // heap, the surface depends on the points alone.
  auto triangles = madeInDeterministicHeap([&] {
    Reconstruction reconstruction;
    for (const Vec3f& p : points) reconstruction.insert(Kernel::Point_3(p.x(), p.y(), p.z()));
    const double scale = scaleSpacings * averageSpacing;
    reconstruction.increase_scale(kSmoothingIterations, Smoother(scale * scale));  // takes the squared radius
    reconstruction.reconstruct_surface(Mesher(kMaxEdgeSpacings * averageSpacing));
    // CGAL smooths its copy in place, without reordering: the facets' indices
    // are the input order, so they index our unsmoothed points as well.
    std::vector<Triangle> made;
    made.reserve(reconstruction.number_of_facets());
    for (auto f = reconstruction.facets_begin(); f != reconstruction.facets_end(); ++f)
      made.push_back({static_cast<std::uint32_t>((*f)[0]), static_cast<std::uint32_t>((*f)[1]),
                      static_cast<std::uint32_t>((*f)[2])});
    return made;
  });
  if (triangles.empty()) return badInput("scale-space reconstruction produced no surface from {} points", points.size());
  Scan mesh;
  mesh.points.positions = points;
  mesh.triangles = std::move(triangles);
  sortCanonically(mesh.triangles);
  return mesh;
}

}  // namespace

// The vertices are all the input points (unsmoothed), in input order; those
// on no triangle stay in (the caller drops unreferenced vertices).
Result<Scan> scaleSpaceReconstruct(const std::vector<Vec3f>& points, double averageSpacing, double scaleSpacings) {
  APO_RETURN_IF_ERROR(validate(points, averageSpacing));
  try {
    return reconstruct(points, averageSpacing, scaleSpacings > 0.0 ? scaleSpacings : kDefaultScaleSpacings);
  } catch (const CGAL::Failure_exception& e) {
    return internalError("scale-space reconstruction failed: CGAL {}", e.what());
  } catch (const std::exception& e) {
    return internalError("scale-space reconstruction failed: {}", e.what());
  }
}

}  // namespace apo::cgal_adapter
