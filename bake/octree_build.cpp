// The adaptive octree of paper section 3.1. The levels down to the coarse
// depth are found by binning m's triangles into the coarse grid at once; each
// coarse cell is then refined on its own (in parallel) by the L2,1 criterion,
// moving m's and M's primitives down into the children they overlap.
#include "bake/octree_build.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <utility>

namespace apo::octree {
namespace {

// ---- Geometry -------------------------------------------------------------

// Projections of the three corners on `axis` against the box's radius on it.
bool separatedOn(const Vec3f& axis, const Vec3f& v0, const Vec3f& v1, const Vec3f& v2, const Vec3f& half) {
  const float p0 = axis.dot(v0), p1 = axis.dot(v1), p2 = axis.dot(v2);
  const float radius = half.dot(axis.cwiseAbs());
  return std::min({p0, p1, p2}) > radius || std::max({p0, p1, p2}) < -radius;
}

// Keeps the part of `polygon` where sign * (p[axis] - bound) <= 0.
std::vector<Vec3f> clipAgainstPlane(const std::vector<Vec3f>& polygon, int axis, float bound, float sign) {
  std::vector<Vec3f> clipped;
  const std::size_t n = polygon.size();
  for (std::size_t i = 0; i < n; ++i) {
    const Vec3f& p = polygon[i];
    const Vec3f& q = polygon[(i + 1) % n];
    const float dp = sign * (p[axis] - bound), dq = sign * (q[axis] - bound);
    if (dp <= 0.0f) clipped.push_back(p);
    if ((dp < 0.0f && dq > 0.0f) || (dp > 0.0f && dq < 0.0f)) {
      Vec3f crossing = p + (q - p) * (dp / (dp - dq));
      crossing[axis] = bound;  // exactly on the face, whatever the rounding
      clipped.push_back(crossing);
    }
  }
  return clipped;
}

// ---- Primitive access -----------------------------------------------------

struct Bounds {
  Vec3f lo, hi;
};

Bounds triangleBounds(const Vec3f& a, const Vec3f& b, const Vec3f& c) {
  return {a.cwiseMin(b).cwiseMin(c), a.cwiseMax(b).cwiseMax(c)};
}

Bounds coarseBounds(const CoarseMesh& m, std::uint32_t t) {
  const Triangle& tri = m.triangles[t];
  return triangleBounds(m.positions[tri[0]], m.positions[tri[1]], m.positions[tri[2]]);
}

bool coarseOverlaps(const CoarseMesh& m, std::uint32_t t, const Cell& cell) {
  const Triangle& tri = m.triangles[t];
  return triangleOverlapsBox(m.positions[tri[0]], m.positions[tri[1]], m.positions[tri[2]], cell);
}

Bounds detailBounds(const DetailPrimitives& d, std::uint32_t i) {
  if (d.triangles.empty()) return {d.positions[i], d.positions[i]};
  const auto c = d.corners(i);
  return triangleBounds(c[0], c[1], c[2]);
}

bool detailOverlaps(const DetailPrimitives& d, std::uint32_t i, const Cell& cell) {
  if (d.triangles.empty())
    return (d.positions[i].array() >= cell.lower().array()).all() && (d.positions[i].array() <= cell.upper().array()).all();
  const auto c = d.corners(i);
  return triangleOverlapsBox(c[0], c[1], c[2], cell);
}

bool boundsInsideCell(const Bounds& b, const Cell& cell) {
  return (b.lo.array() >= cell.lower().array()).all() && (b.hi.array() <= cell.upper().array()).all();
}

// Running sums for the L2,1 integral: over pieces of area a with mean normal
// mu and internal variance v, sum a |mu - n|^2 + a v expands into these.
struct VariationSums {
  double area = 0.0, areaMeanSquared = 0.0, areaVariance = 0.0;
  Eigen::Vector3d areaMean = Eigen::Vector3d::Zero();

  void add(double a, const Eigen::Vector3d& mean, double variance) {
    area += a;
    areaMean += a * mean;
    areaMeanSquared += a * mean.squaredNorm();
    areaVariance += a * variance;
  }

