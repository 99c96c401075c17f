#include "ingest/face_orientation.h"

#include "adapters/flann/flann_search.h"
#include "core/mesh_edges.h"

#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

namespace apo::faces {
namespace {

// Directions and rays per direction of the visibility vote: 64 x 48^2 =
// 147,456 rays, a few tens of milliseconds with Embree.
constexpr int kDirections = 64;
constexpr int kRaysPerSide = 48;
// An open piece needs this many rays to reach it for a decision, and is
// flipped only when its back is seen this many times as often as its front:
// a lone sheet (a terrain, one range scan) is seen from both sides about
// equally and stays as it is; the inward sheets of a multi-view soup show
// their back to nearly every ray.
constexpr std::uint64_t kMinVotes = 8;
constexpr std::uint64_t kClearMajority = 2;

// Whether each component is closed: every undirected edge used by exactly
// two of its triangles.
std::vector<char> closedComponents(const Scan& mesh, const std::vector<std::uint32_t>& component, std::uint32_t count) {
  std::vector<char> closed(count, 1);
  const std::vector<TriangleSide> sides = sortedSides(mesh.triangles);
  forEachEdge(sides, [&](std::size_t first, std::size_t last) {
    if (last - first == 2) return;
    std::uint32_t lowest = component[sides[first].triangle];
    for (std::size_t i = first + 1; i < last; ++i) lowest = std::min(lowest, component[sides[i].triangle]);
    closed[lowest] = 0;
  });
  return closed;
}

// Six times the signed volume of each component, about its own first vertex
// (for precision far from zero).
std::vector<double> signedVolumes(const Scan& mesh, const std::vector<std::uint32_t>& component, std::uint32_t count) {
  std::vector<double> volume(count, 0.0);
  std::vector<Eigen::Vector3d> anchor(count);
  std::vector<char> anchored(count, 0);
  const auto& p = mesh.points.positions;
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i) {
    const Triangle& t = mesh.triangles[i];
    const std::uint32_t c = component[i];
    if (!anchored[c]) {
      anchor[c] = p[t[0]].cast<double>();
      anchored[c] = 1;
    }
    const Eigen::Vector3d a = p[t[0]].cast<double>() - anchor[c], b = p[t[1]].cast<double>() - anchor[c],
                          d = p[t[2]].cast<double>() - anchor[c];
    volume[c] += a.dot(b.cross(d));
  }
  return volume;
}

struct Votes {
  std::uint64_t front = 0, back = 0;
};

// For each component, how many rays from outside the bounding sphere first
// meet it on the side its winding calls front, and how many on the back.
std::vector<Votes> visibilityVotes(const Scan& mesh, const RayCaster& caster, const std::vector<std::uint32_t>& component,
                                   std::uint32_t count) {
  const Aabb box = boundingBox(mesh.points.positions);
  const Vec3f centre = 0.5f * (box.min + box.max);
  const float radius = std::max(0.5f * box.diagonal(), 1e-12f);
  std::vector<Votes> votes(count);
  std::vector<Ray> rays;
  std::vector<RayHit> hits;
  for (const Vec3f& d : fibonacciDirections(kDirections)) {
    const Vec3f u = d.unitOrthogonal(), v = d.cross(u);
    rays.clear();
    for (int i = 0; i < kRaysPerSide; ++i)
      for (int j = 0; j < kRaysPerSide; ++j) {
        const float s = radius * (2.0f * (static_cast<float>(i) + 0.5f) / kRaysPerSide - 1.0f);
        const float t = radius * (2.0f * (static_cast<float>(j) + 0.5f) / kRaysPerSide - 1.0f);
        Ray ray;
        ray.origin = centre + 2.0f * radius * d + s * u + t * v;
        ray.direction = -d;
        rays.push_back(ray);
      }
    caster.intersect(rays, hits);
    for (const RayHit& hit : hits) {
      if (!hit.hit()) continue;
      Votes& vote = votes[component[hit.primitive]];
      // The ray travels along -d: it sees the front when the normal faces d.
      (hit.geometricNormal.dot(d) > 0.0f ? vote.front : vote.back) += 1;
    }
  }
  return votes;
}

Vec3f faceNormal(const Scan& mesh, const Triangle& t) {
  const auto& p = mesh.points.positions;
  return (p[t[1]] - p[t[0]]).cross(p[t[2]] - p[t[0]]);
}

Vec3f centroid(const Scan& mesh, const Triangle& t) {
  const auto& p = mesh.points.positions;
  return (p[t[0]] + p[t[1]] + p[t[2]]) / 3.0f;
}

// Pieces no ray reached (rim fragments of range grids, hidden bits) agree
// with the decided pieces nearest to them: an area-weighted vote of their
// triangles against the nearest decided triangle's normal (after its flip).
// Returns how many were decided so; marks them in `flip`.
Result<std::uint64_t> followNearestDecided(const Scan& mesh, const std::vector<std::uint32_t>& component,
                                           const std::vector<char>& undecided, std::vector<char>& flip) {
  std::vector<Vec3f> decidedCentroids, decidedNormals, queries;
  std::vector<std::uint32_t> queryTriangles;
  for (std::uint32_t i = 0; i < mesh.triangles.size(); ++i) {
    const Triangle& t = mesh.triangles[i];
    if (undecided[component[i]]) {
      queries.push_back(centroid(mesh, t));
      queryTriangles.push_back(i);
    } else {
      decidedCentroids.push_back(centroid(mesh, t));
      decidedNormals.push_back(flip[component[i]] ? -faceNormal(mesh, t) : faceNormal(mesh, t));
    }
  }
  if (queries.empty() || decidedCentroids.empty()) return std::uint64_t{0};
  const auto nearest = flann_adapter::nearestIndices(decidedCentroids, queries);
  if (!nearest) return nearest.error();
  std::vector<double> agreement(flip.size(), 0.0);
  for (std::size_t q = 0; q < queries.size(); ++q) {
    const Vec3f n = faceNormal(mesh, mesh.triangles[queryTriangles[q]]);
    agreement[component[queryTriangles[q]]] += n.dot(decidedNormals[(*nearest)[q]].normalized());
  }
  std::uint64_t decided = 0;
  for (std::size_t c = 0; c < flip.size(); ++c)
    if (undecided[c]) {
      flip[c] = agreement[c] < 0.0;
      ++decided;
    }
  return decided;
}

}  // namespace

