// Every point of a large scan in a store on disk (docs/ingest.md, "Every
// point"): a counting sort into the cells of a grid (as out-of-core LOD
// builders such as PotreeConverter sort), in two passes over the file (count,
// then place), then the normals cell by cell over each cell and a band
// around it, so that they do not depend on how the file was read.
#include "ingest/ingest.h"

#include "adapters/flann/flann_search.h"
#include "core/file_io.h"
#include "ingest/large_scan.h"
#include "ingest/normals.h"

#include <fcntl.h>
#include <nlohmann/json.hpp>
#include <spdlog/spdlog.h>
#include <sys/stat.h>
#include <tbb/parallel_for.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <numeric>

namespace apo {
namespace {

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

constexpr int kStoreVersion = 1;
constexpr const char* kManifest = "store.json";
constexpr const char* kPositions = "positions.bin";  // float x y z per point, in the store's order
constexpr const char* kNormals = "normals.bin";      // float x y z per point
constexpr const char* kCells = "cells.bin";          // uint64 per cell: its first point; then the count
// About this many points to an occupied cell (a surface's grid of 2^d a
// side has about 6 4^d of them): its normals' neighbour search is one
// k-d tree over the cell and its band.
constexpr double kPointsPerCell = 4096.0;
constexpr int kShallowestGrid = 1, kDeepestGrid = 7;  // 2^21 cells: a 16 MB index
// A cell's normals see the points within this share of its side around it.
constexpr float kBandOfCell = 0.25f;

// The grid: a cube over the oriented points' box, 2^depth cells a side.
struct Grid {
  Aabb cube;
  int depth = 0;

  int side() const { return 1 << depth; }
  float cellWidth() const { return (cube.max.x() - cube.min.x()) / static_cast<float>(side()); }
  // The cell along an axis, clamped into the grid (infinities included).
  int along(float value, int axis) const {
    const float at = (value - cube.min[axis]) / cellWidth();
    if (!(at >= 0.0f)) return 0;
    if (at >= static_cast<float>(side())) return side() - 1;
    return static_cast<int>(at);
  }
  std::size_t cellOf(const Vec3f& p) const { return indexOf(along(p.x(), 0), along(p.y(), 1), along(p.z(), 2)); }
  std::size_t indexOf(int x, int y, int z) const {
    return (static_cast<std::size_t>(x) * static_cast<std::size_t>(side()) + static_cast<std::size_t>(y)) *
               static_cast<std::size_t>(side()) +
           static_cast<std::size_t>(z);
  }
  std::size_t cells() const { return static_cast<std::size_t>(side()) * side() * side(); }
  // The cell's box; sides on the grid's faces open to infinity (points
  // beyond the box are filed in the cells along its faces).
  Aabb boxOf(std::size_t cell) const {
    const std::size_t n = static_cast<std::size_t>(side());
    const int xyz[3] = {static_cast<int>(cell / (n * n)), static_cast<int>((cell / n) % n), static_cast<int>(cell % n)};
    const float far = std::numeric_limits<float>::max();
    Aabb box;
    for (int axis = 0; axis < 3; ++axis) {
      box.min[axis] = xyz[axis] == 0 ? -far : cube.min[axis] + cellWidth() * static_cast<float>(xyz[axis]);
      box.max[axis] = xyz[axis] == side() - 1 ? far : cube.min[axis] + cellWidth() * static_cast<float>(xyz[axis] + 1);
    }
    return box;
  }
};

Grid gridOver(const Aabb& box, std::uint64_t points) {
  Grid grid;
  const float side = std::max(box.extent().maxCoeff(), 1e-6f);
  const Vec3f centre = 0.5f * (box.min + box.max);
  grid.cube.min = centre - Vec3f::Constant(0.5f * side * 1.001f);
  grid.cube.max = centre + Vec3f::Constant(0.5f * side * 1.001f);
  const double wanted = std::log(static_cast<double>(points) / (6.0 * kPointsPerCell)) / std::log(4.0);
  grid.depth = std::clamp(static_cast<int>(std::ceil(wanted)), kShallowestGrid, kDeepestGrid);
  return grid;
}

bool insideBox(const Vec3f& p, const Aabb& box) {
  return (p.array() >= box.min.array()).all() && (p.array() <= box.max.array()).all();
}

// The file's points, a run at a time, in `oriented`'s local frame; the
// non-finite ones counted and left out.
Status forEachRun(const large_scan::PointRuns& file, const std::array<double, 3>& origin, std::uint64_t& nonFinite,
                  const std::function<Status(const std::vector<Vec3f>&)>& take) {
  Status status = okStatus();
  std::vector<Vec3f> local;
  auto notes = file.read(large_scan::kRunPoints, [&](Scan& run) {
    if (!status.ok()) return;
    local.clear();
    for (const Vec3f& p : run.points.positions) {
      const double x = run.origin[0] + p.x() - origin[0], y = run.origin[1] + p.y() - origin[1],
                   z = run.origin[2] + p.z() - origin[2];
      if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z)) {
        ++nonFinite;
        continue;
      }
      local.emplace_back(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z));
    }
    status = take(local);
  });
  if (!notes) return notes.error();
  return status;
}

