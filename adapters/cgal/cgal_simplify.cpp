#include "adapters/cgal/cgal_jobs.h"

#include <CGAL/Exact_predicates_inexact_constructions_kernel.h>
#include <CGAL/Polygon_mesh_processing/connected_components.h>
#include <CGAL/Polygon_mesh_processing/orient_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/polygon_soup_to_polygon_mesh.h>
#include <CGAL/Polygon_mesh_processing/repair_degeneracies.h>
#include <CGAL/Polygon_mesh_processing/repair_polygon_soup.h>
#include <CGAL/Polygon_mesh_processing/shape_predicates.h>
#include <CGAL/Polygon_mesh_processing/triangulate_hole.h>
#include <CGAL/Surface_mesh.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/Constrained_placement.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/GarlandHeckbert_plane_policies.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/LindstromTurk_cost.h>
#include <CGAL/Surface_mesh_simplification/Policies/Edge_collapse/LindstromTurk_placement.h>
#include <CGAL/Surface_mesh_simplification/edge_collapse.h>

#include <Eigen/Core>
#include <Eigen/LU>

#include <array>
#include <cmath>
#include <exception>
#include <limits>
#include <vector>

namespace apo::cgal_adapter {
namespace {

using Kernel = CGAL::Exact_predicates_inexact_constructions_kernel;
using Point = Kernel::Point_3;
using Mesh = CGAL::Surface_mesh<Point>;
using SoupTriangle = std::array<std::size_t, 3>;
namespace PMP = CGAL::Polygon_mesh_processing;
namespace SMS = CGAL::Surface_mesh_simplification;

struct Soup {
  std::vector<Point> points;
  std::vector<SoupTriangle> triangles;
};

// Our scan as a CGAL polygon soup. Triangles with a repeated index have no
// place in a halfedge mesh and are dropped; bad indices and non-finite
// coordinates are the input's fault.
Result<Soup> soupFromScan(const Scan& scan) {
  Soup soup;
  soup.points.reserve(scan.points.size());
  for (const Vec3f& p : scan.points.positions) {
    if (!p.allFinite()) return badInput("simplify: vertex {} has a non-finite coordinate", soup.points.size());
    soup.points.emplace_back(p.x(), p.y(), p.z());
  }
  soup.triangles.reserve(scan.triangles.size());
  for (const Triangle& t : scan.triangles) {
    for (const std::uint32_t i : t)
      if (i >= soup.points.size())
        return badInput("simplify: triangle {} uses vertex {} of {}", &t - scan.triangles.data(), i, soup.points.size());
    if (t[0] == t[1] || t[1] == t[2] || t[2] == t[0]) continue;
    soup.triangles.push_back({t[0], t[1], t[2]});
  }
  return soup;
}

// The soup as a halfedge mesh. One that is not a manifold, consistently
// oriented surface is repaired first: duplicate triangles go, and
// orient_polygon_soup duplicates the vertices where non-manifold edges or
// vertices meet; `addedVertices` counts them.
Result<Mesh> manifoldMesh(Soup& soup, std::uint64_t& addedVertices) {
  addedVertices = 0;
  if (!PMP::is_polygon_soup_a_polygon_mesh(soup.triangles)) {
    PMP::merge_duplicate_polygons_in_polygon_soup(soup.points, soup.triangles);
    const std::size_t before = soup.points.size();
    PMP::orient_polygon_soup(soup.points, soup.triangles);
    addedVertices = soup.points.size() - before;
    if (!PMP::is_polygon_soup_a_polygon_mesh(soup.triangles))
      return internalError("simplify: the repaired polygon soup is still not a manifold mesh");
  }
  Mesh mesh;
  PMP::polygon_soup_to_polygon_mesh(soup.points, soup.triangles, mesh);
  return mesh;
}

// CGAL 5.5 has stop predicates on edge counts only; a face count is what the
// user asks for, and on meshes with borders edges and faces do not move in step.
// Faces removed out of those to remove, as a fraction, to a callback.
class CollapseProgress {
 public:
  CollapseProgress(const ProgressCallback& callback, std::size_t startFaces, std::size_t targetFaces)
      : callback_(callback), startFaces_(startFaces), targetFaces_(targetFaces) {}