  // A linearly interpolated field over a triangle: its mean is the corners'
  // mean and its variance a twelfth of the corners' squared deviations.
  void addTriangle(double a, const Vec3f& n0, const Vec3f& n1, const Vec3f& n2) {
    const Eigen::Vector3d m0 = n0.cast<double>(), m1 = n1.cast<double>(), m2 = n2.cast<double>();
    const Eigen::Vector3d mean = (m0 + m1 + m2) / 3.0;
    add(a, mean, ((m0 - mean).squaredNorm() + (m1 - mean).squaredNorm() + (m2 - mean).squaredNorm()) / 12.0);
  }

  double l21() const {
    const double norm = areaMean.norm();
    const double alongMean = norm > 0.0 ? norm : 0.0;  // n . sum(a mu) with n the unit mean
    const double unitArea = norm > 0.0 ? area : 0.0;   // |n|^2 sum(a)
    return std::max(0.0, areaMeanSquared - 2.0 * alongMean + unitArea + areaVariance);
  }
};

double triangleArea(const Vec3f& a, const Vec3f& b, const Vec3f& c) {
  return 0.5 * (b - a).cast<double>().cross((c - a).cast<double>()).norm();
}

// The part of triangle t of M inside the cell, added piece by piece with its
// interpolated normals.
void addTriangleInCell(const DetailPrimitives& d, std::uint32_t t, const Cell& cell, VariationSums& sums) {
  const auto c = d.corners(t);
  const Triangle& tri = d.triangles[t];
  const Vec3f &n0 = d.cornerNormals[tri[0]], &n1 = d.cornerNormals[tri[1]], &n2 = d.cornerNormals[tri[2]];
  if (boundsInsideCell(triangleBounds(c[0], c[1], c[2]), cell)) {
    sums.addTriangle(d.areaScale * triangleArea(c[0], c[1], c[2]), n0, n1, n2);
    return;
  }
  const std::vector<Vec3f> piece = clipTriangleToCell(c[0], c[1], c[2], cell);
  if (piece.size() < 3) return;
  std::vector<Vec3f> normals;
  for (const Vec3f& p : piece) {
    const Eigen::Vector3f w = barycentricsOf(p, c[0], c[1], c[2]);
    normals.push_back(w[0] * n0 + w[1] * n1 + w[2] * n2);
  }
  for (std::size_t k = 1; k + 1 < piece.size(); ++k)
    sums.addTriangle(d.areaScale * triangleArea(piece[0], piece[k], piece[k + 1]), normals[0], normals[k], normals[k + 1]);
}

// Children of `cell` whose closed box meets the bounds: on each axis the
// lower child (bit 1) when the bounds reach below the centre, the upper one
// (bit 0) when they reach above it.
template <class Visit>
void forChildrenTouching(const Cell& cell, const Bounds& bounds, Visit visit) {
  std::array<std::array<bool, 2>, 3> side{};  // side[axis][bit]
  for (int axis = 0; axis < 3; ++axis) {
    side[axis][1] = bounds.lo[axis] <= cell.centre[axis];
    side[axis][0] = bounds.hi[axis] >= cell.centre[axis];
  }
  for (int c = 0; c < 8; ++c)
    if (side[0][(c >> 2) & 1] && side[1][(c >> 1) & 1] && side[2][c & 1]) visit(c);
}

// Whether the bounds fit in one closed child on every axis (then that child
// surely overlaps the primitive and no separating-axis test is needed).
bool insideOneChild(const Cell& cell, const Bounds& bounds) {
  for (int axis = 0; axis < 3; ++axis)
    if (bounds.lo[axis] < cell.centre[axis] && bounds.hi[axis] > cell.centre[axis]) return false;
  return true;
}

// Splits a primitive list among the eight children of `cell`.
template <class BoundsOf, class Overlaps>
std::array<std::vector<std::uint32_t>, 8> distribute(const std::vector<std::uint32_t>& primitives, const Cell& cell,
                                                     BoundsOf boundsOf, Overlaps overlaps, std::uint8_t onlyMask) {
  std::array<std::vector<std::uint32_t>, 8> children;
  for (const std::uint32_t p : primitives) {
    const Bounds bounds = boundsOf(p);
    const bool sure = insideOneChild(cell, bounds);
    forChildrenTouching(cell, bounds, [&](int c) {
      if (!(onlyMask & (1u << c))) return;
      if (sure || overlaps(p, cell.child(c))) children[c].push_back(p);
    });
  }
  return children;
}

// ---- The coarse grid ------------------------------------------------------

// Grid coordinates at depth d of the cells whose closed boxes can meet
// [lo, hi] (a value on a cell boundary belongs to both cells).
struct GridRange {
  std::array<int, 3> first, last;
};

GridRange gridRange(const Bounds& b, int cellsPerAxis) {
  GridRange range{};
  const float n = static_cast<float>(cellsPerAxis);
  for (int axis = 0; axis < 3; ++axis) {
    range.first[axis] = std::clamp(static_cast<int>(std::ceil(b.lo[axis] * n)) - 1, 0, cellsPerAxis - 1);
    range.last[axis] = std::clamp(static_cast<int>(std::floor(b.hi[axis] * n)), 0, cellsPerAxis - 1);
  }
  return range;
}

using GridKey = std::uint64_t;

GridKey gridKey(int x, int y, int z, int depth) {
  return (static_cast<GridKey>(x) << (2 * depth)) | (static_cast<GridKey>(y) << depth) | static_cast<GridKey>(z);
}

std::array<int, 3> gridCoordinates(GridKey key, int depth) {
  const GridKey mask = (GridKey{1} << depth) - 1;
  return {static_cast<int>(key >> (2 * depth)), static_cast<int>((key >> depth) & mask), static_cast<int>(key & mask)};
}

Cell gridCell(GridKey key, int depth) {
  const auto xyz = gridCoordinates(key, depth);
  const float width = std::ldexp(1.0f, -depth);
  return {Vec3f((xyz[0] + 0.5f) * width, (xyz[1] + 0.5f) * width, (xyz[2] + 0.5f) * width), width, depth};
}

bool insideUnitCube(const Bounds& b) {
  return (b.lo.array() >= 0.0f).all() && (b.hi.array() <= 1.0f).all();
}

// (cell key, primitive) for every coarse cell a primitive overlaps among the
// cells `wanted` accepts, sorted: grouped by cell, primitives in increasing
// order within a cell.
template <class BoundsOf, class Overlaps, class Wanted>
std::vector<std::pair<GridKey, std::uint32_t>> binIntoGrid(std::size_t count, int depth, BoundsOf boundsOf,
                                                           Overlaps overlaps, Wanted wanted) {
  const int n = 1 << depth;
  std::vector<std::vector<std::pair<GridKey, std::uint32_t>>> perChunk((count + 4095) / 4096);
  tbb::parallel_for(std::size_t{0}, perChunk.size(), [&](std::size_t chunk) {
    auto& pairs = perChunk[chunk];
    for (std::size_t i = chunk * 4096; i < std::min(count, (chunk + 1) * 4096); ++i) {
      const auto p = static_cast<std::uint32_t>(i);
      const Bounds bounds = boundsOf(p);
      const GridRange r = gridRange(bounds, n);
      // Bounds inside one closed cell: the primitive surely overlaps it.
      const bool single = r.first == r.last && insideUnitCube(bounds);
      for (int x = r.first[0]; x <= r.last[0]; ++x)
        for (int y = r.first[1]; y <= r.last[1]; ++y)
          for (int z = r.first[2]; z <= r.last[2]; ++z) {
            const GridKey key = gridKey(x, y, z, depth);
            if (wanted(key) && (single || overlaps(p, gridCell(key, depth)))) pairs.emplace_back(key, p);
          }
    }
  });
  std::vector<std::pair<GridKey, std::uint32_t>> all;
  for (auto& pairs : perChunk) all.insert(all.end(), pairs.begin(), pairs.end());
  std::sort(all.begin(), all.end());
  return all;
}

// ---- Refinement below the coarse depth ------------------------------------

// One coarse cell's subtree: nodes[0] is the coarse cell itself.
struct Subtree {
  std::vector<OctreeNode> nodes;
  std::vector<std::pair<std::uint64_t, std::uint32_t>> triangleRange;  // per node: begin, count in `triangles`
  std::vector<std::uint32_t> triangles;
};

class SubtreeBuilder {
 public:
  SubtreeBuilder(const CoarseMesh& coarse, const DetailPrimitives& detail, const BuildSettings& settings)
      : coarse_(coarse), detail_(detail), settings_(settings) {}

