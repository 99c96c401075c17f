// CGAL AABB tree: distances from points to a triangle mesh.
#include "adapters/cgal/cgal_jobs.h"

#include <CGAL/AABB_traits.h>
#include <CGAL/AABB_tree.h>
#include <CGAL/AABB_triangle_primitive.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <utility>
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

// The hints of the distance queries: a query starts from the nearest hint's
// triangle, so a few hints per query are enough (CGAL's default, a hint per
// triangle, costs a k-d tree of 1.2M points to answer 100,000 queries on
// the largest meshes). Every stride-th triangle's first corner; the queries
// stay exact, only their starting bound changes.
constexpr std::size_t kHintsPerQuery = 4;

std::vector<std::pair<Kernel::Point_3, std::vector<Triangle3>::const_iterator>> distanceHints(
    const std::vector<Triangle3>& triangles, std::size_t queries) {
  const std::size_t stride = std::max<std::size_t>(1, triangles.size() / std::max<std::size_t>(1, kHintsPerQuery * queries));
  std::vector<std::pair<Kernel::Point_3, std::vector<Triangle3>::const_iterator>> hints;
  hints.reserve(triangles.size() / stride + 1);
  for (std::size_t i = 0; i < triangles.size(); i += stride)
    hints.emplace_back(triangles[i][0], triangles.begin() + static_cast<std::ptrdiff_t>(i));
  return hints;
}

}  // namespace

struct MeshDistance::Tree {
  std::vector<Triangle3> triangles;  // the tree holds iterators into them: never moved
  TriangleTree tree;
};

MeshDistance::MeshDistance(std::unique_ptr<Tree> tree) : tree_(std::move(tree)) {}
MeshDistance::MeshDistance(MeshDistance&&) noexcept = default;
MeshDistance& MeshDistance::operator=(MeshDistance&&) noexcept = default;
MeshDistance::~MeshDistance() = default;

Result<MeshDistance> MeshDistance::make(const Scan& mesh, std::size_t queries) {
  return catchLibraryErrors("CGAL AABB tree", [&]() -> Result<MeshDistance> {
    auto made = std::make_unique<Tree>();
    made->triangles = cgalTriangles(mesh);
    if (!made->triangles.empty()) {
      made->tree.insert(made->triangles.begin(), made->triangles.end());
      // Built here, once: the queries run in parallel.
      made->tree.build();
      const auto hints = distanceHints(made->triangles, queries);
      made->tree.accelerate_distance_queries(hints.begin(), hints.end());
    }
    return MeshDistance(std::move(made));
  });
}

Result<std::vector<float>> MeshDistance::operator()(const std::vector<Vec3f>& points) const {
  // TBB hands a worker's exception to this thread, where catchLibraryErrors takes it.
  return catchLibraryErrors("CGAL AABB tree distances", [&] {
    std::vector<float> distances(points.size(), std::numeric_limits<float>::infinity());
    if (tree_->triangles.empty()) return distances;
    tbb::parallel_for(tbb::blocked_range<std::size_t>(0, points.size()), [&](const tbb::blocked_range<std::size_t>& range) {
      for (std::size_t i = range.begin(); i != range.end(); ++i)
        distances[i] = static_cast<float>(std::sqrt(tree_->tree.squared_distance(toPoint(points[i]))));
    });
    return distances;
  });
}

Result<std::vector<float>> pointToMeshDistances(const std::vector<Vec3f>& points, const Scan& mesh) {
  auto distance = MeshDistance::make(mesh, points.size());
  if (!distance) return distance.error();
  return (*distance)(points);
}

}  // namespace apo::cgal_adapter