// The source file as store.json records it: a store is reused only for
// the same file (path, size and time), k and oriented points (their count:
// they follow from the file and ingest's options).
Json sourceOf(const fs::path& scanPath, int k, std::size_t oriented) {
  std::error_code ignored;
  struct stat info {};
  ::stat(scanPath.c_str(), &info);
  return {{"path", fs::absolute(scanPath, ignored).string()},
          {"bytes", fs::file_size(scanPath, ignored)},
          {"modified_ns", static_cast<std::int64_t>(info.st_mtim.tv_sec) * 1000000000 + info.st_mtim.tv_nsec},
          {"k", k},
          {"oriented_points", oriented}};
}

// Pass 1: points per cell. Pass 2: each point at its cell's cursor.
Status sortIntoCells(const large_scan::PointRuns& file, const std::array<double, 3>& origin, const Grid& grid,
                     const fs::path& folder, std::vector<std::uint64_t>& cellBegin, PointStoreReport& report,
                     const ProgressCallback& progress) {
  std::vector<std::uint64_t> counts(grid.cells() + 1, 0);
  std::uint64_t nonFinite = 0, seen = 0;
  APO_RETURN_IF_ERROR(forEachRun(file, origin, nonFinite, [&](const std::vector<Vec3f>& run) {
    for (const Vec3f& p : run) ++counts[grid.cellOf(p) + 1];
    seen += run.size();
    reportProgress(progress, 0.25 * static_cast<double>(seen) / static_cast<double>(std::max<std::uint64_t>(file.count, 1)));
    return okStatus();
  }));
  report.nonFinite = nonFinite;
  std::partial_sum(counts.begin(), counts.end(), counts.begin());
  cellBegin = counts;
  report.points = cellBegin.back();
  for (std::size_t c = 0; c + 1 < cellBegin.size(); ++c) report.occupiedCells += cellBegin[c + 1] > cellBegin[c] ? 1 : 0;

  const RawFile positions("the point store", folder / kPositions, O_WRONLY | O_CREAT | O_TRUNC);
  APO_RETURN_IF_ERROR(positions.opened());
  std::vector<std::uint64_t> cursor(cellBegin.begin(), cellBegin.end() - 1);
  std::vector<std::uint32_t> order;
  std::vector<std::size_t> cells;
  std::vector<Vec3f> grouped;
  nonFinite = 0;
  seen = 0;
  APO_RETURN_IF_ERROR(forEachRun(file, origin, nonFinite, [&](const std::vector<Vec3f>& run) -> Status {
    // The run's points grouped by cell (in the run's order within each),
    // each group written at its cell's cursor.
    cells.resize(run.size());
    for (std::size_t i = 0; i < run.size(); ++i) cells[i] = grid.cellOf(run[i]);
    order.resize(run.size());
    std::iota(order.begin(), order.end(), 0U);
    std::stable_sort(order.begin(), order.end(), [&](std::uint32_t a, std::uint32_t b) { return cells[a] < cells[b]; });
    for (std::size_t first = 0; first < order.size();) {
      const std::size_t cell = cells[order[first]];
      grouped.clear();
      std::size_t end = first;
      for (; end < order.size() && cells[order[end]] == cell; ++end) grouped.push_back(run[order[end]]);
      APO_RETURN_IF_ERROR(positions.write(cursor[cell] * sizeof(Vec3f), grouped.data(), grouped.size() * sizeof(Vec3f)));
      cursor[cell] += grouped.size();
      first = end;
    }
    seen += run.size();
    reportProgress(progress, 0.25 + 0.25 * static_cast<double>(seen) / static_cast<double>(std::max<std::uint64_t>(report.points, 1)));
    return okStatus();
  }));
  if (seen != report.points)
    return badInput("{}: the second read gave {} finite points, the first {}", file.path.string(), seen, report.points);
  return positions.sync();
}

