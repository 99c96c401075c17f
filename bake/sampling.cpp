// Normal field sampling (paper section 3.2). For each leaf C and each
// triangle t of m in C, rays start on t inside C along m's interpolated
// normal, both ways; the nearest hit on M gives M's interpolated normal
// there, and a miss falls back to M's closest point. A leaf's normal is the
// mean of its samples weighted by the area of t inside C; a two-sided leaf's
// sides are the means of the samples whose m normal picks each side.
#include "bake/sampling.h"

#include "bake/cell_clip.h"
#include "core/triangle_geometry.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <bit>
#include <optional>
#include <span>

namespace apo::sampling {
namespace {

using octree::Cell;

constexpr std::size_t kLeavesPerChunk = 256;
constexpr float kSetBack = 1e-4f;  // of the ray's reach

// A ray origin on triangle t of m, and its share of the leaf's weight.
struct Sample {
  std::uint32_t leaf = 0;  // position in the leaf list of the chunk
  std::uint32_t triangle = 0;
  Eigen::Vector3f barycentrics = Eigen::Vector3f::Zero();
  double weight = 0.0;
};

using octree::barycentricsOf;

// Low-discrepancy points of the unit square (Roberts' R2 sequence): sample j
// of k lands in its own part of the square, the same for every run.
std::array<float, 2> r2Point(int j) {
  constexpr double a1 = 0.7548776662466927, a2 = 0.5698402909980532;  // 1/g, 1/g^2, g^3 = g + 1
  const double x = 0.5 + a1 * j, y = 0.5 + a2 * j;
  return {static_cast<float>(x - std::floor(x)), static_cast<float>(y - std::floor(y))};
}

// k points spread over a convex polygon: the fan triangle of each is picked
// by stratified area, the point in it by the R2 sequence.
std::vector<Vec3f> stratifiedPoints(std::span<const Vec3f> polygon, int k) {
  std::vector<double> cumulative;
  double total = 0.0;
  for (std::size_t i = 1; i + 1 < polygon.size(); ++i) {
    total += 0.5 * (polygon[i] - polygon[0]).cast<double>().cross((polygon[i + 1] - polygon[0]).cast<double>()).norm();
    cumulative.push_back(total);
  }
  std::vector<Vec3f> points;
  for (int j = 0; j < k; ++j) {
    const double target = (j + 0.5) / k * total;
    const std::size_t fan = std::min<std::size_t>(
        static_cast<std::size_t>(std::lower_bound(cumulative.begin(), cumulative.end(), target) - cumulative.begin()),
        cumulative.size() - 1);
    auto [r1, r2] = r2Point(j);
    if (r1 + r2 > 1.0f) {
      r1 = 1.0f - r1;
      r2 = 1.0f - r2;
    }
    const Vec3f& p0 = polygon[0];
    points.push_back(p0 + r1 * (polygon[fan + 1] - p0) + r2 * (polygon[fan + 2] - p0));
  }
  return points;
}

// The cell of every node, walking the broods from the root.
std::vector<Cell> cellsOf(const Octree& octree) {
  std::vector<Cell> cells(octree.nodes.size());
  for (std::uint32_t n = 0; n < octree.nodes.size(); ++n) {
    const OctreeNode& node = octree.nodes[n];
    if (node.isLeaf()) continue;
    std::uint32_t child = node.firstChild;
    for (int c = 0; c < 8; ++c)
      if (node.childMask & (1u << c)) cells[child++] = cells[n].child(c);
  }
  return cells;
}

class LeafSampler {
 public:
  LeafSampler(const octree::BuiltOctree& built, const CoarseFrames& coarse, const DetailSurface& detail,
              const SamplingSettings& settings)
      : built_(built), coarse_(coarse), detail_(detail), settings_(settings), cells_(cellsOf(built.octree)) {}

  // Ray origins of one leaf, appended to `samples`.
  void addSamples(std::uint32_t node, std::uint32_t leafSlot, std::vector<Sample>& samples, double& area) const {
    const Cell cell = cellOf(node);
    const auto& unit = *coarse_.unit;
    area = 0.0;
    for (std::uint64_t i = built_.leafTriangleBegin[node]; i < built_.leafTriangleBegin[node + 1]; ++i) {
      const std::uint32_t t = built_.leafTriangles[i];
      const Triangle& tri = unit.triangles[t];
      const Vec3f &a = unit.positions[tri[0]], &b = unit.positions[tri[1]], &c = unit.positions[tri[2]];
      const octree::CellPolygon inside = octree::clipTriangleToCell(a, b, c, cell);
      const double clippedArea = inside.size >= 3 ? octree::polygonArea(inside.view()) : 0.0;
      area += clippedArea;
      if (settings_.samples == 1 || inside.size < 3) {
        samples.push_back({leafSlot, t, closestPointOnTriangle(cell.centre, a, b, c).weights, clippedArea});
        continue;
      }
      for (const Vec3f& p : stratifiedPoints(inside.view(), settings_.samples))
        samples.push_back({leafSlot, t, barycentricsOf(p, a, b, c), clippedArea / settings_.samples});
    }
  }

