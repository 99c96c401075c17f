// CGAL AABB tree: distances from points to a triangle mesh.
#include "adapters/cgal/cgal_jobs.h"

#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cmath>
#include <limits>
#include <vector>

namespace apo::cgal_adapter {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Triangle3 = Kernel::Triangle_3;
using TrianglePrimitive = CGAL::AABB_triangle_primitive<Kernel, std::vector<Triangle3>::const_iterator>;
using TriangleTree = CGAL::AABB_tree<CGAL::AABB_traits<Kernel, TrianglePrimitive>>;

Kernel::Point_3 toPoint(const Vec3f& p) { return {p.x(), p.y(), p.z()}; }

std::vector<Triangle3> cgalTriangles(const Scan& mesh) {
  const auto& p = mesh.points.positions;
  std::vector<Triangle3> triangles;
  triangles.reserve(mesh.triangles.size());
  for (const Triangle& t : mesh.triangles) triangles.emplace_back(toPoint(p[t[0]]), toPoint(p[t[1]]), toPoint(p[t[2]]));
  return triangles;
}

}  // namespace

Result<std::vector<float>> pointToMeshDistances(const std::vector<Vec3f>& points, const Scan& mesh) {
  return catchLibraryErrors("CGAL AABB tree distances", [&] {
    std::vector<float> distances(points.size(), std::numeric_limits<float>::infinity());
    if (mesh.triangles.empty()) return distances;
    const std::vector<Triangle3> triangles = cgalTriangles(mesh);
    TriangleTree tree(triangles.begin(), triangles.end());
    // Built here, once: the queries below run in parallel (TBB hands a
    // worker's exception to this thread, where catchLibraryErrors takes it).
    tree.build();
    tree.accelerate_distance_queries();
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, points.size()), [&](const tbb::blocked_range<std::size_t>& range) {
      for (std::size_t i = range.begin(); i != range.end(); ++i)
        distances[i] = static_cast<float>(std::sqrt(tree.squared_distance(toPoint(points[i]))));
    });
    return distances;
  });
}

}  // namespace apo::cgal_adapter
