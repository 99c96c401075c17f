#include "ingest/normals.h"

#include "adapters/cgal/cgal_jobs.h"
#include "adapters/flann/flann_search.h"
#include "adapters/pcl/pcl_points.h"

#include "core/timing.h"

#include <Eigen/Eigenvalues>
#include <spdlog/spdlog.h>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <array>
#include <tuple>

namespace apo::normals {
namespace {

constexpr std::size_t kSubsampleSize = 2000;

struct PlaneScratch {
  std::vector<float> squaredDistances;
  std::vector<float> sorted;
};
// Points whose line to their sensor is tested (line_of_sight::measure).
constexpr std::size_t kSightSamples = 4000;
// A normal facing its sensor at this cosine or more is seen squarely
// (orientFromSquarelySeen).
constexpr float kSquarelySeen = 0.3f;
// Neighbours of each point in the orientation graph. CGAL's MST takes
// max(k, 12) (k of the normals); the propagation takes 12 whatever k is:
// on a 1M-point scan with k = 48 it oriented every normal the same way with
// 12 (0 flipped against the true normals) in 6 s and 0.4 GiB, and in 16 s
// and 0.7 GiB with 24 (docs/benchmarks.md, "Raw acquisitions").
constexpr int kMinMstNeighbours = 12;
constexpr std::size_t kPropagationNeighbours = 12;
constexpr double kMinPlanarity = 0.25;  // median lambda1/lambda2 of a 2-D patch
constexpr double kSameSpread = 1e-6;    // eigenvalues closer than this share of the trace are equal
// Lines of sight whose cosine is below this (more than 107 degrees apart)
// come from the other side of a surface: two scans grazing one face from
// either side are rarely that far apart. Chosen on the camel's 10 scans
// among -0.5 to 0.5 and checked on four other meshes (docs/benchmarks.md,
// "Scan positions"): fewer flipped normals on all five, a lower mean angle
// on all five; at 0 two of them had a higher mean angle.
constexpr float kOtherSide = -0.3f;
constexpr std::size_t kMinSameSide = 6;

// Eigenvalues (ascending) of the covariance of the first k neighbours.
Eigen::Vector3d covarianceEigenvalues(const std::vector<Vec3f>& points, const std::vector<int>& neighbours, int k) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (int i = 0; i < k; ++i) mean += points[neighbours[i]].cast<double>();
  mean /= k;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (int i = 0; i < k; ++i) {
    const Eigen::Vector3d d = points[neighbours[i]].cast<double>() - mean;
    covariance += d * d.transpose();
  }
  return Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(covariance, Eigen::EigenvaluesOnly).eigenvalues();
}

std::vector<std::uint32_t> evenSubsample(std::size_t count, std::size_t wanted) {
  std::vector<std::uint32_t> picked;
  const std::size_t stride = std::max<std::size_t>(1, count / wanted);
  for (std::size_t i = 0; i < count; i += stride) picked.push_back(static_cast<std::uint32_t>(i));
  return picked;
}

double median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  const auto middle = values.begin() + static_cast<std::ptrdiff_t>(values.size() / 2);
  std::nth_element(values.begin(), middle, values.end());
  return *middle;
}

template <class T>
std::vector<T> gather(const std::vector<T>& values, const std::vector<std::uint32_t>& indices) {
  std::vector<T> picked;
  picked.reserve(indices.size());
  for (std::uint32_t i : indices) picked.push_back(values[i]);
  return picked;
}

// For each of `queries`, whether its normal agrees (non-negative dot product)
// with the normal of the nearest point in `reference`.
Result<std::vector<char>> agreesWithNearest(const std::vector<Vec3f>& points, const std::vector<Vec3f>& normals,
                                            const std::vector<std::uint32_t>& reference,
                                            const std::vector<std::uint32_t>& queries) {
  const auto nearest = pcl_adapter::nearestInReference(gather(points, reference), gather(points, queries));
  if (!nearest) return nearest.error();
  std::vector<char> agrees(queries.size());
  for (std::size_t q = 0; q < queries.size(); ++q)
    agrees[q] = normals[queries[q]].dot(normals[reference[static_cast<std::size_t>((*nearest)[q])]]) >= 0.0f;
  return agrees;
}

