// CGAL Poisson surface reconstruction, spelled out (implicit function, then
// the surface mesher) rather than through poisson_surface_reconstruction_delaunay,
// which (1) changes its output from run to run even with a seeded generator:
// the mesher's queues and the mesh export order handles by address; (2)
// turns outwards only the component holding the topmost triangle; (3) starts
// the mesher from random surface points seen from one inside point, so it
// easily misses a separate object of the scan.
#include "adapters/cgal/cgal_jobs.h"

#include "adapters/cgal/cgal_index_maps.h"

#include <CGAL/Delaunay_triangulation_3.h>
#include <CGAL/Delaunay_triangulation_cell_base_with_circumcenter_3.h>
#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Implicit_surface_3.h>
#include <CGAL/Poisson_reconstruction_function.h>
#include <CGAL/Random.h>
#include <CGAL/Robust_circumcenter_traits_3.h>
#include <CGAL/Surface_mesh_cell_base_3.h>
#include <CGAL/Surface_mesh_complex_2_in_triangulation_3.h>
#include <CGAL/Surface_mesh_default_criteria_3.h>
#include <CGAL/Surface_mesh_traits_generator_3.h>
#include <CGAL/Surface_mesh_vertex_base_3.h>
#include <CGAL/make_surface_mesh.h>
#include <CGAL/property_map.h>
#include <CGAL/tags.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <map>
#include <numeric>
#include <stdexcept>
#include <unordered_map>
#include <utility>

namespace apo::cgal_adapter {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using cgal_maps::NormalMap;
using cgal_maps::PositionMap;
using ImplicitFunction = CGAL::Poisson_reconstruction_function<Kernel>;

// A creation stamp on a triangulation vertex or cell: CGAL's containers then
// order handles by creation instead of by address (as Mesh_3 does). The
// surface mesher keeps its refinement queues in sets of handles, so without
// stamps its output depends on the heap's history.
template <class Base>
class TimeStamped : public Base {
 public:
  using Has_timestamp = CGAL::Tag_true;
  template <class Tds>
  struct Rebind_TDS {
    using Other = TimeStamped<typename Base::template Rebind_TDS<Tds>::Other>;
  };
  using Base::Base;
  std::size_t time_stamp() const { return stamp_; }
  void set_time_stamp(std::size_t stamp) { stamp_ = stamp; }

 private:
  std::size_t stamp_ = static_cast<std::size_t>(-1);
};

// CGAL's Surface_mesh_default_triangulation_3, with stamps.
using MesherTraits = CGAL::Robust_circumcenter_traits_3<Kernel>;
using MesherVertex = TimeStamped<CGAL::Surface_mesh_vertex_base_3<MesherTraits>>;
using MesherCell = TimeStamped<
    CGAL::Delaunay_triangulation_cell_base_with_circumcenter_3<MesherTraits, CGAL::Surface_mesh_cell_base_3<MesherTraits>>>;
using MesherTriangulation =
    CGAL::Delaunay_triangulation_3<MesherTraits, CGAL::Triangulation_data_structure_3<MesherVertex, MesherCell>>;
using SurfaceComplex = CGAL::Surface_mesh_complex_2_in_triangulation_3<MesherTriangulation>;
using Surface = CGAL::Implicit_surface_3<Kernel, ImplicitFunction>;

// CGAL's default (poisson_surface_reconstruction_delaunay): minimum facet
// angle in degrees.
constexpr double kMinFacetAngle = 20.0;
// Mesher seeds: one per grid cell of this fraction of the bounding-box
// diagonal, found within this many average spacings of an input point.
constexpr double kSeedCellsPerDiagonal = 8.0;
constexpr double kSeedReachSpacings = 3.0;

Status validate(const PointSet& points, double averageSpacing, double distanceSpacings) {
  if (points.size() == 0) return badInput("Poisson reconstruction failed: no points");
  if (points.normals.size() != points.size())
    return badInput("Poisson reconstruction failed: {} normals for {} points", points.normals.size(), points.size());
  if (!(averageSpacing > 0.0) || !std::isfinite(averageSpacing))
    return badInput("Poisson reconstruction failed: average spacing {} is not positive", averageSpacing);
  if (!(distanceSpacings > 0.0) || !std::isfinite(distanceSpacings))
    return badInput("Poisson reconstruction failed: distance bound {} is not positive", distanceSpacings);
  return okStatus();
}

// The mesher refines only the pieces of surface its starting points lie on.
// Adds surface points near a coarse grid sample of the input, found along
// each sample's normal, so that every separate piece gets one.
void insertPieceSeeds(const Surface& surface, const PointSet& points, double spacing, MesherTriangulation& tr) {
  const double cell = boundingBox(points.positions).diagonal() / kSeedCellsPerDiagonal;
  const Result<std::vector<char>> sampled = gridSubsampleMask(points.positions, cell);
  // Inside poissonReconstruct's try: its failure is reported like CGAL's.
  if (!sampled) throw std::runtime_error(sampled.error().message);
  auto intersect = CGAL::Surface_mesh_traits_generator_3<Surface>::type().intersect_3_object();
  const float reach = static_cast<float>(kSeedReachSpacings * spacing);
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!(*sampled)[i]) continue;
    const Vec3f a = points.positions[i] - reach * points.normals[i], b = points.positions[i] + reach * points.normals[i];
    const CGAL::Object crossing = intersect(surface, Kernel::Segment_3(Point(a.x(), a.y(), a.z()), Point(b.x(), b.y(), b.z())));
    if (const Point* seed = CGAL::object_cast<Point>(&crossing)) tr.insert(*seed);
  }
}