// Pass 3: each cell's normals, from its points and those in a band around it.
Status normalsByCell(const Grid& grid, const std::vector<std::uint64_t>& cellBegin, const Scan& oriented, int k,
                     const fs::path& folder, PointStoreReport& report, const ProgressCallback& progress) {
  const RawFile positions("the point store", folder / kPositions, O_RDONLY);
  APO_RETURN_IF_ERROR(positions.opened());
  const RawFile normals("the point store", folder / kNormals, O_WRONLY | O_CREAT | O_TRUNC);
  APO_RETURN_IF_ERROR(normals.opened());
  auto guide = makeFlannClosestPoint(oriented);
  if (!guide) return guide.error();
  const auto nearestOriented = [&](const Vec3f& p) {
    const std::optional<SurfacePoint> closest = (**guide).closest(p);
    return closest ? closest->normal : Vec3f(Vec3f::UnitZ());
  };
  const float band = kBandOfCell * grid.cellWidth();
  const int side = grid.side();
  std::vector<Vec3f> own, reference, read;
  for (std::size_t cell = 0; cell + 1 < cellBegin.size(); ++cell) {
    const std::uint64_t first = cellBegin[cell], count = cellBegin[cell + 1] - first;
    if (count == 0) continue;
    own.resize(count);
    APO_RETURN_IF_ERROR(positions.read(first * sizeof(Vec3f), own.data(), count * sizeof(Vec3f)));
    if (k == 0) {  // no plane: each point takes its nearest oriented point's normal
      std::vector<Vec3f> taken(count);
      tbb::parallel_for(std::size_t{0}, count, [&](std::size_t i) { taken[i] = nearestOriented(own[i]); });
      APO_RETURN_IF_ERROR(normals.write(first * sizeof(Vec3f), taken.data(), count * sizeof(Vec3f)));
      reportProgress(progress, 0.5 + 0.5 * static_cast<double>(cellBegin[cell + 1]) / static_cast<double>(cellBegin.back()));
      continue;
    }
    // The cell's points first, then its neighbours' within the band.
    Aabb reach = grid.boxOf(cell);
    reach.min -= Vec3f::Constant(band);
    reach.max += Vec3f::Constant(band);
    reference = own;
    const int n = side;
    const int x0 = static_cast<int>(cell / (static_cast<std::size_t>(n) * n)), y0 = static_cast<int>((cell / n) % n),
              z0 = static_cast<int>(cell % n);
    for (int x = std::max(x0 - 1, 0); x <= std::min(x0 + 1, n - 1); ++x)
      for (int y = std::max(y0 - 1, 0); y <= std::min(y0 + 1, n - 1); ++y)
        for (int z = std::max(z0 - 1, 0); z <= std::min(z0 + 1, n - 1); ++z) {
          const std::size_t other = grid.indexOf(x, y, z);
          if (other == cell || cellBegin[other + 1] == cellBegin[other]) continue;
          read.resize(cellBegin[other + 1] - cellBegin[other]);
          APO_RETURN_IF_ERROR(positions.read(cellBegin[other] * sizeof(Vec3f), read.data(), read.size() * sizeof(Vec3f)));
          for (const Vec3f& p : read)
            if (insideBox(p, reach)) reference.push_back(p);
        }
    const std::size_t neighbours = std::min<std::size_t>(static_cast<std::size_t>(k), reference.size());
    auto nearest = flann_adapter::nearestOf(reference, own, neighbours);
    if (!nearest) return nearest.error();
    std::vector<Vec3f> guides(count);
    std::vector<char> cut(count, 0);
    tbb::parallel_for(std::size_t{0}, count, [&](std::size_t i) {
      guides[i] = nearestOriented(own[i]);
      // Whether a nearer point could lie beyond the band: the k-th
      // neighbour farther than the band's edge (faces of the grid aside).
      const float kth = std::sqrt(nearest->squaredDistances[i * nearest->k + nearest->k - 1]);
      const Aabb box = grid.boxOf(cell);
      for (int axis = 0; axis < 3; ++axis) {
        const bool lowOpen = box.min[axis] < -1e37f, highOpen = box.max[axis] > 1e37f;
        if ((!lowOpen && own[i][axis] - kth < reach.min[axis]) || (!highOpen && own[i][axis] + kth > reach.max[axis]))
          cut[i] = 1;
      }
    });
    const normals::GuidedNormals fitted = normals::guidedNormals(reference, own, *nearest, guides);
    report.unfittedNormals += fitted.unfitted;
    report.cutNeighbourhoods += static_cast<std::uint64_t>(std::count(cut.begin(), cut.end(), 1));
    APO_RETURN_IF_ERROR(normals.write(first * sizeof(Vec3f), fitted.normals.data(), count * sizeof(Vec3f)));
    reportProgress(progress, 0.5 + 0.5 * static_cast<double>(cellBegin[cell + 1]) / static_cast<double>(cellBegin.back()));
  }
  return normals.sync();
}