// Each of `leftovers` turned, if need be, to agree with the nearest of
// `oriented`.
Status turnLikeNearest(const std::vector<Vec3f>& points, std::vector<Vec3f>& normals,
                       const std::vector<std::uint32_t>& oriented, const std::vector<std::uint32_t>& leftovers) {
  if (leftovers.empty() || oriented.empty()) return okStatus();
  const auto agrees = agreesWithNearest(points, normals, oriented, leftovers);
  if (!agrees) return agrees.error();
  for (std::size_t q = 0; q < leftovers.size(); ++q)
    if (!(*agrees)[q]) normals[leftovers[q]] = -normals[leftovers[q]];
  return okStatus();
}

constexpr std::uint32_t kNoIsland = ~0u;

struct IslandOrientation {
  std::size_t islands = 0;     // k-NN graph components oriented by their own MST
  std::size_t leftovers = 0;   // points oriented by their nearest neighbour alone
  // The propagation's: each point's island (kNoIsland for leftovers).
  std::vector<std::uint32_t> islandOf;
};

// Connected components of the symmetric k-nearest-neighbour graph, largest
// first (ties: lowest first index), each listing its points ascending.
Result<std::vector<std::vector<std::uint32_t>>> neighbourGraphComponents(const std::vector<Vec3f>& points, int k) {
  std::vector<std::uint32_t> all(points.size());
  std::iota(all.begin(), all.end(), 0u);
  const auto found = pcl_adapter::nearestNeighbours(points, all, std::min<int>(k + 1, static_cast<int>(points.size())));
  if (!found) return found.error();
  const std::vector<std::vector<int>>& neighbours = *found;
  std::vector<std::uint32_t> parent(all);
  auto root = [&](std::uint32_t i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  for (std::uint32_t i = 0; i < points.size(); ++i)
    for (int j : neighbours[i]) {
      const std::uint32_t a = root(i), b = root(static_cast<std::uint32_t>(j));
      if (a != b) parent[std::max(a, b)] = std::min(a, b);
    }
  std::vector<std::vector<std::uint32_t>> byRoot(points.size());
  for (std::uint32_t i = 0; i < points.size(); ++i) byRoot[root(i)].push_back(i);
  std::vector<std::vector<std::uint32_t>> components;
  for (auto& members : byRoot)
    if (!members.empty()) components.push_back(std::move(members));
  std::stable_sort(components.begin(), components.end(),
                   [](const auto& a, const auto& b) { return a.size() > b.size(); });
  return components;
}

// CGAL's MST orients only the k-NN graph component that holds the highest
// point, turning that point's normal up. A scan in separate pieces (several
// objects, debris) is therefore oriented component by component with the
// same rule, which is right for closed objects: each one's highest normal
// points up and out. Components too small for a graph (k points or fewer),
// and points CGAL leaves, agree with their nearest oriented point.
Result<IslandOrientation> orientByIslands(const std::vector<Vec3f>& points, std::vector<Vec3f>& normals, int k) {
  IslandOrientation result;
  std::vector<std::uint32_t> oriented, leftovers;
  const auto components = neighbourGraphComponents(points, k);
  if (!components) return components.error();
  for (const auto& component : *components) {
    if (component.size() <= static_cast<std::size_t>(k)) {
      leftovers.insert(leftovers.end(), component.begin(), component.end());
      continue;
    }
    std::vector<Vec3f> componentNormals = gather(normals, component);
    const auto left = cgal_adapter::orientNormalsMst(gather(points, component), componentNormals, k);
    if (!left) return left.error();
    std::vector<char> isLeft(component.size(), 0);
    for (std::uint32_t i : *left) isLeft[i] = 1;
    for (std::size_t i = 0; i < component.size(); ++i) {
      normals[component[i]] = componentNormals[i];
      (isLeft[i] ? leftovers : oriented).push_back(component[i]);
    }
    ++result.islands;
  }
  APO_RETURN_IF_ERROR(turnLikeNearest(points, normals, oriented, leftovers));
  result.leftovers = leftovers.size();
  return result;
}

// The symmetric k-nearest-neighbour graph in compressed rows: the neighbours
// of point i are adjacency[offsets[i], offsets[i + 1]), each edge both ways.
struct Adjacency {
  std::vector<std::uint64_t> offsets;
  std::vector<std::uint32_t> adjacency;
};

// The first `columns` neighbours of each row, made symmetric.
Adjacency symmetricGraph(const flann_adapter::NeighbourGraph& graph, std::size_t columns, std::size_t count) {
  columns = std::min(columns, graph.k);
  Adjacency result;
  result.offsets.assign(count + 1, 0);
  for (std::size_t i = 0; i < count; ++i)
    for (std::size_t j = 0; j < columns; ++j) {
      ++result.offsets[i + 1];
      ++result.offsets[graph.neighbours[i * graph.k + j] + 1];
    }
  std::partial_sum(result.offsets.begin(), result.offsets.end(), result.offsets.begin());
  result.adjacency.resize(result.offsets[count]);
  std::vector<std::uint64_t> next(result.offsets.begin(), result.offsets.end() - 1);
  for (std::size_t i = 0; i < count; ++i)
    for (std::size_t j = 0; j < columns; ++j) {
      const std::uint32_t other = graph.neighbours[i * graph.k + j];
      result.adjacency[next[i]++] = other;
      result.adjacency[next[other]++] = static_cast<std::uint32_t>(i);
    }
  return result;
}

// Points of each connected component of the graph, in breadth-first order
// from its lowest index; components in order of their lowest index.
std::vector<std::vector<std::uint32_t>> graphComponents(const Adjacency& graph, std::size_t count) {
  std::vector<std::vector<std::uint32_t>> components;
  std::vector<char> seen(count, 0);
  for (std::uint32_t start = 0; start < count; ++start) {
    if (seen[start]) continue;
    std::vector<std::uint32_t> members{start};
    seen[start] = 1;
    for (std::size_t head = 0; head < members.size(); ++head)
      for (std::uint64_t e = graph.offsets[members[head]]; e < graph.offsets[members[head] + 1]; ++e)
        if (!seen[graph.adjacency[e]]) {
          seen[graph.adjacency[e]] = 1;
          members.push_back(graph.adjacency[e]);
        }
    components.push_back(std::move(members));
  }
  return components;
}

// Prim's frontier: edges in 256 buckets of weight (1 - |n_i . n_j|, in
// [0, 1]), first in first out within a bucket. Constant time per edge where
// a binary heap took log n: the tree is a minimum spanning tree to within a
// 256th of the weight range, which is all the propagation needs.
class BucketQueue {
 public:
  static constexpr int kBuckets = 256;
  struct Edge {
    std::uint32_t to, from;
  };

  static int bucketOf(float weight) { return std::clamp(static_cast<int>(weight * kBuckets), 0, kBuckets - 1); }
  void push(int bucket, Edge edge) {
    buckets_[bucket].push_back(edge);
    lowest_ = std::min(lowest_, bucket);
    ++size_;
  }
  bool empty() const { return size_ == 0; }
  Edge pop() {
    while (read_[lowest_] == buckets_[lowest_].size()) {
      buckets_[lowest_].clear();
      read_[lowest_] = 0;
      ++lowest_;
    }
    --size_;
    return buckets_[lowest_][read_[lowest_]++];
  }

 private:
  std::array<std::vector<Edge>, kBuckets> buckets_;
  std::array<std::size_t, kBuckets> read_{};
  int lowest_ = kBuckets - 1;
  std::size_t size_ = 0;
};

// Hoppe et al.'s propagation (the rule CGAL's MST orientation follows, in a
// fraction of its time and memory): from the component's highest point,
// whose normal is turned up, visit the points in the order of a minimum
// spanning tree of the graph weighted by 1 - |n_i . n_j| (Prim over a bucket
// queue), turning each normal to agree with the one it was reached from.
// Nearly parallel normals are passed on first, so a flip crosses sharp
// creases and thin sheets last.
// `lightest[i]` is the lightest bucket point i was queued with (kBuckets
// before): an edge to it no lighter can never be the one it is reached
// through (the lighter one, or the earlier of equal ones, is popped first),
// so it is not queued; the tree is the same, with far fewer pushes.
void propagateFromSeeds(const Adjacency& graph, std::vector<Vec3f>& normals, const std::vector<std::uint32_t>& seeds,
                        std::vector<char>& visited, std::vector<std::uint16_t>& lightest) {
  BucketQueue frontier;
  auto pushEdgesOf = [&](std::uint32_t from) {
    visited[from] = 1;
    for (std::uint64_t e = graph.offsets[from]; e < graph.offsets[from + 1]; ++e) {
      const std::uint32_t to = graph.adjacency[e];
      if (visited[to]) continue;
      const int bucket = BucketQueue::bucketOf(1.0f - std::abs(normals[from].dot(normals[to])));
      if (bucket >= lightest[to]) continue;
      lightest[to] = static_cast<std::uint16_t>(bucket);
      frontier.push(bucket, {to, from});
    }
  };
  for (std::uint32_t seed : seeds) visited[seed] = 1;
  for (std::uint32_t seed : seeds) pushEdgesOf(seed);
  while (!frontier.empty()) {
    const auto [to, from] = frontier.pop();
    if (visited[to]) continue;
    if (normals[from].dot(normals[to]) < 0.0f) normals[to] = -normals[to];
    pushEdgesOf(to);
  }
}

void propagateFromHighest(const Adjacency& graph, const std::vector<Vec3f>& points, std::vector<Vec3f>& normals,
                          const std::vector<std::uint32_t>& component, std::vector<char>& visited,
                          std::vector<std::uint16_t>& lightest) {
  const std::uint32_t seed = *std::max_element(component.begin(), component.end(), [&](std::uint32_t a, std::uint32_t b) {
    return std::tie(points[a].z(), b) < std::tie(points[b].z(), a);
  });
  if (normals[seed].z() < 0.0f) normals[seed] = -normals[seed];
  propagateFromSeeds(graph, normals, {seed}, visited, lightest);
}

// Normals facing their sensors where they face it squarely (cosine at least
// kSquarelySeen), the rest by propagation from those: a plane fitted at a
// grazing angle, tilted by noise or by a thin part's other face, can face
// the sensor the wrong way, its neighbours seen squarely cannot. Points in
// pieces with no squarely seen point keep facing their sensor.
void orientFromSquarelySeen(const std::vector<Vec3f>& points, std::vector<Vec3f>& facing, const Sensors& sensors,
                            const flann_adapter::NeighbourGraph& nearest) {
  const Adjacency graph = symmetricGraph(nearest, kPropagationNeighbours, points.size());
  std::vector<std::uint32_t> squarely;
  for (std::uint32_t i = 0; i < points.size(); ++i) {
    const Vec3f toSensor = sensors.of(i) - points[i];
    if (facing[i].allFinite() && facing[i].dot(toSensor) >= kSquarelySeen * toSensor.norm()) squarely.push_back(i);
  }
  std::vector<Vec3f> defined = facing;
  for (Vec3f& n : defined)
    if (!n.allFinite()) n = Vec3f::UnitZ();
  std::vector<char> visited(points.size(), 0);
  std::vector<std::uint16_t> lightest(points.size(), BucketQueue::kBuckets);
  propagateFromSeeds(graph, defined, squarely, visited, lightest);
  for (std::size_t i = 0; i < points.size(); ++i)
    if (facing[i].allFinite()) facing[i] = defined[i];
}

// Orientation by propagation over the graph's first `columns` neighbours,
// component by component (each one's highest normal up and out, as for
// closed objects); components of `columns` points or fewer agree with their
// nearest oriented point.
Result<IslandOrientation> orientByPropagation(const std::vector<Vec3f>& points, std::vector<Vec3f>& normals,
                                              const flann_adapter::NeighbourGraph& nearest, std::size_t columns) {
  IslandOrientation result;
  const Adjacency graph = symmetricGraph(nearest, columns, points.size());
  std::vector<char> visited(points.size(), 0);
  std::vector<std::uint16_t> lightest(points.size(), BucketQueue::kBuckets);
  std::vector<std::uint32_t> oriented, leftovers;
  result.islandOf.assign(points.size(), kNoIsland);
  for (const auto& component : graphComponents(graph, points.size())) {
    if (component.size() <= columns) {
      leftovers.insert(leftovers.end(), component.begin(), component.end());
      continue;
    }
    propagateFromHighest(graph, points, normals, component, visited, lightest);
    oriented.insert(oriented.end(), component.begin(), component.end());
    for (std::uint32_t i : component) result.islandOf[i] = static_cast<std::uint32_t>(result.islands);
    ++result.islands;
  }
  std::sort(leftovers.begin(), leftovers.end());
  std::sort(oriented.begin(), oriented.end());
  APO_RETURN_IF_ERROR(turnLikeNearest(points, normals, oriented, leftovers));
  result.leftovers = leftovers.size();
  return result;
}

// Each neighbour's weight in the plane fit: a Gaussian of its distance
// whose standard deviation is the neighbourhood's median distance (the point
// itself counted at 0). Where a part is thinner or more curved than the
// neighbourhood, its farthest points (around the tip, on the far face) tilt
// a plane fitted with equal weights; the nearest follow the surface. The
// median, not a fixed radius, keeps the weights the same at any density.
// Against equal weights, on six meshes scanned from 10 positions
// (bench/e57_flips.sh): as many or fewer flipped normals on each, a lower
// mean angle to the truth on each (the camel's flips 48 -> 35); on a dense
// noisy 1M-point scan, where equal weights average the most noise, 2.75
// degrees against 2.73. A narrower Gaussian (2 sigma^2 the median's square)
// took a little more off on the six but put 5% on the dense scan's angle
// (docs/benchmarks.md, "Scan positions").
// Returns sigma^2, the median squared distance; 0 where half the neighbours
// or more sit on the point itself (the weights are then uniform).
float medianSquaredDistance(const std::vector<float>& squaredDistances, std::vector<float>& sorted) {
  sorted.assign(squaredDistances.begin(), squaredDistances.end());
  sorted.push_back(0.0f);
  const auto middle = sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2);
  std::nth_element(sorted.begin(), middle, sorted.end());
  return *middle;
}