// Meshes the zero level set of `function` with the bounds and criteria of
// poisson_surface_reconstruction_delaunay.
void meshLevelSet(const ImplicitFunction& function, const PointSet& points, double spacing, double distanceSpacings,
                  double radiusSpacings, SurfaceComplex& complex) {
  const Kernel::Sphere_3 bounds = function.bounding_sphere();
  const double boundingRadius = 5.0 * std::sqrt(bounds.squared_radius());
  const double dichotomyError = distanceSpacings * spacing / 1000.0;
  const Surface surface(function, Kernel::Sphere_3(function.get_inner_point(), boundingRadius * boundingRadius),
                        dichotomyError / boundingRadius);
  insertPieceSeeds(surface, points, spacing, complex.triangulation());
  const CGAL::Surface_mesh_default_criteria_3<MesherTriangulation> criteria(
      kMinFacetAngle, radiusSpacings * spacing, distanceSpacings * spacing);
  CGAL::make_surface_mesh(complex, surface, criteria, CGAL::Manifold_with_boundary_tag());
}

// The complex's facets as a triangle soup, numbered without looking at
// addresses (which decide CGAL's facet order and orientation): vertices in
// the triangulation's iteration order, which depends on the sequence of
// insertions only; each facet in ascending vertex order, the facets sorted.
// Orientation is set afterwards.
Scan triangleSoup(const SurfaceComplex& complex) {
  const MesherTriangulation& tr = complex.triangulation();
  std::unordered_map<MesherTriangulation::Vertex_handle, std::uint32_t> index;
  for (auto facet = complex.facets_begin(); facet != complex.facets_end(); ++facet)
    for (int j = 0; j < 3; ++j) index[facet->first->vertex(tr.vertex_triple_index(facet->second, j))] = 0;
  Scan soup;
  for (auto v = tr.finite_vertices_begin(); v != tr.finite_vertices_end(); ++v) {
    const auto found = index.find(v);
    if (found == index.end()) continue;
    found->second = static_cast<std::uint32_t>(soup.points.positions.size());
    const Point& p = v->point();
    soup.points.positions.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()));
  }
  for (auto facet = complex.facets_begin(); facet != complex.facets_end(); ++facet) {
    Triangle t;
    for (int j = 0; j < 3; ++j) t[j] = index.at(facet->first->vertex(tr.vertex_triple_index(facet->second, j)));
    std::sort(t.begin(), t.end());
    soup.triangles.push_back(t);
  }
  std::sort(soup.triangles.begin(), soup.triangles.end());
  return soup;
}

using Edge = std::pair<std::uint32_t, std::uint32_t>;

bool hasDirectedEdge(const Triangle& t, std::uint32_t a, std::uint32_t b) {
  return (t[0] == a && t[1] == b) || (t[1] == a && t[2] == b) || (t[2] == a && t[0] == b);
}