  Subtree build(const Cell& cell, std::vector<std::uint32_t> triangles, std::vector<std::uint32_t> primitives) const {
    Subtree tree;
    tree.nodes.emplace_back();
    tree.nodes[0].depth = static_cast<std::uint8_t>(cell.depth);
    tree.triangleRange.emplace_back(0, 0);
    refine(tree, 0, cell, std::move(triangles), std::move(primitives));
    return tree;
  }

 private:
  void refine(Subtree& tree, std::uint32_t node, const Cell& cell, std::vector<std::uint32_t> triangles,
              std::vector<std::uint32_t> primitives) const {
    const bool split = cell.depth < settings_.maxDepth &&
                       (cell.depth < settings_.coarseDepth || normalVariation(detail_, primitives, cell) > settings_.error);
    std::array<std::vector<std::uint32_t>, 8> childTriangles;
    std::uint8_t mask = 0;
    if (split) {
      childTriangles = distribute(
          triangles, cell, [&](std::uint32_t t) { return coarseBounds(coarse_, t); },
          [&](std::uint32_t t, const Cell& child) { return coarseOverlaps(coarse_, t, child); }, 0xFF);
      for (int c = 0; c < 8; ++c)
        if (!childTriangles[c].empty()) mask |= static_cast<std::uint8_t>(1u << c);
    }
    if (mask == 0) {  // a leaf: keep m's triangles for the sampling
      tree.triangleRange[node] = {tree.triangles.size(), static_cast<std::uint32_t>(triangles.size())};
      tree.triangles.insert(tree.triangles.end(), triangles.begin(), triangles.end());
      return;
    }
    auto childPrimitives = distribute(
        primitives, cell, [&](std::uint32_t i) { return detailBounds(detail_, i); },
        [&](std::uint32_t i, const Cell& child) { return detailOverlaps(detail_, i, child); }, mask);
    // M's primitives that meet no kept child are not needed below: the rays
    // are cast against all of M, not against the cells' lists.
    std::vector<std::uint32_t>().swap(triangles);
    std::vector<std::uint32_t>().swap(primitives);
    const auto first = static_cast<std::uint32_t>(tree.nodes.size());
    tree.nodes[node].firstChild = first;
    tree.nodes[node].childMask = mask;
    for (int c = 0; c < 8; ++c) {
      if (!(mask & (1u << c))) continue;
      OctreeNode child;
      child.depth = static_cast<std::uint8_t>(cell.depth + 1);
      tree.nodes.push_back(child);
      tree.triangleRange.emplace_back(0, 0);
    }
    std::uint32_t next = first;
    for (int c = 0; c < 8; ++c) {
      if (!(mask & (1u << c))) continue;
      refine(tree, next++, cell.child(c), std::move(childTriangles[c]), std::move(childPrimitives[c]));
    }
  }