// The normal of the plane fitted to a point and its first `others`
// neighbours (the eigenvector of the smallest eigenvalue of their covariance,
// weighted by distance: medianSquaredDistance), turned towards `towards`. NaN when
// the neighbourhood has fewer than 3 points, no extent, or no one flattest
// direction (its two smallest spreads equal: a ball of points, not a patch
// of surface). `scratch` holds no state between calls; it spares an
// allocation per point.
Vec3f planeNormal(const Vec3f& point, const std::vector<Vec3f>& points, const std::uint32_t* neighbours,
                  std::size_t others, const Vec3f& towards, PlaneScratch& scratch) {
  constexpr float kUndefined = std::numeric_limits<float>::quiet_NaN();
  if (others + 1 < 3) return Vec3f::Constant(kUndefined);
  scratch.squaredDistances.resize(others);
  for (std::size_t j = 0; j < others; ++j)
    scratch.squaredDistances[j] = (points[neighbours[j]] - point).squaredNorm();
  const float sigma2 = medianSquaredDistance(scratch.squaredDistances, scratch.sorted);
  // Offsets from the point itself keep the sums exact for georeferenced
  // coordinates as well. The point itself weighs 1 at offset 0.
  const Eigen::Vector3d origin = point.cast<double>();
  double total = 1.0;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  Eigen::Matrix3d products = Eigen::Matrix3d::Zero();
  for (std::size_t j = 0; j < others; ++j) {
    const double w = sigma2 > 0.0f ? std::exp(-scratch.squaredDistances[j] / (2.0f * sigma2)) : 1.0f;
    const Eigen::Vector3d d = points[neighbours[j]].cast<double>() - origin;
    total += w;
    sum += w * d;
    products += w * d * d.transpose();
  }
  const Eigen::Vector3d mean = sum / total;
  const Eigen::Matrix3d covariance = products / total - mean * mean.transpose();
  if (!(covariance.trace() > 0.0)) return Vec3f::Constant(kUndefined);
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(covariance);
  const Eigen::Vector3d spread = solver.eigenvalues();  // ascending
  if (spread[1] - spread[0] <= kSameSpread * covariance.trace()) return Vec3f::Constant(kUndefined);
  Vec3f normal = solver.eigenvectors().col(0).cast<float>().normalized();
  if (normal.dot(towards - point) < 0.0f) normal = -normal;
  return normal;
}