  Vec3f originOf(const Sample& s) const {
    const Triangle& tri = coarse_.unit->triangles[s.triangle];
    const auto& p = *coarse_.worldPositions;
    const Eigen::Vector3f& w = s.barycentrics;
    return w[0] * p[tri[0]] + w[1] * p[tri[1]] + w[2] * p[tri[2]];
  }

  // Starts a hair behind the origin, so that M passing exactly through the
  // origin (m and M share vertices where they touch) is hit by both rays
  // rather than by neither, whatever the caster does at t = 0.
  Ray rayOf(const Sample& s, float direction, float reach) const {
    const Triangle& tri = coarse_.unit->triangles[s.triangle];
    const auto& n = *coarse_.vertexNormals;
    const Eigen::Vector3f& w = s.barycentrics;
    Ray ray;
    ray.direction = direction * (w[0] * n[tri[0]] + w[1] * n[tri[1]] + w[2] * n[tri[2]]).normalized();
    const float setBack = kSetBack * reach;
    ray.origin = originOf(s) - setBack * ray.direction;
    ray.tFar = reach + setBack;
    return ray;
  }

  float reachOf(std::uint32_t node) const {
    const float cellDiagonal = std::sqrt(3.0f) * cellOf(node).width / static_cast<float>(built_.octree.transform.scale);
    return std::max(static_cast<float>(settings_.maxDistance), cellDiagonal);
  }

  // M's normal at a hit: interpolated vertex normals on a mesh, the point's
  // own normal for a disc.
  Vec3f normalAt(const RayHit& hit) const {
    const Scan& m = *detail_.detail;
    if (!m.isMesh()) return m.points.normals[hit.primitive];
    const Triangle& tri = m.triangles[hit.primitive];
    const auto& n = m.points.normals;
    const Vec3f interpolated = (1.0f - hit.u - hit.v) * n[tri[0]] + hit.u * n[tri[1]] + hit.v * n[tri[2]];
    if (interpolated.squaredNorm() > 0.0f) return interpolated.normalized();
    return hit.geometricNormal.normalized();
  }

  Cell cellOf(std::uint32_t node) const { return cells_[node]; }