  const CoarseMesh& coarse_;
  const DetailPrimitives& detail_;
  const BuildSettings& settings_;
};

// ---- Assembly -------------------------------------------------------------

// The complete levels down to the coarse depth, breadth first, over the
// occupied coarse cells (sorted keys). Returns the node index of each.
std::vector<std::uint32_t> buildUpperLevels(const std::vector<GridKey>& occupied, int coarseDepth,
                                            std::vector<OctreeNode>& nodes) {
  // levels[d]: sorted keys of the occupied cells at depth d.
  std::vector<std::vector<GridKey>> levels(coarseDepth + 1);
  levels[coarseDepth] = occupied;
  for (int d = coarseDepth - 1; d >= 0; --d) {
    for (const GridKey key : levels[d + 1]) {
      const auto xyz = gridCoordinates(key, d + 1);
      levels[d].push_back(gridKey(xyz[0] >> 1, xyz[1] >> 1, xyz[2] >> 1, d));
    }
    std::sort(levels[d].begin(), levels[d].end());
    levels[d].erase(std::unique(levels[d].begin(), levels[d].end()), levels[d].end());
  }
  std::vector<std::uint32_t> coarseNodes(occupied.size());
  std::vector<std::pair<GridKey, int>> queue = {{0, 0}};  // (key, depth), breadth first
  nodes.assign(1, OctreeNode{});
  for (std::size_t q = 0; q < queue.size(); ++q) {
    const auto [key, depth] = queue[q];
    const auto node = static_cast<std::uint32_t>(q);
    if (depth == coarseDepth) {
      coarseNodes[static_cast<std::size_t>(std::lower_bound(occupied.begin(), occupied.end(), key) - occupied.begin())] = node;
      continue;
    }
    const auto xyz = gridCoordinates(key, depth);
    nodes[node].firstChild = static_cast<std::uint32_t>(nodes.size());
    for (int c = 0; c < 8; ++c) {
      // Child bit 1 is the lower half: grid coordinate 2x; bit 0: 2x + 1.
      const GridKey child = gridKey(2 * xyz[0] + ((c & 4) ? 0 : 1), 2 * xyz[1] + ((c & 2) ? 0 : 1),
                                    2 * xyz[2] + ((c & 1) ? 0 : 1), depth + 1);
      if (!std::binary_search(levels[depth + 1].begin(), levels[depth + 1].end(), child)) continue;
      nodes[node].childMask |= static_cast<std::uint8_t>(1u << c);
      OctreeNode childNode;
      childNode.depth = static_cast<std::uint8_t>(depth + 1);
      nodes.push_back(childNode);
      queue.emplace_back(child, depth + 1);
    }
  }
  return coarseNodes;
}

// Appends a subtree below its root's node in the global octree.
void appendSubtree(const Subtree& tree, std::uint32_t root, BuiltOctree& built,
                   std::vector<std::pair<std::uint64_t, std::uint32_t>>& ranges) {
  auto& nodes = built.octree.nodes;
  const auto base = static_cast<std::uint32_t>(nodes.size());
  const auto global = [&](std::uint32_t local) { return local == 0 ? root : base + local - 1; };
  const auto shift = [&](std::uint32_t local) {
    std::pair<std::uint64_t, std::uint32_t> r = tree.triangleRange[local];
    r.first += built.leafTriangles.size();
    return r;
  };
  OctreeNode top = tree.nodes[0];
  if (!top.isLeaf()) top.firstChild = global(top.firstChild);
  nodes[root] = top;
  ranges[root] = shift(0);
  for (std::uint32_t local = 1; local < tree.nodes.size(); ++local) {
    OctreeNode node = tree.nodes[local];
    if (!node.isLeaf()) node.firstChild = global(node.firstChild);
    nodes.push_back(node);
    ranges.push_back(shift(local));
  }
  built.leafTriangles.insert(built.leafTriangles.end(), tree.triangles.begin(), tree.triangles.end());
}

// Groups sorted (key, primitive) pairs by key.
struct Groups {
  std::vector<GridKey> keys;
  std::vector<std::vector<std::uint32_t>> members;
};

Groups groupByKey(const std::vector<std::pair<GridKey, std::uint32_t>>& pairs) {
  Groups groups;
  for (const auto& [key, member] : pairs) {
    if (groups.keys.empty() || groups.keys.back() != key) {
      groups.keys.push_back(key);
      groups.members.emplace_back();
    }
    groups.members.back().push_back(member);
  }
  return groups;
}

}  // namespace

bool triangleOverlapsBox(const Vec3f& a, const Vec3f& b, const Vec3f& c, const Cell& cell) {
  const Vec3f half = Vec3f::Constant(0.5f * cell.width);
  const Vec3f v0 = a - cell.centre, v1 = b - cell.centre, v2 = c - cell.centre;
  for (int axis = 0; axis < 3; ++axis)
    if (std::min({v0[axis], v1[axis], v2[axis]}) > half[axis] || std::max({v0[axis], v1[axis], v2[axis]}) < -half[axis])
      return false;
  const std::array<Vec3f, 3> edges = {v1 - v0, v2 - v1, v0 - v2};
  if (separatedOn(edges[0].cross(edges[1]), v0, v1, v2, half)) return false;
  for (const Vec3f& edge : edges)
    for (int axis = 0; axis < 3; ++axis)
      if (separatedOn(Vec3f::Unit(axis).cross(edge), v0, v1, v2, half)) return false;
  return true;
}

std::vector<Vec3f> clipTriangleToCell(const Vec3f& a, const Vec3f& b, const Vec3f& c, const Cell& cell) {
  std::vector<Vec3f> polygon = {a, b, c};
  const Vec3f lower = cell.lower(), upper = cell.upper();
  for (int axis = 0; axis < 3 && !polygon.empty(); ++axis) {
    polygon = clipAgainstPlane(polygon, axis, upper[axis], 1.0f);
    if (!polygon.empty()) polygon = clipAgainstPlane(polygon, axis, lower[axis], -1.0f);
  }
  return polygon;
}

double polygonArea(const std::vector<Vec3f>& polygon) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (std::size_t i = 1; i + 1 < polygon.size(); ++i)
    sum += (polygon[i] - polygon[0]).cast<double>().cross((polygon[i + 1] - polygon[0]).cast<double>());
  return 0.5 * sum.norm();
}