  void reach(std::size_t faces) const {
    if (!callback_ || startFaces_ <= targetFaces_) return;
    const std::size_t removed = startFaces_ - std::max(std::min(faces, startFaces_), targetFaces_);
    const int percent = static_cast<int>(100 * removed / (startFaces_ - targetFaces_));
    if (percent <= lastPercent_) return;
    lastPercent_ = percent;
    callback_(percent / 100.0);
  }

 private:
  const ProgressCallback& callback_;
  std::size_t startFaces_, targetFaces_;
  mutable int lastPercent_ = -1;
};

// Asked before every collapse; also reports the share of the faces to remove
// that are gone, once per percent.
struct FaceCountStop {
  const Mesh* mesh;
  std::size_t targetFaces;
  const CollapseProgress* progress = nullptr;

  template <class Profile>
  bool operator()(const double& /*cost*/, const Profile& /*profile*/, std::size_t /*initialEdges*/,
                  std::size_t /*currentEdges*/) const {
    if (progress) progress->reach(mesh->number_of_faces());
    return mesh->number_of_faces() <= targetFaces;
  }
};

// Border edges are constrained: never collapsed, and (with
// Constrained_placement) their vertices never move, so borders stay exactly.
// Collapsing interior edges never makes new border edges, so asking the mesh
// each time is the same as marking the border once.
struct BorderEdgeMap {
  using key_type = Mesh::Edge_index;
  using value_type = bool;
  using reference = bool;
  using category = boost::readable_property_map_tag;
  const Mesh* mesh;
  friend bool get(const BorderEdgeMap& map, key_type e) { return map.mesh->is_border(e); }
};

// Rounds each placement to float, the precision we export in, so that the
// degeneracy check below judges the triangles we return, not finer ones.
template <class BasePlacement>
struct FloatRoundedPlacement : BasePlacement {
  explicit FloatRoundedPlacement(const BasePlacement& base) : BasePlacement(base) {}

  template <class Profile>
  boost::optional<Point> operator()(const Profile& profile) const {
    const boost::optional<Point> placed = BasePlacement::operator()(profile);
    if (!placed) return placed;
    const auto round = [](double v) { return static_cast<double>(static_cast<float>(v)); };
    return Point(round(placed->x()), round(placed->y()), round(placed->z()));
  }
};

// Refuses a collapse that would leave a triangle with collinear corners: the
// fold test of edge_collapse lets zero-area triangles through.
struct NoDegenerateTriangleFilter {
  template <class Profile>
  boost::optional<Point> operator()(const Profile& profile, boost::optional<Point> placed) const {
    if (!placed) return placed;
    const auto& triangles = profile.triangles();
    // The first one or two triangles hold the collapsing edge and vanish; in
    // the others, corner v1 is the vertex that moves to `placed`.
    const std::size_t vanishing = (profile.left_face_exists() ? 1 : 0) + (profile.right_face_exists() ? 1 : 0);
    for (std::size_t i = vanishing; i < triangles.size(); ++i) {
      const auto& t = triangles[i];
      if (CGAL::collinear(get(profile.vertex_point_map(), t.v0), *placed, get(profile.vertex_point_map(), t.v2)))
        return boost::none;
    }
    return placed;
  }
};

// Garland-Heckbert's placement minimises the summed plane quadric
// x^T A x + 2 b^T x + c, solving A x = -b. CGAL 5.5 inverts A whenever its
// determinant is not exactly zero, so on a flat region that is not
// axis-aligned, rounding noise makes A "invertible" and throws the point far
// along the plane; the collapse would fold the mesh, is refused, and the
// queue churns (CGAL issue 8988: a tilted 205K-face plane took 26 s and
// stopped at 36K faces). We solve from the edge midpoint m with a ridge term,
// x = m + (A + d I)^-1 (-b - A m), d a small fraction of trace(A): along
// directions where A is flat (eigenvalue << d) the point stays at m, along
// the others it reaches the quadric's minimum (pulled towards m by d/(l + d)).
// One 3x3 solve, as cheap as CGAL's own placement.
template <class Quadrics>
struct RidgeQuadricPlacement {
  // d / trace(A). For two planes at angle t, A's small eigenvalue over its
  // trace is about t^2 / 4: planes within about 4 degrees count as one.
  static constexpr double kRidgeRatio = 1e-3;
  Quadrics quadrics;