Json manifestOf(const Grid& grid, const PointStoreReport& report, const Json& source) {
  return {{"format_version", kStoreVersion},
          {"source", source},
          {"points", report.points},
          {"non_finite", report.nonFinite},
          {"grid", {{"depth", grid.depth},
                    {"min", {grid.cube.min.x(), grid.cube.min.y(), grid.cube.min.z()}},
                    {"max", {grid.cube.max.x(), grid.cube.max.y(), grid.cube.max.z()}}}},
          {"occupied_cells", report.occupiedCells},
          {"neighbours", report.neighbours},
          {"unfitted_normals", report.unfittedNormals},
          {"cut_neighbourhoods", report.cutNeighbourhoods}};
}

std::uint64_t fileBytes(const fs::path& path) {
  std::error_code error;
  const auto bytes = fs::file_size(path, error);
  return error ? 0 : bytes;
}

}  // namespace

Result<PointStore> PointStore::open(const fs::path& folder) {
  auto text = readFileBytes(folder / kManifest);
  if (!text) return badInput("{}: no complete point store here", folder.string());
  return catchLibraryErrors("point store manifest", [&]() -> Result<PointStore> {
    const Json json = Json::parse(*text);
    if (json.value("format_version", 0) != kStoreVersion)
      return badInput("{}: point store format_version {} (this apo reads {})", (folder / kManifest).string(),
                      json.value("format_version", 0), kStoreVersion);
    PointStore store;
    store.folder_ = folder;
    store.count_ = json.at("points").get<std::uint64_t>();
    store.depth_ = json.at("grid").at("depth").get<int>();
    if (store.depth_ < kShallowestGrid || store.depth_ > kDeepestGrid)
      return badInput("{}: grid depth {} outside [{}, {}]", (folder / kManifest).string(), store.depth_, kShallowestGrid,
                      kDeepestGrid);
    for (int axis = 0; axis < 3; ++axis) {
      store.grid_.min[axis] = json.at("grid").at("min").at(axis).get<float>();
      store.grid_.max[axis] = json.at("grid").at("max").at(axis).get<float>();
    }
    const std::size_t cells = std::size_t{1} << (3 * store.depth_);
    if (fileBytes(folder / kCells) != (cells + 1) * sizeof(std::uint64_t) ||
        fileBytes(folder / kPositions) != store.count_ * sizeof(Vec3f) ||
        fileBytes(folder / kNormals) != store.count_ * sizeof(Vec3f))
      return badInput("{}: the store's files disagree with store.json ({} points, {} cells)", folder.string(),
                      store.count_, cells);
    store.cellBegin_.resize(cells + 1);
    const RawFile index("the point store", folder / kCells, O_RDONLY);
    APO_RETURN_IF_ERROR(index.opened());
    APO_RETURN_IF_ERROR(index.read(0, store.cellBegin_.data(), store.cellBegin_.size() * sizeof(std::uint64_t)));
    if (store.cellBegin_.front() != 0 || store.cellBegin_.back() != store.count_ ||
        !std::is_sorted(store.cellBegin_.begin(), store.cellBegin_.end()))
      return badInput("{}: the cell index is damaged", (folder / kCells).string());
    PointStoreReport& report = store.report_;
    report.points = store.count_;
    report.nonFinite = json.value("non_finite", std::uint64_t{0});
    report.gridDepth = store.depth_;
    report.occupiedCells = json.value("occupied_cells", std::uint64_t{0});
    report.neighbours = json.value("neighbours", 0);
    report.unfittedNormals = json.value("unfitted_normals", std::uint64_t{0});
    report.cutNeighbourhoods = json.value("cut_neighbourhoods", std::uint64_t{0});
    report.bytes = fileBytes(folder / kPositions) + fileBytes(folder / kNormals) + fileBytes(folder / kCells);
    return store;
  });
}

