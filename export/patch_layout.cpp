// The packed per-triangle patches (paper section 4, in a simpler form): each
// triangle of m laid flat, unsheared, at one texel density for all, packed
// on shelves. The paper sizes each patch from the fine mesh's spacing under
// it and packs the triangles' own shapes; this packs their bounding boxes
// (docs/export.md says what that costs).
#include "export/export.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

namespace apo {
namespace {

constexpr std::uint32_t kMinSize = 16, kMaxSize = 16384;

// A triangle in its own plane: the longest edge from the origin along +x,
// the third corner above it (y >= 0) and, the base angles being under 90
// degrees, with x within the base.
struct FlatTriangle {
  int first = 0;            // the corner at the origin; then first+1 on +x, first+2 above
  std::array<Vec2f, 3> at;  // per corner of the original order, in model units
  float width = 0.0f, height = 0.0f;
};

FlatTriangle flatten(const Vec3f& a, const Vec3f& b, const Vec3f& c) {
  const std::array<Vec3f, 3> p{a, b, c};
  FlatTriangle flat;
  float longest = -1.0f;
  for (int k = 0; k < 3; ++k) {
    const float length = (p[(k + 1) % 3] - p[k]).norm();
    if (length > longest) longest = length, flat.first = k;
  }
  const Vec3f& origin = p[flat.first];
  const Vec3f base = p[(flat.first + 1) % 3] - origin;
  const Vec3f third = p[(flat.first + 2) % 3] - origin;
  const Vec3f e1 = longest > 0.0f ? Vec3f(base / longest) : Vec3f::UnitX();
  // The third corner's offset from the base line, in the plane.
  const Vec3f across = third - e1 * third.dot(e1);
  const float height = across.norm();
  flat.at[flat.first] = Vec2f::Zero();
  flat.at[(flat.first + 1) % 3] = Vec2f(longest, 0.0f);
  flat.at[(flat.first + 2) % 3] = Vec2f(std::clamp(third.dot(e1), 0.0f, std::max(longest, 0.0f)), height);
  flat.width = std::max(longest, 0.0f);
  flat.height = height;
  return flat;
}

struct Placement {
  std::vector<std::array<Vec2f, 3>> corners;  // per triangle, in texels
  double usedShare = 0.0;
};

// The texel columns a triangle claims in one row: those whose centres may lie
// within `gutter` of it (the triangle within gutter of the row's centre line
// vertically, then gutter either way: a square round each point, which holds
// the disc the fill uses). Empty (first > last) where none.
std::pair<long, long> claimedColumns(const std::array<Vec2f, 3>& t, long row, float gutter) {
  const float centre = static_cast<float>(row) + 0.5f, low = centre - gutter, high = centre + gutter;
  float xmin = std::numeric_limits<float>::max(), xmax = std::numeric_limits<float>::lowest();
  for (int k = 0; k < 3; ++k) {
    const Vec2f& a = t[static_cast<std::size_t>(k)];
    const Vec2f& b = t[static_cast<std::size_t>((k + 1) % 3)];
    // The part of edge ab within the band [low, high].
    const float ya = a.y(), yb = b.y();
    if (std::max(ya, yb) < low || std::min(ya, yb) > high) continue;
    const auto xAt = [&](float y) { return ya == yb ? a.x() : a.x() + (b.x() - a.x()) * (y - ya) / (yb - ya); };
    const float from = std::clamp(std::min(ya, yb), low, high), to = std::clamp(std::max(ya, yb), low, high);
    for (const float y : {from, to}) {
      const float x = ya == yb ? std::min(a.x(), b.x()) : xAt(y);
      const float x2 = ya == yb ? std::max(a.x(), b.x()) : x;
      xmin = std::min(xmin, x);
      xmax = std::max(xmax, x2);
    }
  }
  if (xmin > xmax) return {1, 0};
  return {static_cast<long>(std::ceil(xmin - gutter - 0.5f)), static_cast<long>(std::floor(xmax + gutter - 0.5f))};
}

// The triangle in a shelf of `rows` rows from row `top`: its longest edge
// along the shelf's top, apex below ("down"), or turned half a turn, edge
// along the shelf's bottom ("up"); x from 0. A rotation, never a mirror.
std::array<Vec2f, 3> inShelf(const FlatTriangle& flat, float density, bool up, float top, float rows, float gutter) {
  std::array<Vec2f, 3> corners{Vec2f::Zero(), Vec2f::Zero(), Vec2f::Zero()};
  const float w = flat.width * density;
  for (std::size_t k = 0; k < 3; ++k) {
    const Vec2f local = flat.at[k] * density;
    corners[k] = up ? Vec2f(w - local.x(), top + rows - gutter - 0.5f - local.y())
                    : Vec2f(local.x(), top + gutter + 0.5f + local.y());
  }
  return corners;
}

// Shelves, tallest patches first; within a shelf each patch slides left
// until its claimed texels meet the shelf's, turned edge-down or edge-up,
// whichever ends further left, so that neighbours interlock (paper section 4
// packs shapes, not boxes). Empty when they do not all fit.
std::optional<Placement> shelve(const std::vector<FlatTriangle>& flats, const std::vector<std::size_t>& order,
                                float density, int gutter, std::uint32_t width, std::uint32_t height) {
  Placement placement;
  placement.corners.assign(flats.size(), {Vec2f::Zero(), Vec2f::Zero(), Vec2f::Zero()});
  const auto g = static_cast<float>(gutter);
  long top = 0, rows = 0;
  std::vector<long> frontier;  // per row of the shelf: the rightmost claimed column
  double area = 0.0;
  const auto openShelf = [&](const FlatTriangle& first) {
    top += rows;
    rows = static_cast<long>(std::ceil(first.height * density + 2.0f * g + 1.0f));
    frontier.assign(static_cast<std::size_t>(rows), -1);
  };
  const auto claims = [&](const std::array<Vec2f, 3>& t) {
    std::vector<std::pair<long, long>> columns(static_cast<std::size_t>(rows));
    for (long r = 0; r < rows; ++r) columns[static_cast<std::size_t>(r)] = claimedColumns(t, top + r, g);
    return columns;
  };
  // The shift that puts the patch right of the shelf's frontier, and the
  // rightmost column it then claims.
  const auto slide = [&](const std::vector<std::pair<long, long>>& columns) {
    long shift = std::numeric_limits<long>::min(), right = std::numeric_limits<long>::min();
    for (std::size_t r = 0; r < columns.size(); ++r)
      if (columns[r].first <= columns[r].second) shift = std::max(shift, frontier[r] + 1 - columns[r].first);
    for (const auto& [first, last] : columns)
      if (first <= last) right = std::max(right, last + shift);
    return std::pair{shift, right};
  };
  for (std::size_t n = 0; n < order.size(); ++n) {
    const FlatTriangle& flat = flats[order[n]];
    if (n == 0) openShelf(flat);
    for (int attempt = 0; attempt < 2; ++attempt) {
      std::array<Vec2f, 3> best{Vec2f::Zero(), Vec2f::Zero(), Vec2f::Zero()};
      std::vector<std::pair<long, long>> bestColumns;
      long bestShift = 0, bestRight = std::numeric_limits<long>::max();
      for (const bool up : {false, true}) {
        const std::array<Vec2f, 3> t = inShelf(flat, density, up, static_cast<float>(top), static_cast<float>(rows), g);
        const auto columns = claims(t);
        const auto [shift, right] = slide(columns);
        if (right < bestRight) best = t, bestColumns = columns, bestShift = shift, bestRight = right;
      }
      if (bestRight < static_cast<long>(width)) {
        if (top + rows > static_cast<long>(height)) return std::nullopt;
        for (Vec2f& c : best) c.x() += static_cast<float>(bestShift);
        for (std::size_t r = 0; r < bestColumns.size(); ++r)
          if (bestColumns[r].first <= bestColumns[r].second)
            frontier[r] = std::max(frontier[r], bestColumns[r].second + bestShift);
        placement.corners[order[n]] = best;
        break;
      }
      if (attempt == 1) return std::nullopt;  // wider than the map alone
      openShelf(flat);
    }
    area += 0.5 * static_cast<double>(flat.width) * flat.height * density * density;
  }
  placement.usedShare = area / (static_cast<double>(width) * height);
  return placement;
}

}  // namespace

Result<PatchAtlas> packTrianglePatches(const Scan& coarse, std::uint32_t width, std::uint32_t height, int gutter,
                                       const std::vector<float>& scales) {
  if (width < kMinSize || width > kMaxSize || height < kMinSize || height > kMaxSize)
    return usageError("the normal map must be between {} and {} texels per side (asked {} x {})", kMinSize, kMaxSize,
                      width, height);
  if (gutter < 1 || gutter > 8) return usageError("the gutter must be 1 to 8 texels (asked {})", gutter);
  if (!scales.empty() && scales.size() != coarse.triangles.size())
    return internalError("{} patch scales for {} triangles", scales.size(), coarse.triangles.size());
  const auto& p = coarse.points.positions;
  std::vector<FlatTriangle> flats;
  flats.reserve(coarse.triangles.size());
  double area = 0.0;
  for (std::size_t f = 0; f < coarse.triangles.size(); ++f) {
    const Triangle& t = coarse.triangles[f];
    FlatTriangle flat = flatten(p[t[0]], p[t[1]], p[t[2]]);
    if (!scales.empty()) {
      for (Vec2f& corner : flat.at) corner *= scales[f];
      flat.width *= scales[f];
      flat.height *= scales[f];
    }
    flats.push_back(flat);
    area += 0.5 * static_cast<double>(flat.width) * flat.height;
  }
  if (!(area > 0.0)) return badInput("m has no triangle of positive area to give a patch of the normal map");

  std::vector<std::size_t> order(flats.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  // Tallest first, then widest, then m's order: the same layout every run.
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    if (flats[a].height != flats[b].height) return flats[a].height > flats[b].height;
    return flats[a].width > flats[b].width;
  });
  // The density never exceeds the one at which the triangles alone fill the map.
  float low = 0.0f, high = static_cast<float>(std::sqrt(static_cast<double>(width) * height / area));
  std::optional<Placement> best = shelve(flats, order, low, gutter, width, height);
  if (!best)
    return badInput("m's {} triangles do not fit a {} x {} normal map even as their gutters alone ({} texels each): give "
                    "a larger --map-size or a smaller --gutter",
                    flats.size(), width, height, 4 * gutter * gutter);
  for (int step = 0; step < 40; ++step) {
    const float middle = 0.5f * (low + high);
    if (std::optional<Placement> placed = shelve(flats, order, middle, gutter, width, height)) {
      low = middle;
      best = std::move(placed);
    } else {
      high = middle;
    }
  }
  PatchAtlas atlas;
  atlas.width = width;
  atlas.height = height;
  atlas.texelsPerUnit = low;
  atlas.gutter = gutter;
  atlas.usedShare = best->usedShare;
  atlas.corners = std::move(best->corners);
  atlas.scales = scales.empty() ? std::vector<float>(coarse.triangles.size(), 1.0f) : scales;
  return atlas;
}

