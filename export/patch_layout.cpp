// The packed per-triangle patches (paper section 4, in a simpler form): each
// triangle of m laid flat, unsheared, at one texel density for all, packed
// on shelves. The paper sizes each patch from the fine mesh's spacing under
// it and packs the triangles' own shapes; this packs their bounding boxes
// (docs/export.md says what that costs).
#include "export/export.h"

#include <algorithm>
#include <cmath>
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
  std::vector<Vec2f> origins;  // per triangle, the texel where its flat origin goes
  double usedShare = 0.0;
};

// Shelves, tallest patches first: each patch takes ceil(size * density) + 2
// gutters texels each way. Empty when they do not all fit.
std::optional<Placement> shelve(const std::vector<FlatTriangle>& flats, const std::vector<std::size_t>& order,
                                float density, int gutter, std::uint32_t width, std::uint32_t height) {
  Placement placement;
  placement.origins.assign(flats.size(), Vec2f::Zero());
  std::uint64_t x = 0, y = 0, shelfHeight = 0;
  double area = 0.0;
  for (std::size_t i : order) {
    const auto w = static_cast<std::uint64_t>(std::ceil(flats[i].width * density)) + 2 * static_cast<std::uint64_t>(gutter);
    const auto h = static_cast<std::uint64_t>(std::ceil(flats[i].height * density)) + 2 * static_cast<std::uint64_t>(gutter);
    if (w > width) return std::nullopt;
    if (x + w > width) x = 0, y += shelfHeight, shelfHeight = 0;
    if (y + h > height) return std::nullopt;
    placement.origins[i] = Vec2f(static_cast<float>(x + static_cast<std::uint64_t>(gutter)),
                                 static_cast<float>(y + static_cast<std::uint64_t>(gutter)));
    shelfHeight = std::max(shelfHeight, h);
    x += w;
    area += 0.5 * static_cast<double>(flats[i].width) * flats[i].height * density * density;
  }
  placement.usedShare = area / (static_cast<double>(width) * height);
  return placement;
}

}  // namespace

Result<PatchAtlas> packTrianglePatches(const Scan& coarse, std::uint32_t width, std::uint32_t height, int gutter) {
  if (width < kMinSize || width > kMaxSize || height < kMinSize || height > kMaxSize)
    return usageError("the normal map must be between {} and {} texels per side (asked {} x {})", kMinSize, kMaxSize,
                      width, height);
  if (gutter < 1 || gutter > 8) return usageError("the gutter must be 1 to 8 texels (asked {})", gutter);
  const auto& p = coarse.points.positions;
  std::vector<FlatTriangle> flats;
  flats.reserve(coarse.triangles.size());
  double area = 0.0;
  for (const Triangle& t : coarse.triangles) {
    flats.push_back(flatten(p[t[0]], p[t[1]], p[t[2]]));
    area += 0.5 * static_cast<double>(flats.back().width) * flats.back().height;
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
  atlas.corners.reserve(flats.size());
  for (std::size_t i = 0; i < flats.size(); ++i) {
    std::array<Vec2f, 3> corners;
    for (int k = 0; k < 3; ++k) corners[static_cast<std::size_t>(k)] = best->origins[i] + flats[i].at[static_cast<std::size_t>(k)] * low;
    atlas.corners.push_back(corners);
  }
  return atlas;
}

}  // namespace apo
