// Point-based LOD with object textures (Maximo, Marroquim, Esperança): four
// levels of surfels, each merging up to 4 adjacent samples of the level
// below, with Sequential Point Trees' perpendicular error (Dachsbacher et
// al. 2003); the coarsest level's samples are the patches sent to the GPU,
// the three finer levels are stored per patch in the object texture.
#include "adapters/flann/flann_search.h"
#include "render/render.h"

#include <algorithm>
#include <cmath>
#include <numeric>

namespace apo {
namespace {

// Neighbours looked at when grouping a sample with its adjacent ones.
constexpr std::size_t kGroupCandidates = 8;
// Two samples are adjacent when their centres are closer than this many
// times the larger of their radii (their discs overlap or nearly touch).
constexpr float kAdjacentRadii = 2.0f;
// A point's disc is capped at this many times the median spacing: an
// outlying point stays a small disc where no surface is.
constexpr float kRadiusCapOverMedian = 2.0f;

// 21 bits per axis of the box, interleaved: the order the samples are
// grouped in, so that groups grow from neighbouring places.
std::uint64_t mortonCode(const Vec3f& p, const Aabb& box) {
  const Vec3f extent = (box.max - box.min).cwiseMax(Vec3f::Constant(1e-30f));
  std::uint64_t code = 0;
  std::array<std::uint64_t, 3> q{};
  for (int axis = 0; axis < 3; ++axis)
    q[axis] = static_cast<std::uint64_t>(std::clamp((p[axis] - box.min[axis]) / extent[axis], 0.0f, 1.0f) * 2097151.0f);
  for (int bit = 20; bit >= 0; --bit)
    for (int axis = 0; axis < 3; ++axis) code = (code << 1) | ((q[axis] >> bit) & 1u);
  return code;
}

// Groups of up to 4 adjacent samples, each sample in exactly one, in the
// Morton order of their first member.
Result<std::vector<std::vector<std::uint32_t>>> groupAdjacent(const std::vector<Surfel>& samples) {
  std::vector<Vec3f> positions;
  positions.reserve(samples.size());
  for (const Surfel& s : samples) positions.push_back(s.position);
  auto graph = flann_adapter::nearestNeighbourGraph(positions, kGroupCandidates);
  if (!graph) return graph.error();
  const Aabb box = boundingBox(positions);
  std::vector<std::uint64_t> codes(samples.size());
  for (std::size_t i = 0; i < samples.size(); ++i) codes[i] = mortonCode(positions[i], box);
  std::vector<std::uint32_t> order(samples.size());
  std::iota(order.begin(), order.end(), 0u);
  std::stable_sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) { return codes[a] < codes[b]; });
  std::vector<bool> taken(samples.size(), false);
  std::vector<std::vector<std::uint32_t>> groups;
  for (const std::uint32_t first : order) {
    if (taken[first]) continue;
    std::vector<std::uint32_t> group = {first};
    taken[first] = true;
    for (std::size_t j = 0; j < graph->k && group.size() < kLodFanOut; ++j) {
      const std::uint32_t other = graph->neighbours[first * graph->k + j];
      if (taken[other]) continue;
      const Surfel& a = samples[first];
      const Surfel& b = samples[other];
      // Adjacent, and on the same side (never both sides of a thin part).
      if ((a.position - b.position).norm() > kAdjacentRadii * std::max(a.radius, b.radius) || a.normal.dot(b.normal) <= 0.0f)
        continue;
      group.push_back(other);
      taken[other] = true;
    }
    groups.push_back(std::move(group));
  }
  return groups;
}

std::vector<float> cappedRadii(std::vector<float> radii) {
  if (radii.empty()) return radii;
  std::vector<float> sorted = radii;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2), sorted.end());
  const float cap = kRadiusCapOverMedian * sorted[sorted.size() / 2];
  for (float& r : radii) r = std::min(r, cap);
  return radii;
}

}  // namespace