// Each point's line of sight: the unit vector to its sensor.
std::vector<Vec3f> unitSights(const std::vector<Vec3f>& points, const Sensors& sensors) {
  std::vector<Vec3f> sights(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) sights[i] = (sensors.of(i) - points[i]).normalized();
  return sights;
}

// The first `others` graph neighbours of point i seen from its side: those
// whose line of sight (from the neighbour to its own sensor) is within
// kOtherSide of point i's. Where a part is thinner than the neighbourhood,
// scans taken from opposite sides each see one face; the other face's
// points, seen from the other side, would tilt the plane. All of them when
// fewer than kMinSameSide remain.
std::size_t sameSideNeighbours(std::size_t i, const flann_adapter::NeighbourGraph& graph, std::size_t others,
                               const std::vector<Vec3f>& sights, std::vector<std::uint32_t>& kept) {
  const std::uint32_t* row = &graph.neighbours[i * graph.k];
  kept.clear();
  for (std::size_t j = 0; j < others; ++j)
    if (sights[row[j]].dot(sights[i]) >= kOtherSide) kept.push_back(row[j]);
  if (kept.size() >= kMinSameSide) return kept.size();
  kept.assign(row, row + others);
  return others;
}

// PCA normals from each point and its first k - 1 graph neighbours (with
// sensors of their own, only those seen from the same side: sameSideNeighbours),
// each turned towards its sensor, on every core (each normal written by one
// task: the result does not depend on their number).
std::vector<Vec3f> pcaNormals(const std::vector<Vec3f>& points, const flann_adapter::NeighbourGraph& graph, int k,
                              const std::optional<Sensors>& sensors) {
  const std::size_t others = std::min(graph.k, static_cast<std::size_t>(std::max(k - 1, 0)));
  // Without sensors the propagation decides; the origin only makes the
  // starting signs reproducible.
  const Sensors towards = sensors ? *sensors : Sensors::single(Vec3f::Zero());
  const std::vector<Vec3f> sights = sensors ? unitSights(points, *sensors) : std::vector<Vec3f>();
  std::vector<Vec3f> normals(points.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, points.size(), 4096), [&](const auto& range) {
    std::vector<std::uint32_t> kept;
    PlaneScratch scratch;
    for (std::size_t i = range.begin(); i < range.end(); ++i) {
      const std::size_t count = sensors ? sameSideNeighbours(i, graph, others, sights, kept) : others;
      const std::uint32_t* fitted = sensors ? kept.data() : &graph.neighbours[i * graph.k];
      normals[i] = planeNormal(points[i], points, fitted, count, towards.of(i), scratch);
    }
  });
  return normals;
}

