// PCL jobs over points: outlier removal, normal estimation, k-NN searches.
#include "adapters/pcl/pcl_points.h"

#include <pcl/filters/statistical_outlier_removal.h>
#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <cmath>
#include <limits>

namespace apo::pcl_adapter {
namespace {

pcl::PointCloud<pcl::PointXYZ>::Ptr toPcl(const std::vector<Vec3f>& points) {
  auto cloud = std::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  cloud->resize(points.size());
  for (std::size_t i = 0; i < points.size(); ++i) (*cloud)[i] = pcl::PointXYZ(points[i].x(), points[i].y(), points[i].z());
  return cloud;
}

}  // namespace

Result<std::vector<char>> statisticalOutlierKeepMask(const std::vector<Vec3f>& points, int k, double stdDevs) {
  return catchLibraryErrors("PCL outlier removal", [&] {
    pcl::StatisticalOutlierRemoval<pcl::PointXYZ> filter;
    filter.setInputCloud(toPcl(points));
    filter.setMeanK(k);
    filter.setStddevMulThresh(stdDevs);
    pcl::Indices kept;
    filter.filter(kept);
    std::vector<char> keep(points.size(), 0);
    for (int i : kept) keep[static_cast<std::size_t>(i)] = 1;
    return keep;
  });
}

Result<std::vector<std::vector<int>>> nearestNeighbours(const std::vector<Vec3f>& points,
                                                        const std::vector<std::uint32_t>& queries, int k) {
  return catchLibraryErrors("PCL k-nearest search", [&] {
    pcl::KdTreeFLANN<pcl::PointXYZ> tree;
    const auto cloud = toPcl(points);
    tree.setInputCloud(cloud);
    std::vector<std::vector<int>> neighbours(queries.size());
    pcl::Indices indices;
    std::vector<float> squaredDistances;
    for (std::size_t q = 0; q < queries.size(); ++q) {
      tree.nearestKSearch((*cloud)[queries[q]], k, indices, squaredDistances);
      neighbours[q].assign(indices.begin(), indices.end());
    }
    return neighbours;
  });
}

Result<std::vector<int>> nearestInReference(const std::vector<Vec3f>& reference, const std::vector<Vec3f>& queries) {
  return catchLibraryErrors("PCL nearest search", [&] {
    pcl::KdTreeFLANN<pcl::PointXYZ> tree;
    tree.setInputCloud(toPcl(reference));
    std::vector<int> nearest(queries.size());
    pcl::Indices indices;
    std::vector<float> squaredDistances;
    for (std::size_t q = 0; q < queries.size(); ++q) {
      tree.nearestKSearch(pcl::PointXYZ(queries[q].x(), queries[q].y(), queries[q].z()), 1, indices, squaredDistances);
      nearest[q] = indices.at(0);
    }
    return nearest;
  });
}

}  // namespace apo::pcl_adapter