// Flips triangles so that each edge-connected component agrees with its first
// triangle (the surface mesher's manifold output is orientable, with at most
// two triangles per edge). Returns each triangle's component.
std::vector<std::uint32_t> orientComponentsConsistently(std::vector<Triangle>& triangles) {
  std::map<Edge, std::vector<std::uint32_t>> edgeTriangles;
  for (std::uint32_t i = 0; i < triangles.size(); ++i)
    for (int j = 0; j < 3; ++j) {
      const std::uint32_t a = triangles[i][j], b = triangles[i][(j + 1) % 3];
      edgeTriangles[{std::min(a, b), std::max(a, b)}].push_back(i);
    }
  constexpr std::uint32_t kUnvisited = ~0u;
  std::vector<std::uint32_t> component(triangles.size(), kUnvisited);
  std::uint32_t components = 0;
  std::vector<std::uint32_t> stack;
  for (std::uint32_t seed = 0; seed < triangles.size(); ++seed) {
    if (component[seed] != kUnvisited) continue;
    component[seed] = components;
    stack.push_back(seed);
    while (!stack.empty()) {
      const std::uint32_t i = stack.back();
      stack.pop_back();
      for (int j = 0; j < 3; ++j) {
        const std::uint32_t a = triangles[i][j], b = triangles[i][(j + 1) % 3];
        for (std::uint32_t n : edgeTriangles.at({std::min(a, b), std::max(a, b)})) {
          if (component[n] != kUnvisited) continue;
          // A consistent neighbour runs the shared edge the other way round.
          if (hasDirectedEdge(triangles[n], a, b)) std::swap(triangles[n][1], triangles[n][2]);
          component[n] = components;
          stack.push_back(n);
        }
      }
    }
    ++components;
  }
  return component;
}

// Turns every component outwards: the Poisson function is negative inside,
// so it must grow along outward normals. Each triangle votes with its area by
// the sign of the function's change across it.
void orientOutwards(Scan& mesh, const std::vector<std::uint32_t>& component, const ImplicitFunction& function,
                    double spacing) {
  const std::uint32_t count = component.empty() ? 0 : *std::max_element(component.begin(), component.end()) + 1;
  std::vector<double> vote(count, 0.0);
  const double step = 0.1 * spacing;
  const auto& p = mesh.points.positions;
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i) {
    const Triangle& t = mesh.triangles[i];
    const Eigen::Vector3d a = p[t[0]].cast<double>(), b = p[t[1]].cast<double>(), c = p[t[2]].cast<double>();
    const Eigen::Vector3d areaNormal = 0.5 * (b - a).cross(c - a);
    const double area = areaNormal.norm();
    if (area == 0.0) continue;
    const Eigen::Vector3d centre = (a + b + c) / 3.0, offset = step / area * areaNormal;
    const Eigen::Vector3d ahead = centre + offset, behind = centre - offset;
    const double rise = function(Point(ahead.x(), ahead.y(), ahead.z())) - function(Point(behind.x(), behind.y(), behind.z()));
    vote[component[i]] += rise > 0.0 ? area : rise < 0.0 ? -area : 0.0;
  }
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i)
    if (vote[component[i]] < 0.0) std::swap(mesh.triangles[i][1], mesh.triangles[i][2]);
}

// Each triangle starting at its smallest index (orientation kept), triangles
// in lexicographic order.
void sortCanonically(std::vector<Triangle>& triangles) {
  for (Triangle& t : triangles) std::rotate(t.begin(), std::min_element(t.begin(), t.end()), t.end());
  std::sort(triangles.begin(), triangles.end());
}

Result<Scan> reconstruct(const PointSet& points, double spacing, double distanceSpacings, double radiusSpacings) {
  const auto indices = cgal_maps::allIndices(points.size());
  ImplicitFunction function(indices.begin(), indices.end(), PositionMap{&points.positions},
                            NormalMap{&points.normals});
  if (!function.compute_implicit_function())
    return badInput("Poisson reconstruction failed: the Poisson equation could not be solved");

  MesherTriangulation triangulation;
  SurfaceComplex complex(triangulation);
  meshLevelSet(function, points, spacing, distanceSpacings, radiusSpacings, complex);
  Scan mesh = triangleSoup(complex);
  if (mesh.triangles.empty()) return badInput("Poisson reconstruction failed: the surface mesher found no surface");
  const auto component = orientComponentsConsistently(mesh.triangles);
  orientOutwards(mesh, component, function, spacing);
  sortCanonically(mesh.triangles);
  return mesh;
}

}  // namespace

Result<Scan> poissonReconstruct(const PointSet& points, double averageSpacing, double distanceSpacings,
                                double radiusSpacings, std::uint32_t seed) {
  APO_RETURN_IF_ERROR(validate(points, averageSpacing, distanceSpacings));
  if (!(radiusSpacings > 0.0) || !std::isfinite(radiusSpacings))
    return badInput("Poisson reconstruction failed: radius bound {} is not positive", radiusSpacings);
  try {
    // The surface mesher draws its initial points from CGAL's default
    // generator, which is seeded by time unless we seed it.
    CGAL::get_default_random() = CGAL::Random(seed);
    return reconstruct(points, averageSpacing, distanceSpacings, radiusSpacings);
  } catch (const CGAL::Failure_exception& e) {
    return internalError("Poisson reconstruction failed: CGAL {}", e.what());
  } catch (const std::exception& e) {
    return internalError("Poisson reconstruction failed: {}", e.what());
  }
}

}  // namespace apo::cgal_adapter