Surfel mergeSurfels(const std::vector<Surfel>& children) {
  APO_CHECK(!children.empty());
  double weight = 0.0;
  Vec3f position = Vec3f::Zero(), normal = Vec3f::Zero();
  for (const Surfel& c : children) {
    // By area: a disc stands for its share of the surface.
    const float w = std::max(c.radius * c.radius, 1e-30f);
    weight += w;
    position += w * c.position;
    normal += w * c.normal;
  }
  Surfel merged;
  merged.position = position / static_cast<float>(weight);
  merged.normal = normal.norm() > 0.0f ? Vec3f(normal.normalized()) : children.front().normal;
  float low = 0.0f, high = 0.0f;
  bool first = true;
  for (const Surfel& c : children) {
    const Vec3f offset = c.position - merged.position;
    merged.radius = std::max(merged.radius, offset.norm() + c.radius);
    // The child's extent along the merged normal: its centre's height, its
    // disc's tilt, and the thickness it already stands for.
    const float height = offset.dot(merged.normal);
    const float cosine = std::clamp(c.normal.dot(merged.normal), -1.0f, 1.0f);
    const float reach = c.radius * std::sqrt(std::max(0.0f, 1.0f - cosine * cosine)) + 0.5f * c.perpendicularError;
    low = first ? height - reach : std::min(low, height - reach);
    high = first ? height + reach : std::max(high, height + reach);
    first = false;
    // The child's own spread adds to its normal's angle (atan2: small angles exact).
    const float angle = std::atan2(c.normal.cross(merged.normal).norm(), c.normal.dot(merged.normal));
    merged.normalSpread = std::max(merged.normalSpread, angle + c.normalSpread);
  }
  merged.perpendicularError = high - low;
  return merged;
}

float projectedLodError(float perpendicularError, const Vec3f& position, const Vec3f& eye, float pixelsPerWorldUnitAtOne) {
  const float distance = std::max((eye - position).norm(), 1e-30f);
  return perpendicularError * pixelsPerWorldUnitAtOne / distance;
}

int chooseLodLevel(const Surfel& patch, const LodPatch& finer, const Vec3f& eye, float pixelsPerWorldUnitAtOne,
                   float thresholdPixels) {
  const auto fine = [&](float error) {
    return projectedLodError(error, patch.position, eye, pixelsPerWorldUnitAtOne) <= thresholdPixels;
  };
  if (fine(lodError(patch))) return 3;
  if (fine(finer.maxError[0])) return 2;
  if (fine(finer.maxError[1])) return 1;
  return 0;
}

Result<PointLod> buildPointLod(const PointSet& points) {
  if (!points.hasNormals()) return badInput("render: M is a point cloud without normals (run apo ingest, which estimates them)");
  if (points.size() > std::numeric_limits<std::uint32_t>::max() / 2)
    return badInput("render: {} points are more than the point LOD indexes", points.size());
  auto radii = discRadii(points);
  if (!radii) return radii.error();
  const std::vector<float> capped = cappedRadii(std::move(radii).value());
  PointLod lod;
  lod.levels[0].reserve(points.size());
  for (std::size_t i = 0; i < points.size(); ++i)
    lod.levels[0].push_back(Surfel{points.positions[i], points.normals[i].normalized(), capped[i], 0.0f});

  // children[k][j]: the samples of level k merged into sample j of level k + 1.
  std::array<std::vector<std::vector<std::uint32_t>>, kLodLevels - 1> children;
  for (int level = 0; level + 1 < kLodLevels; ++level) {
    auto groups = groupAdjacent(lod.levels[level]);
    if (!groups) return groups.error();
    children[level] = std::move(groups).value();
    lod.parent[level].assign(lod.levels[level].size(), 0);
    for (std::uint32_t j = 0; j < children[level].size(); ++j) {
      std::vector<Surfel> merged;
      for (const std::uint32_t child : children[level][j]) {
        merged.push_back(lod.levels[level][child]);
        lod.parent[level][child] = j;
      }
      lod.levels[level + 1].push_back(mergeSurfels(merged));
    }
  }

  // The object texture: per patch, its level-2, then level-1, then level-0
  // samples (coarsest first, as in the paper), each level in the order of
  // the groups.
  for (std::uint32_t patch = 0; patch < lod.levels[3].size(); ++patch) {
    LodPatch record;
    record.first = static_cast<std::uint32_t>(lod.objectTexture.size());
    std::vector<std::uint32_t> current = {patch};
    for (int level = 2; level >= 0; --level) {
      std::vector<std::uint32_t> next;
      for (const std::uint32_t sample : current)
        for (const std::uint32_t child : children[level][sample]) next.push_back(child);
      const int slot = 2 - level;
      record.count[slot] = static_cast<std::uint32_t>(next.size());
      for (const std::uint32_t sample : next) {
        const Surfel& s = lod.levels[level][sample];
        lod.objectTexture.push_back(s);
        record.maxError[slot] = std::max(record.maxError[slot], lodError(s));
      }
      current = std::move(next);
    }
    lod.patches.push_back(record);
  }
  return lod;
}

}  // namespace apo
