// M to m: edge-collapse simplification and its distance figures.
#include "reconstruct/reconstruct.h"

#include "adapters/cgal/cgal_jobs.h"
#include "adapters/meshopt/meshopt_simplify.h"
#include "core/mesh_edit.h"
#include "core/timing.h"
#include "reconstruct/mesh_quality.h"

#include <spdlog/spdlog.h>
#include <tbb/task_group.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <limits>
#include <optional>
#include <queue>
#include <tuple>

namespace apo {
namespace {

// The smallest closed triangle mesh.
constexpr std::uint64_t kMinTargetFaces = 4;
// Surface samples per side for the Hausdorff and mean distances.
constexpr std::size_t kDistanceSamples = 100000;

std::uint64_t targetFaceCount(const Scan& mesh, const SimplifyOptions& options) {
  if (options.ratio != 0.0)
    return std::max<std::uint64_t>(kMinTargetFaces, static_cast<std::uint64_t>(std::llround(options.ratio * mesh.triangles.size())));
  return options.targetFaces;
}

struct OneSided {
  double max = 0.0, mean = 0.0;
};

OneSided summary(const std::vector<float>& distances) {
  OneSided figures;
  if (distances.empty()) return figures;
  figures.max = *std::max_element(distances.begin(), distances.end());
  figures.mean = std::accumulate(distances.begin(), distances.end(), 0.0) / static_cast<double>(distances.size());
  return figures;
}

// M's side of the distance measures, independent of m: made on another core
// while the collapses (one core) make m.
struct DenseSide {
  std::vector<Vec3f> samples;                            // area-proportional, on M
  std::optional<cgal_adapter::MeshDistance> distanceTo;  // M's tree
};

Result<DenseSide> prepareDenseSide(const Scan& dense) {
  DenseSide side;
  side.samples = sampleSurface(dense, kDistanceSamples);
  auto tree = cgal_adapter::MeshDistance::make(dense, kDistanceSamples);
  if (!tree) return tree.error();
  side.distanceTo = std::move(*tree);
  return side;
}

// Two-sided Hausdorff and mean distances between m and M, as fractions of M's
// bounding-box diagonal, from area-proportional samples of each surface.
Status measureDistances(const Scan& coarse, const Scan& dense, const DenseSide& denseSide, SimplifyReport& report) {
  const double diagonal = boundingBox(dense.points.positions).diagonal();
  if (diagonal <= 0.0) return okStatus();
  const auto coarseToDense = (*denseSide.distanceTo)(sampleSurface(coarse, kDistanceSamples));
  if (!coarseToDense) return coarseToDense.error();
  const auto denseToCoarse = cgal_adapter::pointToMeshDistances(denseSide.samples, coarse);
  if (!denseToCoarse) return denseToCoarse.error();
  const OneSided there = summary(*coarseToDense), back = summary(*denseToCoarse);
  report.hausdorff = std::max(there.max, back.max) / diagonal;
  report.meanDistance = 0.5 * (there.mean + back.mean) / diagonal;
  return okStatus();
}

cgal_adapter::CollapseCost collapseCostOf(SimplifyPolicy policy) {
  return policy == SimplifyPolicy::LindstromTurk ? cgal_adapter::CollapseCost::LindstromTurk
                                                 : cgal_adapter::CollapseCost::GarlandHeckbert;
}

// The quick pass stops early rather than move the surface by more than this
// fraction of its extent; CGAL's collapses then do the rest.
constexpr double kQuickPassMaxError = 0.01;
// It keeps at least this many faces per face of the target, so that CGAL's
// manifold-keeping collapses make the final choices.
constexpr std::uint64_t kQuickPassFacesPerTarget = 20;

// M brought down quickly when it is large; nullopt when the pass is not worth it.
Result<std::optional<meshopt_adapter::QuickCollapse>> quickFirstPass(const Scan& mesh, std::uint64_t target,
                                                                      const SimplifyOptions& options) {
  const std::uint64_t stop = std::max(kQuickCollapseFaces, kQuickPassFacesPerTarget * target);
  if (!options.quickFirstPass || mesh.triangles.size() <= 2 * stop) return std::optional<meshopt_adapter::QuickCollapse>{};
  auto collapsed = meshopt_adapter::quickCollapse(mesh, stop, kQuickPassMaxError);
  if (!collapsed) return collapsed.error();
  spdlog::info("simplify: quick first pass (meshoptimizer) {} -> {} faces, error {:.2g} of the extent; {} folded "
               "triangles and {} pinched pockets removed",
               mesh.triangles.size(), collapsed->mesh.triangles.size(), collapsed->relativeError,
               collapsed->coincidentTriangles, collapsed->pockets);
  return std::optional<meshopt_adapter::QuickCollapse>{std::move(*collapsed)};
}

// Which vertex of the quick mesh each vertex of M now stands for: the kept
// vertex nearest along M's edges (meshoptimizer keeps a subset of M's
// vertices and collapses the others along edges into them). Dijkstra from
// all kept vertices at once; equal distances go to the lower index, so the
// answer is deterministic. Vertices no kept vertex reaches (pieces the pass
// removed) stand for none (UINT32_MAX).
std::vector<std::uint32_t> nearestKeptAlongEdges(const Scan& dense, const std::vector<std::uint32_t>& sourceVertex) {
  const std::size_t n = dense.points.size();
  // Each triangle's edges both ways, in compressed rows.
  std::vector<std::uint64_t> first(n + 1, 0);
  for (const Triangle& t : dense.triangles)
    for (std::uint32_t v : t) first[v + 1] += 2;
  std::partial_sum(first.begin(), first.end(), first.begin());
  std::vector<std::uint32_t> neighbours(first[n]);
  std::vector<std::uint64_t> next(first.begin(), first.end() - 1);
  for (const Triangle& t : dense.triangles)
    for (int k = 0; k < 3; ++k) {
      neighbours[next[t[k]]++] = t[(k + 1) % 3];
      neighbours[next[t[(k + 1) % 3]]++] = t[k];
    }
  constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();
  std::vector<std::uint32_t> owner(n, kNone);
  std::vector<double> distance(n, std::numeric_limits<double>::infinity());
  using Entry = std::tuple<double, std::uint32_t, std::uint32_t>;  // (distance, vertex, owner)
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> frontier;
  for (std::uint32_t kept = 0; kept < sourceVertex.size(); ++kept) {
    distance[sourceVertex[kept]] = 0.0;
    frontier.emplace(0.0, sourceVertex[kept], kept);
  }
  std::vector<char> settled(n, 0);
  while (!frontier.empty()) {
    const auto [d, v, from] = frontier.top();
    frontier.pop();
    if (settled[v]) continue;
    settled[v] = 1;
    owner[v] = from;
    for (std::uint64_t e = first[v]; e < first[v + 1]; ++e) {
      const std::uint32_t w = neighbours[e];
      const double through = d + (dense.points.positions[w] - dense.points.positions[v]).cast<double>().norm();
      if (!settled[w] && through < distance[w]) {
        distance[w] = through;
        frontier.emplace(through, w, from);
      }
    }
  }
  return owner;
}

// What the quick pass took out, for CGAL's collapses to remember: the plane
// quadric of each of M's faces (CGAL's: unit normal n and offset d, the outer
// product of [n, d]), added at its three corners as CGAL adds them, each
// corner's share handed to the quick mesh's vertex that corner now stands for.
std::vector<Eigen::Matrix4d> inheritedQuadrics(const Scan& dense, const meshopt_adapter::QuickCollapse& quick) {
  const std::vector<std::uint32_t> owner = nearestKeptAlongEdges(dense, quick.sourceVertex);
  std::vector<Eigen::Matrix4d> inherited(quick.mesh.points.size(), Eigen::Matrix4d::Zero());
  for (const Triangle& t : dense.triangles) {
    const Eigen::Vector3d a = dense.points.positions[t[0]].cast<double>();
    const Eigen::Vector3d normal =
        (dense.points.positions[t[1]].cast<double>() - a).cross(dense.points.positions[t[2]].cast<double>() - a);
    const double length = normal.norm();
    if (!(length > 0.0)) continue;
    Eigen::Vector4d plane;
    plane << normal / length, -normal.dot(a) / length;
    const Eigen::Matrix4d quadric = plane * plane.transpose();
    for (const std::uint32_t corner : t)
      if (owner[corner] != std::numeric_limits<std::uint32_t>::max()) inherited[owner[corner]] += quadric;
  }
  return inherited;
}

// Collapsing is most of a simplification's time; the distance measures the rest.
constexpr double kCollapseShare = 0.8;

// m from M: the quick pass when M is large, then CGAL's collapses to the
// target (report.targetFaces), M's planes handed down.
Status makeCoarse(const Scan& mesh, const SimplifyOptions& options, const ProgressCallback& onProgress,
                  SimplifyReport& report, Scan& coarse) {
  const std::uint64_t target = report.targetFaces;
  if (target >= mesh.triangles.size()) {
    // Nothing to collapse: m is M, said so rather than refused.
    spdlog::warn("simplify: target {} faces is not below the input's {}; m is the input mesh", target,
                 mesh.triangles.size());
    report.policy = "none (target not below input)";
    coarse = mesh;
  } else {
    auto quick = quickFirstPass(mesh, target, options);
    if (!quick) return quick.error();
    if (*quick) {
      report.quickPassFaces = (*quick)->mesh.triangles.size();
      report.quickPassError = (*quick)->relativeError;
      report.quickPassPockets = (*quick)->coincidentTriangles / 2 + (*quick)->pockets;
    }
    const Scan& collapseInput = *quick ? (*quick)->mesh : mesh;
    std::vector<Eigen::Matrix4d> inherited;
    if (*quick && options.policy == SimplifyPolicy::GarlandHeckbert) {
      const Stopwatch handing;
      inherited = inheritedQuadrics(mesh, **quick);
      spdlog::info("simplify: the planes of M's {} faces handed to the quick pass's vertices in {:.2f} s",
                   mesh.triangles.size(), handing.seconds());
    }
    auto collapsed = cgal_adapter::edgeCollapse(
        collapseInput, target, collapseCostOf(options.policy),
        [&](double fraction) { reportProgress(onProgress, kCollapseShare * fraction); }, inherited);
    if (!collapsed) return collapsed.error();
    if (collapsed->repairedVertices > 0)
      spdlog::warn("simplify: input had non-manifold vertices; {} vertices were split to repair it",
                   collapsed->repairedVertices);
    report.bordersCollapsed = collapsed->bordersCollapsed;
    report.filledHoles = collapsed->filledHoles;
    if (report.filledHoles > 0) spdlog::info("simplify: {} small holes of M closed before collapsing", report.filledHoles);
    if (collapsed->bordersCollapsed)
      spdlog::warn("simplify: this mesh's borders (holes, open edges) alone hold more than {} faces; border edges "
                   "were collapsed too, keeping their shape (Lindstrom-Turk)",
                   report.targetFaces);
    coarse = std::move(collapsed->mesh);
  }
  return okStatus();
}

}  // namespace

template <>
Result<Checked<SimplifyOptions>> check(const SimplifyOptions& options) {
  if (options.ratio != 0.0 && !(options.ratio > 0.0 && options.ratio <= 1.0))
    return usageError("--ratio must be in (0, 1], got {}", options.ratio);
  if (options.ratio == 0.0 && options.targetFaces < kMinTargetFaces)
    return usageError("--faces must be at least {}, got {}", kMinTargetFaces, options.targetFaces);
  return Checked<SimplifyOptions>(options);
}

std::string policyName(SimplifyPolicy policy) {
  switch (policy) {
    case SimplifyPolicy::GarlandHeckbert: return "garland-heckbert";
    case SimplifyPolicy::LindstromTurk: return "lindstrom-turk";
  }
  return "unknown";
}

Result<Simplification> simplifyMesh(const Scan& mesh, const Checked<SimplifyOptions>& checkedOptions,
                                    const ProgressCallback& onProgress) {
  const SimplifyOptions& options = *checkedOptions;
  if (!mesh.isMesh()) return badInput("simplification needs a triangle mesh, got {} points and no triangles", mesh.points.size());
  const std::uint64_t target = targetFaceCount(mesh, options);
  Stopwatch watch;
  Simplification result;
  SimplifyReport& report = result.report;
  report.policy = policyName(options.policy);
  report.facesIn = mesh.triangles.size();
  report.targetFaces = target;

  // M's side of the measures is prepared on the other core meanwhile.
  Result<DenseSide> denseSide = DenseSide{};
  tbb::task_group group;
  group.run([&] { denseSide = prepareDenseSide(mesh); });
  const Status made = makeCoarse(mesh, options, onProgress, report, result.mesh);
  group.wait();
  APO_RETURN_IF_ERROR(made);
  if (!denseSide) return denseSide.error();
  result.mesh.origin = mesh.origin;  // m stays in M's frame
  result.mesh.readNotes.clear();
  dropDegenerateTriangles(result.mesh);
  dropUnreferencedVertices(result.mesh);
  result.mesh.points.normals = areaWeightedVertexNormals(result.mesh);
  report.facesOut = result.mesh.triangles.size();
  if (static_cast<double>(report.facesOut) > 1.01 * static_cast<double>(report.targetFaces))
    spdlog::warn("simplify: stopped at {} faces, above the target {}: no further collapse keeps the mesh manifold "
                 "and free of degenerate faces",
                 report.facesOut, report.targetFaces);
  report.quality = measureMesh(result.mesh);
  APO_RETURN_IF_ERROR(measureDistances(result.mesh, mesh, *denseSide, report));
  report.seconds = watch.seconds();
  reportProgress(onProgress, 1.0);
  return result;
}

Result<Scan> previewMesh(const Scan& mesh, std::uint64_t targetFaces) {
  if (!mesh.isMesh()) return badInput("a preview needs a triangle mesh, got {} points and no triangles", mesh.points.size());
  if (mesh.triangles.size() <= targetFaces) return mesh;
  // Any error: a preview is held to its size, not to a distance.
  auto collapsed = meshopt_adapter::quickCollapse(mesh, targetFaces, 1.0);
  if (!collapsed) return collapsed.error();
  return std::move(collapsed->mesh);
}

}  // namespace apo