Eigen::Vector3f barycentricsOf(const Vec3f& p, const Vec3f& a, const Vec3f& b, const Vec3f& c) {
  const Vec3f v0 = b - a, v1 = c - a, v2 = p - a;
  const double d00 = v0.dot(v0), d01 = v0.dot(v1), d11 = v1.dot(v1), d20 = v2.dot(v0), d21 = v2.dot(v1);
  const double denominator = d00 * d11 - d01 * d01;
  if (!(denominator > 0.0)) return {1.0f, 0.0f, 0.0f};
  const double v = (d11 * d20 - d01 * d21) / denominator, w = (d00 * d21 - d01 * d20) / denominator;
  Eigen::Vector3f weights(static_cast<float>(1.0 - v - w), static_cast<float>(v), static_cast<float>(w));
  weights = weights.cwiseMax(0.0f);  // the point is on the triangle up to rounding
  return weights / weights.sum();
}

double normalVariation(const DetailPrimitives& detail, const std::vector<std::uint32_t>& primitives, const Cell& cell) {
  VariationSums sums;
  for (const std::uint32_t i : primitives) {
    if (detail.triangles.empty())
      sums.add(detail.weights[i], detail.normals[i].cast<double>(), 0.0);
    else
      addTriangleInCell(detail, i, cell, sums);
  }
  return sums.l21();
}

