#include "reconstruct/cgal_adapters.h"

#include <flann/flann.hpp>

#include <cmath>
#include <limits>
#include <vector>

namespace apo::flann_adapter {
namespace {

// FLANN reads our points in place, as rows of three floats.
static_assert(sizeof(Vec3f) == 3 * sizeof(float), "Vec3f must be three packed floats");

flann::Matrix<float> pointRows(const std::vector<Vec3f>& points) {
  // FLANN takes a mutable matrix but only reads queries and, with `reorder`,
  // copies the reference points into its own storage.
  return {const_cast<float*>(points.front().data()), points.size(), 3};
}

struct Nearest {
  std::vector<std::size_t> indices;
  std::vector<float> squaredDistances;  // FLANN's L2 is the squared distance
};

// Exact 1-NN: one k-d tree searched to the end (KDTreeSingleIndex ignores
// `checks`, and eps = 0). Randomised trees were wrong 58% of the time on our
// data (../shared/STACK.md). cores = 0 lets OpenMP use every core; each query
// writes its own row, so the result does not depend on the thread count.
Nearest searchNearest(const std::vector<Vec3f>& reference, const std::vector<Vec3f>& queries) {
  Nearest nearest;
  nearest.indices.resize(queries.size());
  nearest.squaredDistances.resize(queries.size());
  flann::Index<flann::L2_Simple<float>> index(pointRows(reference), flann::KDTreeSingleIndexParams());
  index.buildIndex();
  flann::Matrix<std::size_t> indices(nearest.indices.data(), queries.size(), 1);
  flann::Matrix<float> distances(nearest.squaredDistances.data(), queries.size(), 1);
  flann::SearchParams params;
  params.eps = 0.0f;
  params.cores = 0;
  index.knnSearch(pointRows(queries), indices, distances, 1, params);
  return nearest;
}

}  // namespace

// With no reference point, every distance is +infinity.
std::vector<float> nearestDistances(const std::vector<Vec3f>& reference, const std::vector<Vec3f>& queries) {
  if (queries.empty()) return {};
  if (reference.empty()) return std::vector<float>(queries.size(), std::numeric_limits<float>::infinity());
  std::vector<float> distances = searchNearest(reference, queries).squaredDistances;
  for (float& d : distances) d = std::sqrt(d);
  return distances;
}

// With no reference point, every index is UINT32_MAX.
std::vector<std::uint32_t> nearestIndices(const std::vector<Vec3f>& reference, const std::vector<Vec3f>& queries) {
  if (queries.empty()) return {};
  if (reference.empty()) return std::vector<std::uint32_t>(queries.size(), std::numeric_limits<std::uint32_t>::max());
  const Nearest nearest = searchNearest(reference, queries);
  return std::vector<std::uint32_t>(nearest.indices.begin(), nearest.indices.end());
}

}  // namespace apo::flann_adapter