  template <class Profile>
  boost::optional<Point> operator()(const Profile& profile) const {
    const Eigen::Matrix4d quadric = get(quadrics.vcm(), profile.v0()) + get(quadrics.vcm(), profile.v1());
    const Eigen::Matrix3d a = quadric.topLeftCorner<3, 3>();
    const Eigen::Vector3d b = quadric.topRightCorner<3, 1>();
    const Eigen::Vector3d midpoint = 0.5 * (toEigen(profile.p0()) + toEigen(profile.p1()));
    const double ridge = kRidgeRatio * a.trace();
    if (!(ridge > 0.0)) return profile.p0();  // no plane has a say: keep a vertex where it is
    const Eigen::Matrix3d damped = a + ridge * Eigen::Matrix3d::Identity();
    const Eigen::Vector3d optimum = midpoint + damped.inverse() * (-b - a * midpoint);
    return Point(optimum.x(), optimum.y(), optimum.z());
  }

  static Eigen::Vector3d toEigen(const Point& p) { return {p.x(), p.y(), p.z()}; }
};

// Garland-Heckbert's cost with each vertex's quadric made of the planes it
// stands for in the mesh before an earlier pass (meshoptimizer's) removed
// them: when edge_collapse initialises the quadrics, vertex i's face planes
// are replaced by `inherited[i]` (its border terms stay). Without it the
// collapses forget the detail the first pass took out, and m lands a third
// farther from M (docs/benchmarks.md). Vertex i of the halfedge mesh is
// point i of the soup; vertices the repair appended keep their own planes.
template <class Quadrics>
struct InheritingQuadrics : Quadrics {
  InheritingQuadrics(const Quadrics& quadrics, const std::vector<Eigen::Matrix4d>& inherited)
      : Quadrics(quadrics), inherited(&inherited) {}
  const std::vector<Eigen::Matrix4d>* inherited;