// Each propagated island turned, if need be, so that most of its points
// face their sensors: how the two would agree if the sensors were right.
void signIslandsBySensors(const std::vector<Vec3f>& facing, std::vector<Vec3f>& propagated,
                          const IslandOrientation& islands) {
  std::vector<std::int64_t> vote(islands.islands, 0);
  for (std::size_t i = 0; i < propagated.size(); ++i)
    if (islands.islandOf[i] != kNoIsland && facing[i].allFinite())
      vote[islands.islandOf[i]] += propagated[i].dot(facing[i]) >= 0.0f ? 1 : -1;
  for (std::size_t i = 0; i < propagated.size(); ++i)
    if (islands.islandOf[i] != kNoIsland && vote[islands.islandOf[i]] < 0) propagated[i] = -propagated[i];
}

// The line-of-sight test's cell: twice the median distance to the sixth
// nearest neighbour, so that a surface's cells leave no gap for a line to
// slip through.
float sightCell(const std::vector<Vec3f>& points, const flann_adapter::NeighbourGraph& graph) {
  if (graph.k == 0) return 0.0f;
  const std::size_t column = std::min<std::size_t>(5, graph.k - 1);
  std::vector<double> distances;
  for (std::uint32_t i : evenSubsample(points.size(), kSubsampleSize))
    distances.push_back((points[graph.neighbours[i * graph.k + column]] - points[i]).norm());
  return static_cast<float>(2.0 * median(distances));
}