BuiltOctree buildOctree(const CoarseMesh& coarse, const DetailPrimitives& detail, const BuildSettings& settings) {
  const int depth = settings.coarseDepth;
  const Groups coarseCells = groupByKey(binIntoGrid(
      coarse.triangles.size(), depth, [&](std::uint32_t t) { return coarseBounds(coarse, t); },
      [&](std::uint32_t t, const Cell& cell) { return coarseOverlaps(coarse, t, cell); }, [](GridKey) { return true; }));
  const auto occupied = [&](GridKey key) {
    return std::binary_search(coarseCells.keys.begin(), coarseCells.keys.end(), key);
  };
  // M's primitives in the occupied coarse cells only.
  const Groups detailCells = groupByKey(binIntoGrid(
      detail.size(), depth, [&](std::uint32_t i) { return detailBounds(detail, i); },
      [&](std::uint32_t i, const Cell& cell) { return detailOverlaps(detail, i, cell); }, occupied));

  BuiltOctree built;
  const std::vector<std::uint32_t> coarseNodes = buildUpperLevels(coarseCells.keys, depth, built.octree.nodes);
  std::vector<Subtree> subtrees(coarseCells.keys.size());
  const SubtreeBuilder builder(coarse, detail, settings);
  tbb::parallel_for(std::size_t{0}, subtrees.size(), [&](std::size_t i) {
    const GridKey key = coarseCells.keys[i];
    std::vector<std::uint32_t> primitives;
    const auto found = std::lower_bound(detailCells.keys.begin(), detailCells.keys.end(), key);
    if (found != detailCells.keys.end() && *found == key)
      primitives = detailCells.members[static_cast<std::size_t>(found - detailCells.keys.begin())];
    subtrees[i] = builder.build(gridCell(key, depth), coarseCells.members[i], std::move(primitives));
  });

  std::vector<std::pair<std::uint64_t, std::uint32_t>> ranges(built.octree.nodes.size(), {0, 0});
  for (std::size_t i = 0; i < subtrees.size(); ++i) {
    appendSubtree(subtrees[i], coarseNodes[i], built, ranges);
    subtrees[i] = Subtree{};  // free as we go
  }
  built.leafTriangleBegin.resize(built.octree.nodes.size() + 1);
  // Leaves' ranges are laid out in append order, which is not node order for
  // the coarse cells: rebuild a CSR in node order.
  std::vector<std::uint32_t> ordered;
  ordered.reserve(built.leafTriangles.size());
  for (std::size_t n = 0; n < built.octree.nodes.size(); ++n) {
    built.leafTriangleBegin[n] = ordered.size();
    const auto [begin, count] = ranges[n];
    ordered.insert(ordered.end(), built.leafTriangles.begin() + static_cast<std::ptrdiff_t>(begin),
                   built.leafTriangles.begin() + static_cast<std::ptrdiff_t>(begin + count));
  }
  built.leafTriangleBegin.back() = ordered.size();
  built.leafTriangles = std::move(ordered);
  return built;
}

}  // namespace apo::octree