  template <class VertexPointMap, class Traits>
  void initialize(const Mesh& mesh, const VertexPointMap points, const Traits& traits) const {
    Quadrics::initialize(mesh, points, traits);
    if (inherited->empty()) return;
    for (const Mesh::Vertex_index v : mesh.vertices()) {
      if (v.idx() >= inherited->size()) continue;
      auto quadric = get(this->vcm(), v);
      for (const Mesh::Face_index f : mesh.faces_around_target(mesh.halfedge(v)))
        if (f != Mesh::null_face()) quadric -= this->construct_quadric(f, mesh, points, traits);
      put(this->vcm(), v, quadric + (*inherited)[v.idx()]);
    }
  }
};

template <class Cost, class Placement>
void collapseToFaceCount(Mesh& mesh, std::size_t targetFaces, const CollapseProgress& progress, const Cost& cost,
                         const Placement& basePlacement) {
  const BorderEdgeMap border{&mesh};
  const SMS::Constrained_placement<FloatRoundedPlacement<Placement>, BorderEdgeMap> placement(
      border, FloatRoundedPlacement<Placement>(basePlacement));
  SMS::edge_collapse(mesh, FaceCountStop{&mesh, targetFaces, &progress},
                     CGAL::parameters::get_cost(cost)
                         .get_placement(placement)
                         .edge_is_constrained_map(border)
                         .filter(NoDegenerateTriangleFilter{}));
}

void collapseWithPolicy(Mesh& mesh, std::size_t targetFaces, CollapseCost policy,
                        const std::vector<Eigen::Matrix4d>& inheritedQuadrics, const CollapseProgress& progress) {
  switch (policy) {
    case CollapseCost::GarlandHeckbert: {
      // The cost and placement copies share the per-vertex quadrics, which
      // edge_collapse keeps up to date through the cost object.
      using Quadrics = SMS::GarlandHeckbert_plane_policies<Mesh, Kernel>;
      const Quadrics quadrics(mesh);
      collapseToFaceCount(mesh, targetFaces, progress, InheritingQuadrics<Quadrics>(quadrics, inheritedQuadrics),
                          RidgeQuadricPlacement<Quadrics>{quadrics});
      return;
    }
    case CollapseCost::LindstromTurk:
      collapseToFaceCount(mesh, targetFaces, progress, SMS::LindstromTurk_cost<Mesh>(),
                          SMS::LindstromTurk_placement<Mesh>());
      return;
  }
}

// Scan meshes are riddled with small holes (missing returns, trimmed bridges);
// each would pin its border vertices in m. Holes with at most this many
// border edges are closed by a plain triangulation before collapsing: a few
// spacings wide, the patch stays close to the surface around it.
constexpr std::size_t kMaxFilledHoleEdges = 32;

std::size_t borderCycleLength(const Mesh& mesh, Mesh::Halfedge_index start) {
  std::size_t length = 0;
  for (Mesh::Halfedge_index h : CGAL::halfedges_around_face(start, mesh)) {
    (void)h;
    ++length;
  }
  return length;
}

struct BorderCycle {
  Mesh::Halfedge_index start;
  std::size_t length;
  std::size_t component;
};

// Every border cycle once, in halfedge index order (so the result repeats),
// with the connected component it bounds.
std::vector<BorderCycle> borderCycles(const Mesh& mesh, std::size_t& componentCount) {
  std::vector<std::size_t> faceComponent(mesh.number_of_faces());
  const auto componentMap = CGAL::make_property_map(faceComponent);
  componentCount = PMP::connected_components(mesh, componentMap);
  std::vector<BorderCycle> cycles;
  std::vector<char> seen(mesh.number_of_halfedges(), 0);
  for (const Mesh::Halfedge_index h : mesh.halfedges()) {
    if (!mesh.is_border(h) || seen[h]) continue;
    for (Mesh::Halfedge_index g : CGAL::halfedges_around_face(h, mesh)) seen[g] = 1;
    cycles.push_back({h, borderCycleLength(mesh, h), faceComponent[mesh.face(mesh.opposite(h))]});
  }
  return cycles;
}

// Fills the small holes; the longest border of each component is its outer
// edge, never a hole (a lone triangle or a small disk stays open). Returns
// how many were filled.
std::uint64_t fillSmallHoles(Mesh& mesh) {
  std::size_t componentCount = 0;
  const std::vector<BorderCycle> cycles = borderCycles(mesh, componentCount);
  constexpr std::size_t none = std::numeric_limits<std::size_t>::max();
  std::vector<std::size_t> outer(componentCount, none);
  for (std::size_t i = 0; i < cycles.size(); ++i) {
    std::size_t& o = outer[cycles[i].component];
    if (o == none || cycles[i].length > cycles[o].length) o = i;
  }
  std::uint64_t filled = 0;
  std::vector<Mesh::Face_index> patch;
  for (std::size_t i = 0; i < cycles.size(); ++i) {
    if (cycles[i].length > kMaxFilledHoleEdges || outer[cycles[i].component] == i) continue;
    patch.clear();
    PMP::triangulate_hole(mesh, cycles[i].start, std::back_inserter(patch));
    filled += patch.empty() ? 0 : 1;
  }
  return filled;
}

// Border edges free: Garland-Heckbert's plane quadrics have no border term
// and would pull borders inwards, Lindstrom-Turk's boundary preservation
// keeps the border's shape.
void collapseBordersToo(Mesh& mesh, std::size_t targetFaces, const CollapseProgress& progress) {
  using Placement = SMS::LindstromTurk_placement<Mesh>;
  SMS::edge_collapse(mesh, FaceCountStop{&mesh, targetFaces, &progress},
                     CGAL::parameters::get_cost(SMS::LindstromTurk_cost<Mesh>())
                         .get_placement(FloatRoundedPlacement<Placement>(Placement()))
                         .filter(NoDegenerateTriangleFilter{}));
}

// Within 1% of the target counts as reached (the tolerance).
bool aboveTarget(const Mesh& mesh, std::size_t targetFaces) {
  return static_cast<double>(mesh.number_of_faces()) > 1.01 * static_cast<double>(targetFaces);
}

std::size_t countDegenerateFaces(const Mesh& mesh) {
  std::size_t count = 0;
  for (const Mesh::Face_index f : mesh.faces())
    if (PMP::is_degenerate_triangle_face(f, mesh)) ++count;
  return count;
}

// Vertices in index order (isolated ones left out), faces in index order:
// the same mesh always exports to the same arrays.
Scan scanFromMesh(Mesh& mesh) {
  mesh.collect_garbage();
  Scan scan;
  constexpr auto unused = std::numeric_limits<std::uint32_t>::max();
  std::vector<std::uint32_t> newIndex(mesh.number_of_vertices(), unused);
  for (const Mesh::Vertex_index v : mesh.vertices()) {
    if (mesh.is_isolated(v)) continue;
    newIndex[v] = static_cast<std::uint32_t>(scan.points.positions.size());
    const Point& p = mesh.point(v);
    scan.points.positions.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z()));
  }
  scan.triangles.reserve(mesh.number_of_faces());
  for (const Mesh::Face_index f : mesh.faces()) {
    Triangle triangle{};
    std::size_t corner = 0;
    for (const Mesh::Vertex_index v : mesh.vertices_around_face(mesh.halfedge(f))) triangle[corner++] = newIndex[v];
    scan.triangles.push_back(triangle);
  }
  return scan;
}