 private:
  const octree::BuiltOctree& built_;
  const CoarseFrames& coarse_;
  const DetailSurface& detail_;
  const SamplingSettings& settings_;
  std::vector<Cell> cells_;
};

}  // namespace

// Children come after their parent in the node array, so a reverse sweep sees
// every child before its parent. `moments` holds the leaves' and receives
// the internal nodes'; with `mayShowCoarse`, an internal node where m's
// normals are closer to the samples below shows them (mip-mapped renders
// stop at internal nodes: across a thin part their mean averages both
// sides).
void averageInternalNodes(Octree& octree, std::vector<SampleMoments>& moments, bool mayShowCoarse) {
  for (std::size_t n = octree.nodes.size(); n-- > 0;) {
    OctreeNode& node = octree.nodes[n];
    if (node.isLeaf()) continue;
    moments[n] = SampleMoments{};
    for (int k = 0; k < std::popcount(static_cast<unsigned>(node.childMask)); ++k)
      moments[n] += moments[node.firstChild + static_cast<std::uint32_t>(k)];
    const SampleMoments& below = moments[n];
    node.coarseNormal = mayShowCoarse && (below.coversBothSides() || below.detailTurns()) && below.coarseIsCloser();
    Eigen::Vector3d weighted = Eigen::Vector3d::Zero(), plain = Eigen::Vector3d::Zero();
    double weight = 0.0;
    std::uint32_t child = node.firstChild;
    for (int c = 0; c < 8; ++c) {
      if (!(node.childMask & (1u << c))) continue;
      const OctreeNode& k = octree.nodes[child++];
      weighted += k.weight * k.normal.cast<double>();
      plain += k.normal.cast<double>();
      weight += k.weight;
    }
    const Eigen::Vector3d sum = weighted.squaredNorm() > 0.0 ? weighted : plain;
    node.normal = sum.squaredNorm() > 0.0 ? Vec3f(sum.normalized().cast<float>()) : Vec3f(Vec3f::UnitZ());
    node.weight = weight;
  }
}

SampleCounts sampleNormalField(octree::BuiltOctree& built, const CoarseFrames& coarse, const DetailSurface& detail,
                               const SamplingSettings& settings,
                               const std::function<void(std::size_t, std::size_t)>& onChunkDone) {
  std::vector<std::uint32_t> leaves;
  for (std::uint32_t n = 0; n < built.octree.nodes.size(); ++n)
    if (built.octree.nodes[n].isLeaf()) leaves.push_back(n);
  std::vector<SampleMoments> moments(built.octree.nodes.size());
  const SampleCounts counts = sampleLeaves(built, leaves, coarse, detail, settings, moments, onChunkDone);
  averageInternalNodes(built.octree, moments, settings.internalNodesMayShowCoarse);
  return counts;
}

SampleCounts sampleLeaves(octree::BuiltOctree& built, std::span<const std::uint32_t> leaves, const CoarseFrames& coarse,
                          const DetailSurface& detail, const SamplingSettings& settings,
                          std::vector<SampleMoments>& moments,
                          const std::function<void(std::size_t, std::size_t)>& onChunkDone) {
  Octree& octree = built.octree;
  const LeafSampler sampler(built, coarse, detail, settings);
  const double unitToWorldArea = 1.0 / (octree.transform.scale * octree.transform.scale);

  const std::size_t chunks = (leaves.size() + kLeavesPerChunk - 1) / kLeavesPerChunk;
  // Each chunk writes its own leaves' moments.
  std::vector<SampleCounts> counts(chunks);
  std::atomic<std::size_t> chunksDone{0};
  tbb::parallel_for(std::size_t{0}, chunks, [&](std::size_t chunk) {
    const std::size_t begin = chunk * kLeavesPerChunk, end = std::min(leaves.size(), begin + kLeavesPerChunk);
    std::vector<Sample> samples;
    std::vector<double> areas(end - begin);
    for (std::size_t i = begin; i < end; ++i)
      sampler.addSamples(leaves[i], static_cast<std::uint32_t>(i - begin), samples, areas[i - begin]);
    // Two rays per sample: along m's normal (rays[k]) and against it
    // (rays[n + k]), each half in the samples' order, neighbours in space:
    // the caster takes them as a coherent stream.
    const std::size_t n = samples.size();
    std::vector<Ray> rays(2 * n);
    for (std::size_t k = 0; k < n; ++k) {
      const float reach = sampler.reachOf(leaves[begin + samples[k].leaf]);
      rays[k] = sampler.rayOf(samples[k], 1.0f, reach);
      rays[n + k] = sampler.rayOf(samples[k], -1.0f, reach);
    }
    std::vector<RayHit> hits;
    detail.caster->intersect(rays, hits);

    std::vector<Eigen::Vector3d> weighted(end - begin, Eigen::Vector3d::Zero()), plain(end - begin, Eigen::Vector3d::Zero());
    std::vector<std::array<Eigen::Vector3d, 2>> sides(end - begin, {Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()});
    SampleCounts& count = counts[chunk];
    count.rays += rays.size();
    for (std::size_t k = 0; k < samples.size(); ++k) {
      const RayHit& forward = hits[k];
      const RayHit& backward = hits[n + k];
      Vec3f normal;
      if (forward.hit() || backward.hit()) {
        const RayHit& nearest = (forward.hit() && (!backward.hit() || forward.t <= backward.t)) ? forward : backward;
        normal = sampler.normalAt(nearest);
        ++count.hits;
      } else {
        const std::optional<SurfacePoint> closest = detail.closest->closest(sampler.originOf(samples[k]));
        if (!closest) {
          ++count.unanswered;
          continue;
        }
        normal = closest->normal;
        ++count.fallbacks;
      }
      const std::uint32_t slot = samples[k].leaf;
      SampleMoments& leafMoments = moments[leaves[begin + slot]];
      leafMoments.weight += samples[k].weight;
      leafMoments.sum += samples[k].weight * normal.cast<double>();
      leafMoments.alongCoarse += samples[k].weight * static_cast<double>(normal.dot(rays[k].direction));
      leafMoments.coarseSum += samples[k].weight * rays[k].direction.cast<double>();
      weighted[slot] += samples[k].weight * normal.cast<double>();
      plain[slot] += normal.cast<double>();
      const OctreeNode& leaf = octree.nodes[leaves[begin + slot]];
      // The forward ray runs along m's normal at the sample.
      if (leaf.twoSided) sides[slot][leafSide(rays[k].direction, leaf.sideAxis)] += samples[k].weight * normal.cast<double>();
    }
    for (std::size_t i = begin; i < end; ++i) {
      OctreeNode& leaf = octree.nodes[leaves[i]];
      const Eigen::Vector3d sum = weighted[i - begin].squaredNorm() > 0.0 ? weighted[i - begin] : plain[i - begin];
      leaf.normal = sum.squaredNorm() > 0.0 ? Vec3f(sum.normalized().cast<float>()) : Vec3f(Vec3f::UnitZ());
      leaf.weight = areas[i - begin] * unitToWorldArea;
      // A side no sample picked (m's normals all on one side here after all)
      // shows the leaf's mean.
      for (int side = 0; side < 2 && leaf.twoSided; ++side)
        leaf.sides[side] = sides[i - begin][side].squaredNorm() > 0.0 ? Vec3f(sides[i - begin][side].normalized().cast<float>())
                                                                       : leaf.normal;
    }
    if (onChunkDone) onChunkDone(++chunksDone, chunks);
  });
  SampleCounts total;
  for (const SampleCounts& c : counts) {
    total.rays += c.rays;
    total.hits += c.hits;
    total.fallbacks += c.fallbacks;
    total.unanswered += c.unanswered;
  }
  return total;
}

}  // namespace apo::sampling