Result<PointSet> PointStore::pointsIn(const Aabb& box) const {
  const Grid grid{grid_, depth_};
  std::array<int, 3> low{}, high{};
  for (int axis = 0; axis < 3; ++axis) {
    low[axis] = grid.along(box.min[axis], axis);
    high[axis] = grid.along(box.max[axis], axis);
  }
  const RawFile positions("the point store", folder_ / kPositions, O_RDONLY);
  APO_RETURN_IF_ERROR(positions.opened());
  const RawFile normals("the point store", folder_ / kNormals, O_RDONLY);
  APO_RETURN_IF_ERROR(normals.opened());
  PointSet inside;
  std::vector<Vec3f> p, n;
  for (int x = low[0]; x <= high[0]; ++x)
    for (int y = low[1]; y <= high[1]; ++y) {
      // A run of cells along z is one range of the files.
      const std::uint64_t first = cellBegin_[grid.indexOf(x, y, low[2])], end = cellBegin_[grid.indexOf(x, y, high[2]) + 1];
      if (end == first) continue;
      p.resize(end - first);
      n.resize(end - first);
      APO_RETURN_IF_ERROR(positions.read(first * sizeof(Vec3f), p.data(), p.size() * sizeof(Vec3f)));
      APO_RETURN_IF_ERROR(normals.read(first * sizeof(Vec3f), n.data(), n.size() * sizeof(Vec3f)));
      for (std::size_t i = 0; i < p.size(); ++i)
        if (insideBox(p[i], box)) {
          inside.positions.push_back(p[i]);
          inside.normals.push_back(n[i]);
        }
    }
  return inside;
}

Result<PointStore> writePointStore(const fs::path& scanPath, const Scan& oriented, int k, const fs::path& folder,
                                   const ProgressCallback& progress) {
  const Stopwatch watch;
  const Json source = sourceOf(scanPath, k, oriented.points.size());
  if (auto earlier = PointStore::open(folder); earlier.ok()) {
    auto json = readFileBytes(folder / kManifest);
    const Json found = json ? Json::parse(*json, nullptr, false) : Json();
    if (found.is_object() && found.value("source", Json()) == source) {
      earlier->report_.reused = true;
      spdlog::info("ingest: the point store in {} is complete: reused", folder.string());
      return earlier;
    }
  }
  if (!oriented.points.hasNormals() || oriented.points.size() == 0)
    return internalError("a point store needs the scan's oriented points with normals");
  auto format = formatFromExtension(scanPath);
  if (!format) return format.error();
  auto file = large_scan::openPointRuns(scanPath, *format, 0);
  if (!file) return file.error();
  if (!*file)
    return badInput(
        "{}: a point store reads PLY of vertices alone, PCD of one row, LAS, LAZ, E57 or XYZ/CSV/PTS files",
        scanPath.string());
  std::error_code error;
  fs::remove(folder / kManifest, error);  // the store is incomplete from here on
  fs::create_directories(folder, error);
  if (error) return internalError("cannot make the point store folder {}: {}", folder.string(), error.message());

  PointStoreReport report;
  report.neighbours = k;
  const Grid grid = gridOver(boundingBox(oriented.points.positions), (*file)->count);
  report.gridDepth = grid.depth;
  std::vector<std::uint64_t> cellBegin;
  APO_RETURN_IF_ERROR(sortIntoCells(**file, oriented.origin, grid, folder, cellBegin, report, progress));
  spdlog::info("ingest: {} points sorted into {} cells of a {}^3 grid in {:.1f} s", report.points, report.occupiedCells,
               grid.side(), watch.seconds());
  APO_RETURN_IF_ERROR(normalsByCell(grid, cellBegin, oriented, k, folder, report, progress));
  {
    const RawFile index("the point store", folder / kCells, O_WRONLY | O_CREAT | O_TRUNC);
    APO_RETURN_IF_ERROR(index.opened());
    APO_RETURN_IF_ERROR(index.write(0, cellBegin.data(), cellBegin.size() * sizeof(std::uint64_t)));
    APO_RETURN_IF_ERROR(index.sync());
  }
  APO_RETURN_IF_ERROR(writeFileAtomically(folder / kManifest, manifestOf(grid, report, source).dump(2) + "\n"));
  auto store = PointStore::open(folder);
  if (!store) return store.error();
  store->report_.seconds = watch.seconds();
  if (k == 0)
    spdlog::info("ingest: every point's normal, its nearest centroid's, in {:.1f} s", store->report_.seconds);
  else
    spdlog::info("ingest: every point's normal in {:.1f} s ({} with no plane fitted, {} neighbourhoods cut by the band)",
                 store->report_.seconds, report.unfittedNormals, report.cutNeighbourhoods);
  return store;
}

}  // namespace apo