SensorAgreement measureAgreement(const std::vector<Vec3f>& points, const std::vector<Vec3f>& facing,
                                 const std::vector<Vec3f>& propagated, const Sensors& sensors, float cell) {
  SensorAgreement agreement;
  for (std::size_t i = 0; i < facing.size(); ++i) {
    if (!facing[i].allFinite()) continue;
    ++agreement.compared;
    if (facing[i].dot(propagated[i]) < 0.0f) ++agreement.disagreeing;
  }
  agreement.sight = line_of_sight::measure(points, facing, sensors, cell, kSightSamples);
  agreement.sensorsKept =
      agreement.share() <= kMaxSensorDisagreement || agreement.sight.share() <= kMaxHiddenFromSensor;
  return agreement;
}

// Every normal defined (orienting needs them all; undefined ones are
// dropped by the caller), oriented by `orientation`.
Result<IslandOrientation> orientAll(const std::vector<Vec3f>& points, std::vector<Vec3f>& normals,
                                    const flann_adapter::NeighbourGraph& graph, int neighbours,
                                    OrientationMethod orientation) {
  for (Vec3f& n : normals)
    if (!n.allFinite()) n = Vec3f::UnitZ();
  return orientation == OrientationMethod::CgalMst
             ? orientByIslands(points, normals, std::max(neighbours, kMinMstNeighbours))
             : orientByPropagation(points, normals, graph, kPropagationNeighbours);
}

}  // namespace

