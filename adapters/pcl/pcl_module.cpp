// The PCL module (apo-pcl.so): outlier removal and k-nearest searches by
// PCL, behind the C interface of pcl_module.h. Every exception is caught
// here and returned as a message.
#include "adapters/pcl/pcl_module.h"

#include <pcl/filters/statistical_outlier_removal.h>
#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>

#include <algorithm>
#include <cstring>
#include <exception>
#include <memory>
#include <vector>

namespace {

pcl::PointCloud<pcl::PointXYZ>::Ptr toPcl(const float* xyz, std::size_t count) {
  auto cloud = std::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  cloud->resize(count);
  for (std::size_t i = 0; i < count; ++i) (*cloud)[i] = pcl::PointXYZ(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]);
  return cloud;
}

void copyMessage(const char* message, char* error, std::size_t errorBytes) {
  if (errorBytes == 0) return;
  const std::size_t length = std::min(std::strlen(message), errorBytes - 1);
  std::memcpy(error, message, length);
  error[length] = '\0';
}

// 0 when `body` returns, 1 with its exception's message otherwise.
template <class Body>
int caught(Body&& body, char* error, std::size_t errorBytes) {
  try {
    body();
    return 0;
  } catch (const std::exception& e) {
    copyMessage(e.what(), error, errorBytes);
  } catch (...) {
    copyMessage("an exception that is not a std::exception", error, errorBytes);
  }
  return 1;
}

int statisticalOutlierKeepMask(const float* xyz, std::size_t count, int k, double stdDevs, char* keep, char* error,
                               std::size_t errorBytes) {
  return caught(
      [&] {
        pcl::StatisticalOutlierRemoval<pcl::PointXYZ> filter;
        filter.setInputCloud(toPcl(xyz, count));
        filter.setMeanK(k);
        filter.setStddevMulThresh(stdDevs);
        pcl::Indices kept;
        filter.filter(kept);
        std::fill(keep, keep + count, 0);
        for (const int i : kept) keep[static_cast<std::size_t>(i)] = 1;
      },
      error, errorBytes);
}

int nearestNeighbours(const float* xyz, std::size_t count, const std::uint32_t* queries, std::size_t queryCount, int k,
                      int* neighbours, char* error, std::size_t errorBytes) {
  return caught(
      [&] {
        pcl::KdTreeFLANN<pcl::PointXYZ> tree;
        const auto cloud = toPcl(xyz, count);
        tree.setInputCloud(cloud);
        pcl::Indices indices;
        std::vector<float> squaredDistances;
        const auto width = static_cast<std::size_t>(k);
        for (std::size_t q = 0; q < queryCount; ++q) {
          tree.nearestKSearch((*cloud)[queries[q]], k, indices, squaredDistances);
          int* row = neighbours + q * width;
          std::fill(row, row + width, -1);
          std::copy_n(indices.begin(), std::min(indices.size(), width), row);
        }
      },
      error, errorBytes);
}

int nearestInReference(const float* reference, std::size_t referenceCount, const float* queries, std::size_t queryCount,
                       int* nearest, char* error, std::size_t errorBytes) {
  return caught(
      [&] {
        pcl::KdTreeFLANN<pcl::PointXYZ> tree;
        tree.setInputCloud(toPcl(reference, referenceCount));
        pcl::Indices indices;
        std::vector<float> squaredDistances;
        for (std::size_t q = 0; q < queryCount; ++q) {
          const float* p = queries + 3 * q;
          tree.nearestKSearch(pcl::PointXYZ(p[0], p[1], p[2]), 1, indices, squaredDistances);
          nearest[q] = indices.at(0);
        }
      },
      error, errorBytes);
}

constexpr ApoPclModule kModule{apo::pcl_adapter::kApoPclModuleVersion, statisticalOutlierKeepMask, nearestNeighbours,
                               nearestInReference};

}  // namespace

extern "C" __attribute__((visibility("default"))) const ApoPclModule* apoPclModule() { return &kModule; }
