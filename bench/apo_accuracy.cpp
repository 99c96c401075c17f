// How close the APO's normals are to M's, measured as issue 5 quotes the
// other tools: points sampled on m, the APO's normal there (the walk the
// shader does) against M's interpolated normal at the closest point of M,
// next to m's own interpolated normal (the bare baseline).
//   apo_accuracy M.ply m.ply scan.apo [samples=200000]
// Prints mean, median and 95th percentile angular errors in degrees.
#include "adapters/flann/flann_search.h"
#include "format/format.h"
#include "ingest/ingest.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <numbers>
#include <random>

namespace {

using apo::Vec3f;

struct Stats {
  double mean = 0, median = 0, p95 = 0;
};

Stats statsOf(std::vector<double> values) {
  Stats s;
  if (values.empty()) return s;
  for (const double v : values) s.mean += v;
  s.mean /= static_cast<double>(values.size());
  std::sort(values.begin(), values.end());
  s.median = values[values.size() / 2];
  s.p95 = values[static_cast<std::size_t>(0.95 * static_cast<double>(values.size() - 1))];
  return s;
}

double degreesBetween(const Vec3f& a, const Vec3f& b) {
  return std::acos(std::clamp(static_cast<double>(a.normalized().dot(b.normalized())), -1.0, 1.0)) * 180.0 /
         std::numbers::pi;
}

// Area-uniform points on the mesh (fixed seed), with the barycentrics of each.
struct SurfaceSample {
  std::size_t triangle;
  float u, v;
};

std::vector<SurfaceSample> sampleByArea(const apo::Scan& mesh, std::size_t count) {
  std::vector<double> cumulative;
  double total = 0.0;
  for (const apo::Triangle& t : mesh.triangles) {
    const auto& p = mesh.points.positions;
    total += 0.5 * (p[t[1]] - p[t[0]]).cross(p[t[2]] - p[t[0]]).norm();
    cumulative.push_back(total);
  }
  std::mt19937_64 rng(2007);
  std::uniform_real_distribution<double> pick(0.0, total);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  std::vector<SurfaceSample> samples;
  for (std::size_t i = 0; i < count; ++i) {
    const auto it = std::lower_bound(cumulative.begin(), cumulative.end(), pick(rng));
    float u = unit(rng), v = unit(rng);
    if (u + v > 1.0f) u = 1.0f - u, v = 1.0f - v;
    samples.push_back({static_cast<std::size_t>(std::min<std::ptrdiff_t>(it - cumulative.begin(), mesh.triangles.size() - 1)), u, v});
  }
  return samples;
}

int run(int argc, char** argv) {
  if (argc < 4) {
    fmt::print(stderr, "usage: apo_accuracy M.ply m.ply scan.apo [samples]\n");
    return 1;
  }
  auto detail = apo::readScan(argv[1]);
  auto coarse = apo::readScan(argv[2]);
  auto texture = apo::readApoFile(argv[3]);
  if (!detail || !coarse || !texture) {
    fmt::print(stderr, "cannot read the inputs: {}\n",
               !detail ? detail.error().message : !coarse ? coarse.error().message : texture.error().message);
    return 2;
  }
  apo::addVertexNormalsIfMissing(*detail);
  const std::vector<Vec3f> coarseNormals = apo::vertexNormalsAsDrawn(*coarse);
  auto closest = apo::makeFlannClosestPoint(*detail);
  if (!closest) return 2;
  const std::size_t count = argc > 4 ? std::strtoull(argv[4], nullptr, 10) : 200000;
  std::vector<double> apoErrors, filteredErrors, bareErrors;
  std::size_t outside = 0;
  for (const SurfaceSample& s : sampleByArea(*coarse, count)) {
    const apo::Triangle& t = coarse->triangles[s.triangle];
    const auto& p = coarse->points.positions;
    const float w = 1.0f - s.u - s.v;
    const Vec3f point = w * p[t[0]] + s.u * p[t[1]] + s.v * p[t[2]];
    const Vec3f bare = w * coarseNormals[t[0]] + s.u * coarseNormals[t[1]] + s.v * coarseNormals[t[2]];
    const Vec3f truth = (*closest)->closest(point).value().normal;
    const Vec3f coarseNormal = bare.normalized();  // what leaves that show m's normal give
    const apo::Lookup found = apo::lookupTexture(*texture, texture->transform.toUnit(point), 255, coarseNormal);
    if (!found.found) ++outside;
    apoErrors.push_back(found.found ? degreesBetween(found.normal, truth) : 180.0);
    const apo::Lookup filtered = apo::lookupTextureFiltered(*texture, texture->transform.toUnit(point), coarseNormal);
    filteredErrors.push_back(filtered.found ? degreesBetween(filtered.normal, truth) : 180.0);
    bareErrors.push_back(degreesBetween(bare, truth));
  }
  const Stats a = statsOf(apoErrors), f = statsOf(filteredErrors), b = statsOf(bareErrors);
  fmt::print("samples {} outside {}\n", count, outside);
  fmt::print("apo  mean {:.3f} median {:.3f} p95 {:.3f} deg\n", a.mean, a.median, a.p95);
  fmt::print("apo filtered mean {:.3f} median {:.3f} p95 {:.3f} deg\n", f.mean, f.median, f.p95);
  fmt::print("bare mean {:.3f} median {:.3f} p95 {:.3f} deg\n", b.mean, b.median, b.p95);
  return 0;
}

}  // namespace

int main(int argc, char** argv) { return run(argc, argv); }