Result<FaceOrientation> orientFacesOutward(Scan& mesh, const CasterFactory& makeCaster) {
  FaceOrientation result;
  if (!mesh.isMesh()) return result;
  const MeshPieces pieces = meshPieces(mesh);
  const std::uint32_t count = pieces.count;
  const std::vector<std::uint32_t>& component = pieces.ofTriangle;
  result.components = count;
  const std::vector<char> closed = closedComponents(mesh, component, count);
  const std::vector<double> volume = signedVolumes(mesh, component, count);
  const bool anyOpen = std::find(closed.begin(), closed.end(), 0) != closed.end();
  std::vector<Votes> votes(count);
  if (anyOpen) {
    const auto caster = makeCaster(mesh);
    if (!caster) return caster.error();
    votes = visibilityVotes(mesh, **caster, component, count);
  }

  std::vector<char> flip(count, 0), undecided(count, 0);
  for (std::uint32_t c = 0; c < count; ++c) {
    if (closed[c]) {
      ++result.byVolume;
      flip[c] = volume[c] < 0.0;
    } else if (votes[c].front + votes[c].back >= kMinVotes) {
      ++result.byVisibility;
      flip[c] = votes[c].back > kClearMajority * votes[c].front;
    } else {
      undecided[c] = 1;
    }
  }
  const auto byNeighbours = followNearestDecided(mesh, component, undecided, flip);
  if (!byNeighbours) return byNeighbours.error();
  result.byNeighbours = *byNeighbours;
  for (std::uint32_t c = 0; c < count; ++c) {
    result.undecided += undecided[c] && result.byNeighbours == 0;
    result.flippedComponents += flip[c];
  }
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i)
    if (flip[component[i]]) {
      std::swap(mesh.triangles[i][1], mesh.triangles[i][2]);
      ++result.flippedTriangles;
    }
  return result;
}

}  // namespace apo::faces