Result<int> chooseNeighbourCount(const std::vector<Vec3f>& points) {
  const int largest = kCandidateNeighbourCounts[std::size(kCandidateNeighbourCounts) - 1];
  const int available = static_cast<int>(std::min<std::size_t>(points.size(), largest));
  if (available <= kCandidateNeighbourCounts[0]) return std::max(3, available);

  const auto samples = evenSubsample(points.size(), kSubsampleSize);
  const auto found = pcl_adapter::nearestNeighbours(points, samples, available);
  if (!found) return found.error();
  const std::vector<std::vector<int>>& neighbourhoods = *found;

  int best = 0;
  double bestVariation = 0.0;
  for (int k : kCandidateNeighbourCounts) {
    if (k > available) break;
    std::vector<double> planarity;
    double variationSum = 0.0;
    for (const auto& neighbours : neighbourhoods) {
      if (static_cast<int>(neighbours.size()) < k) continue;
      const Eigen::Vector3d lambda = covarianceEigenvalues(points, neighbours, k).cwiseMax(0.0);
      const double total = lambda.sum();
      if (total <= 0.0) continue;
      variationSum += lambda[0] / total;
      planarity.push_back(lambda[2] > 0 ? lambda[1] / lambda[2] : 0.0);
    }
    if (planarity.empty() || median(planarity) < kMinPlanarity) continue;
    const double meanVariation = variationSum / static_cast<double>(planarity.size());
    if (best == 0 || meanVariation < bestVariation) {
      best = k;
      bestVariation = meanVariation;
    }
  }
  // Every candidate looked one-dimensional: take the widest neighbourhood.
  return best != 0 ? best : available;
}

