#include "ingest/normals.h"

#include "ingest/cgal_adapter.h"
#include "ingest/pcl_adapter.h"

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>

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

void turnAwayFromCentroid(const std::vector<Vec3f>& points, std::vector<Vec3f>& normals,
                          const std::vector<std::uint32_t>& affected) {
  if (affected.empty()) return;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  for (const Vec3f& p : points) centroid += p.cast<double>();
  centroid /= static_cast<double>(points.size());
  for (std::uint32_t i : affected)
    if (normals[i].dot((points[i].cast<double>() - centroid).cast<float>()) < 0) normals[i] = -normals[i];
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
  const int mstNeighbours = std::max(result.neighbours, 12);
  const auto unoriented = cgal_adapter::orientNormalsMst(points, defined, mstNeighbours);
  for (std::size_t i = 0; i < points.size(); ++i)
    if (result.normals[i].allFinite()) result.normals[i] = defined[i];
  // Islands the spanning tree cannot reach get the convex-object rule.
  result.unoriented = unoriented.size();
  turnAwayFromCentroid(points, result.normals, unoriented);
  return result;
}

}  // namespace apo::normals
