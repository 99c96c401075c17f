#include "ingest/normals.h"

#include "ingest/cgal_adapter.h"
#include "ingest/pcl_adapter.h"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <numeric>

namespace apo::normals {
namespace {

constexpr std::size_t kSubsampleSize = 2000;
constexpr double kMinPlanarity = 0.25;  // median lambda1/lambda2 of a 2-D patch

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
std::vector<char> agreesWithNearest(const std::vector<Vec3f>& points, const std::vector<Vec3f>& normals,
                                    const std::vector<std::uint32_t>& reference,
                                    const std::vector<std::uint32_t>& queries) {
  const auto nearest = pcl_adapter::nearestInReference(gather(points, reference), gather(points, queries));
  std::vector<char> agrees(queries.size());
  for (std::size_t q = 0; q < queries.size(); ++q)
    agrees[q] = normals[queries[q]].dot(normals[reference[static_cast<std::size_t>(nearest[q])]]) >= 0.0f;
  return agrees;
}

struct IslandOrientation {
  std::size_t islands = 0;     // MST passes that oriented something
  std::size_t leftovers = 0;   // points oriented by their nearest neighbour alone
};

// CGAL's MST orients only the k-NN graph component that holds the highest
// point, turning that point's normal up. A scan in separate pieces (several
// objects, debris) is therefore oriented island by island with the same rule,
// which is right for closed objects: each one's highest normal points up and
// out. After kMaxIslandPasses, each leftover point agrees with its nearest
// oriented point.
constexpr int kMaxIslandPasses = 8;
IslandOrientation orientByIslands(const std::vector<Vec3f>& points, std::vector<Vec3f>& normals, int k) {
  IslandOrientation result;
  std::vector<std::uint32_t> oriented;
  std::vector<std::uint32_t> remaining(points.size());
  std::iota(remaining.begin(), remaining.end(), 0u);
  for (int pass = 0; pass < kMaxIslandPasses && remaining.size() > static_cast<std::size_t>(k); ++pass) {
    std::vector<Vec3f> islandNormals = gather(normals, remaining);
    const auto leftInSubset = cgal_adapter::orientNormalsMst(gather(points, remaining), islandNormals, k);
    std::vector<char> left(remaining.size(), 0);
    for (std::uint32_t i : leftInSubset) left[i] = 1;

    std::vector<std::uint32_t> island, stillRemaining;
    for (std::size_t i = 0; i < remaining.size(); ++i) {
      normals[remaining[i]] = islandNormals[i];
      (left[i] ? stillRemaining : island).push_back(remaining[i]);
    }
    oriented.insert(oriented.end(), island.begin(), island.end());
    remaining = std::move(stillRemaining);
    ++result.islands;
  }
  if (!remaining.empty() && !oriented.empty()) {
    const auto agrees = agreesWithNearest(points, normals, oriented, remaining);
    for (std::size_t q = 0; q < remaining.size(); ++q)
      if (!agrees[q]) normals[remaining[q]] = -normals[remaining[q]];
  }
  result.leftovers = remaining.size();
  return result;
}

}  // namespace

int chooseNeighbourCount(const std::vector<Vec3f>& points) {
  const int largest = kCandidateNeighbourCounts[std::size(kCandidateNeighbourCounts) - 1];
  const int available = static_cast<int>(std::min<std::size_t>(points.size(), largest));
  if (available <= kCandidateNeighbourCounts[0]) return std::max(3, available);

  const auto samples = evenSubsample(points.size(), kSubsampleSize);
  const auto neighbourhoods = pcl_adapter::nearestNeighbours(points, samples, available);

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

OrientedNormals estimateOrientedNormals(const std::vector<Vec3f>& points,
                                        const std::optional<Viewpoint>& viewpoint, int k) {
  OrientedNormals result;
  result.neighbours = k > 0 ? k : chooseNeighbourCount(points);
  // PCL turns every normal towards the viewpoint it is given.
  result.normals = pcl_adapter::estimateNormals(points, result.neighbours, viewpoint ? viewpoint->origin : Vec3f::Zero());
  if (viewpoint) {
    result.orientation = "viewpoint";
    return result;
  }
  result.orientation = "mst";
  // MST needs every normal defined; undefined ones are dropped by the caller.
  std::vector<Vec3f> defined = result.normals;
  for (Vec3f& n : defined)
    if (!n.allFinite()) n = Vec3f::UnitZ();
  const IslandOrientation islands = orientByIslands(points, defined, std::max(result.neighbours, 12));
  for (std::size_t i = 0; i < points.size(); ++i)
    if (result.normals[i].allFinite()) result.normals[i] = defined[i];
  result.islands = islands.islands;
  result.unoriented = islands.leftovers;
  return result;
}

}  // namespace apo::normals