Result<OrientedNormals> estimateOrientedNormals(const std::vector<Vec3f>& points,
                                                const std::optional<Sensors>& sensors, int k,
                                                OrientationMethod orientation) {
  OrientedNormals result;
  Stopwatch phase;
  if (k > 0) {
    result.neighbours = k;
  } else {
    const Result<int> chosen = chooseNeighbourCount(points);
    if (!chosen) return chosen.error();
    result.neighbours = *chosen;
  }
  spdlog::info("ingest: k = {} for normals{} in {:.2f} s", result.neighbours, k > 0 ? " (given)" : " (chosen)", phase.seconds());
  phase = Stopwatch();
  // One neighbour search serves the plane fits (k - 1 others) and the
  // orientation graph (its first kPropagationNeighbours columns).
  const std::size_t searched = std::max(static_cast<std::size_t>(result.neighbours - 1), kPropagationNeighbours);
  const auto graph = flann_adapter::nearestNeighbourGraph(points, searched);
  if (!graph) return graph.error();
  spdlog::info("ingest: {} nearest neighbours of {} points in {:.2f} s", graph->k, points.size(), phase.seconds());
  phase = Stopwatch();
  result.normals = pcaNormals(points, *graph, result.neighbours, sensors);
  spdlog::info("ingest: PCA normals of {} points in {:.2f} s", points.size(), phase.seconds());
  phase = Stopwatch();
  // With sensors, the propagation is the check (SensorAgreement), whatever
  // `orientation` would have been.
  const OrientationMethod method = sensors ? OrientationMethod::Propagation : orientation;
  std::vector<Vec3f> oriented = result.normals;
  Result<IslandOrientation> islands = orientAll(points, oriented, *graph, result.neighbours, method);
  if (!islands) return islands.error();
  spdlog::info("ingest: normals oriented by {} in {:.2f} s", orientationMethodName(method), phase.seconds());
  if (sensors) {
    std::vector<Vec3f> signedBySensors = oriented;
    signIslandsBySensors(result.normals, signedBySensors, *islands);
    result.agreement = measureAgreement(points, result.normals, signedBySensors, *sensors, sightCell(points, *graph));
    if (result.agreement->sensorsKept) {
      orientFromSquarelySeen(points, result.normals, *sensors, *graph);
      result.orientation = "viewpoint";
      return result;
    }
    // Sensors that are not where the points were seen from say nothing of
    // which neighbours share a face: the planes are fitted again over every
    // neighbour, as without sensors.
    result.normals = pcaNormals(points, *graph, result.neighbours, std::nullopt);
    oriented = result.normals;
    islands = orientAll(points, oriented, *graph, result.neighbours, method);
    if (!islands) return islands.error();
  }
  result.orientation = orientationMethodName(method);
  for (std::size_t i = 0; i < points.size(); ++i)
    if (result.normals[i].allFinite()) result.normals[i] = oriented[i];
  result.islands = islands->islands;
  result.unoriented = islands->leftovers;
  return result;
}

GuidedNormals guidedNormals(const std::vector<Vec3f>& reference, const std::vector<Vec3f>& queries,
                            const flann_adapter::NearestRows& nearest, const std::vector<Vec3f>& guides) {
  GuidedNormals result;
  result.normals.resize(queries.size());
  std::vector<char> fitted(queries.size(), 0);
  // Each row holds the query itself first (it is among the reference
  // points), then its k - 1 nearest others.
  const std::size_t others = nearest.k > 0 ? nearest.k - 1 : 0;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, queries.size(), 1024), [&](const auto& range) {
    PlaneScratch scratch;
    for (std::size_t q = range.begin(); q < range.end(); ++q) {
      const Vec3f normal = planeNormal(queries[q], reference, &nearest.indices[q * nearest.k + 1], others,
                                       queries[q] + guides[q], scratch);
      fitted[q] = normal.allFinite() ? 1 : 0;
      result.normals[q] = fitted[q] ? normal : guides[q];
    }
  });
  for (const char f : fitted) result.unfitted += f ? 0 : 1;
  return result;
}

}  // namespace apo::normals
