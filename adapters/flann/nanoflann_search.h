// Internal to the FLANN adapter: nanoflann's searches over points
// (nanoflann_search.cpp) behind flann_search.h's checked functions. They
// check nothing and may throw (the callers catch).
#pragma once

#include "adapters/flann/flann_search.h"

#include <memory>
#include <vector>

namespace apo::flann_adapter {

// discRadii's radii (at least one point).
std::vector<float> nanoflannDiscRadii(const std::vector<Vec3f>& positions);

// makeFlannPointsSearch's radii and nearest point, from one tree (at least
// one point, each with a normal).
PointsSearch nanoflannPointsSearch(const PointSet& points);

// The nearest point and its normal (at least one point, each with a normal).
std::unique_ptr<ClosestPointFinder> nanoflannNearestPoint(const PointSet& points);

}  // namespace apo::flann_adapter