Result<EdgeCollapseResult> simplify(const Scan& input, std::uint64_t targetFaces, CollapseCost policy,
                                    const std::vector<Eigen::Matrix4d>& inheritedQuadrics,
                                    const ProgressCallback& onCollapsed) {
  Result<Soup> soup = soupFromScan(input);
  if (!soup) return soup.error();
  if (soup->triangles.empty()) return badInput("simplify: the mesh has no non-degenerate triangle");
  EdgeCollapseResult result;
  Result<Mesh> mesh = manifoldMesh(*soup, result.repairedVertices);
  if (!mesh) return mesh.error();
  const CollapseProgress progress(onCollapsed, mesh->number_of_faces(), targetFaces);
  if (mesh->number_of_faces() > targetFaces) {
    result.filledHoles = fillSmallHoles(*mesh);
    collapseWithPolicy(*mesh, targetFaces, policy, inheritedQuadrics, progress);
  }
  if (aboveTarget(*mesh, targetFaces)) {
    collapseBordersToo(*mesh, targetFaces, progress);
    result.bordersCollapsed = true;
  }
  // The filter keeps collapses from making degenerate faces, but the input may
  // bring its own (ingest drops exact ones; slivers can survive).
  if (countDegenerateFaces(*mesh) > 0) PMP::remove_degenerate_faces(*mesh);
  if (const std::size_t left = countDegenerateFaces(*mesh); left > 0)
    return internalError("simplify: {} degenerate faces could not be removed", left);
  result.mesh = scanFromMesh(*mesh);
  return result;
}

}  // namespace

Result<EdgeCollapseResult> edgeCollapse(const Scan& mesh, std::uint64_t targetFaces, CollapseCost policy,
                                        const ProgressCallback& onCollapsed,
                                        const std::vector<Eigen::Matrix4d>& inheritedQuadrics) {
  if (targetFaces == 0) return usageError("simplify: the target face count must be positive");
  if (!inheritedQuadrics.empty() && inheritedQuadrics.size() != mesh.points.size())
    return internalError("simplify: {} inherited quadrics for {} vertices", inheritedQuadrics.size(), mesh.points.size());
  try {
    return simplify(mesh, targetFaces, policy, inheritedQuadrics, onCollapsed);
  } catch (const std::exception& e) {
    return internalError("simplify: CGAL edge collapse failed: {}", e.what());
  } catch (...) {
    return internalError("simplify: CGAL edge collapse failed with an unknown exception");
  }
}

}  // namespace apo::cgal_adapter