std::vector<float> detailPatchScales(const Scan& coarse, const NormalField& field) {
  constexpr int kSteps = 4;  // lattice of points at barycentrics (i, j, k) / kSteps
  const auto& p = coarse.points.positions;
  const std::vector<Vec3f> vertexNormals = vertexNormalsAsDrawn(coarse);
  std::vector<float> turn(coarse.triangles.size(), 0.0f);
  for (std::size_t f = 0; f < coarse.triangles.size(); ++f) {
    const Triangle& t = coarse.triangles[f];
    // The field on the lattice, row by row (i + j <= kSteps).
    std::vector<Vec3f> points, normals;
    for (int i = 0; i <= kSteps; ++i)
      for (int j = 0; i + j <= kSteps; ++j) {
        const Vec3f w(static_cast<float>(kSteps - i - j), static_cast<float>(i), static_cast<float>(j));
        const Vec3f point = (w[0] * p[t[0]] + w[1] * p[t[1]] + w[2] * p[t[2]]) / kSteps;
        Vec3f coarseNormal = w[0] * vertexNormals[t[0]] + w[1] * vertexNormals[t[1]] + w[2] * vertexNormals[t[2]];
        coarseNormal = coarseNormal.squaredNorm() > 0.0f ? Vec3f(coarseNormal.normalized()) : Vec3f::UnitZ();
        const Vec3f n = field(point, coarseNormal);
        points.push_back(point);
        normals.push_back(n.squaredNorm() > 0.0f ? Vec3f(n.normalized()) : coarseNormal);
      }
    // Mean turn per unit length between lattice neighbours (+i and +j).
    const auto at = [](int i, int j) { return static_cast<std::size_t>(i * (2 * kSteps + 3 - i) / 2 + j); };
    double sum = 0.0;
    int pairs = 0;
    for (int i = 0; i <= kSteps; ++i)
      for (int j = 0; i + j <= kSteps; ++j)
        for (const auto& [di, dj] : {std::pair{1, 0}, std::pair{0, 1}}) {
          if (i + di + j + dj > kSteps) continue;
          const std::size_t a = at(i, j), b = at(i + di, j + dj);
          const float length = (points[a] - points[b]).norm();
          if (length <= 0.0f) continue;
          // atan2, not acos: acos of a float dot product loses small angles.
          sum += std::atan2(normals[a].cross(normals[b]).norm(), normals[a].dot(normals[b])) / length;
          ++pairs;
        }
    turn[f] = pairs > 0 ? static_cast<float>(sum / pairs) : 0.0f;
  }
  std::vector<float> sorted = turn;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>(sorted.size() / 2), sorted.end());
  const float median = sorted.empty() ? 0.0f : sorted[sorted.size() / 2];
  std::vector<float> scales(turn.size(), 1.0f);
  if (!(median > 0.0f)) return scales;  // no detail anywhere (or on most of m): one density
  for (std::size_t f = 0; f < turn.size(); ++f)
    scales[f] = std::clamp(std::cbrt(turn[f] / median), kMinPatchScale, kMaxPatchScale);
  return scales;
}

}  // namespace apo
