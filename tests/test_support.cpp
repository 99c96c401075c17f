#include "tests/test_support.h"

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <mutex>

namespace apo::test {
namespace fs = std::filesystem;

fs::path freshTempDir() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::string name = info ? std::string(info->test_suite_name()) + "." + info->name() : "apo_test";
  for (char& c : name)
    if (c == '/') c = '_';
  const fs::path dir = fs::temp_directory_path() / ("apo_tests_" + std::to_string(::getpid())) / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

void writeBytes(const fs::path& path, std::string_view bytes) {
  if (path.has_parent_path()) fs::create_directories(path.parent_path());
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  if (!out) ADD_FAILURE() << "cannot write fixture " << path;
}

fs::path datasetPath(const std::string& relative) {
  const fs::path root = fs::path(APO_SOURCE_DIR) / "datasets";
  const fs::path path = root / relative;
  static std::mutex fetchMutex;
  std::lock_guard lock(fetchMutex);
  if (!fs::exists(path)) {
    const std::string command = "bash " + (fs::path(APO_SOURCE_DIR) / "datasets_scripts" / "fetch_datasets.sh").string();
    const int rc = std::system(command.c_str());
    if (rc != 0 || !fs::exists(path)) ADD_FAILURE() << "dataset " << path << " missing and " << command << " failed";
  }
  return path;
}

fs::path apoExecutable() { return fs::path(APO_EXECUTABLE); }

CommandResult runCommand(const std::string& command) {
  CommandResult result;
  FILE* pipe = ::popen((command + " 2>&1").c_str(), "r");
  if (!pipe) return result;
  std::array<char, 4096> buffer{};
  std::size_t n = 0;
  while ((n = std::fread(buffer.data(), 1, buffer.size(), pipe)) > 0) result.output.append(buffer.data(), n);
  const int status = ::pclose(pipe);
  result.exitCode = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

CommandResult runApo(const std::string& arguments) { return runCommand(apoExecutable().string() + " " + arguments); }

}  // namespace apo::test

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <optional>
#include <random>

namespace apo::test {

Scan makeIcosphere(int subdivisions) {
  const float t = (1.0f + std::sqrt(5.0f)) / 2.0f;
  Scan mesh;
  auto& p = mesh.points.positions;
  p = {{-1, t, 0}, {1, t, 0}, {-1, -t, 0}, {1, -t, 0}, {0, -1, t}, {0, 1, t},
       {0, -1, -t}, {0, 1, -t}, {t, 0, -1}, {t, 0, 1}, {-t, 0, -1}, {-t, 0, 1}};
  for (auto& v : p) v.normalize();
  mesh.triangles = {{0, 11, 5}, {0, 5, 1}, {0, 1, 7}, {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
                    {11, 10, 2}, {10, 7, 6}, {7, 1, 8}, {3, 9, 4}, {3, 4, 2}, {3, 2, 6}, {3, 6, 8},
                    {3, 8, 9}, {4, 9, 5}, {2, 4, 11}, {6, 2, 10}, {8, 6, 7}, {9, 8, 1}};
  for (int level = 0; level < subdivisions; ++level) {
    std::map<std::pair<std::uint32_t, std::uint32_t>, std::uint32_t> midpoints;
    auto midpoint = [&](std::uint32_t a, std::uint32_t b) {
      const auto key = std::minmax(a, b);
      auto [it, inserted] = midpoints.try_emplace(key, static_cast<std::uint32_t>(p.size()));
      if (inserted) p.push_back((p[a] + p[b]).normalized());
      return it->second;
    };
    std::vector<Triangle> finer;
    for (const Triangle& tri : mesh.triangles) {
      const std::uint32_t ab = midpoint(tri[0], tri[1]), bc = midpoint(tri[1], tri[2]), ca = midpoint(tri[2], tri[0]);
      finer.push_back({tri[0], ab, ca});
      finer.push_back({tri[1], bc, ab});
      finer.push_back({tri[2], ca, bc});
      finer.push_back({ab, bc, ca});
    }
    mesh.triangles = std::move(finer);
  }
  return mesh;
}

Scan makeTorus(float majorRadius, float minorRadius, int segments, int rings) {
  Scan mesh;
  for (int i = 0; i < segments; ++i)
    for (int j = 0; j < rings; ++j) {
      const double u = 2.0 * std::numbers::pi * i / segments, v = 2.0 * std::numbers::pi * j / rings;
      const double radius = majorRadius + minorRadius * std::cos(v);
      mesh.points.positions.emplace_back(static_cast<float>(radius * std::cos(u)), static_cast<float>(radius * std::sin(u)),
                                         static_cast<float>(minorRadius * std::sin(v)));
    }
  auto index = [&](int i, int j) { return static_cast<std::uint32_t>((i % segments) * rings + (j % rings)); };
  for (int i = 0; i < segments; ++i)
    for (int j = 0; j < rings; ++j) {
      mesh.triangles.push_back({index(i, j), index(i + 1, j), index(i + 1, j + 1)});
      mesh.triangles.push_back({index(i, j), index(i + 1, j + 1), index(i, j + 1)});
    }
  return mesh;
}

Scan squareOfTwoTriangles() {
  Scan mesh;
  mesh.points.positions = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  mesh.points.intensities = {0, 1, 2, 3};
  mesh.triangles = {{0, 1, 2}, {0, 2, 3}};
  return mesh;
}

Scan makeSquareGrid(int n) {
  Scan grid;
  for (int i = 0; i <= n; ++i)
    for (int j = 0; j <= n; ++j) grid.points.positions.emplace_back(float(i) / n, float(j) / n, 0.0f);
  const auto id = [&](int i, int j) { return static_cast<std::uint32_t>(i * (n + 1) + j); };
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      grid.triangles.push_back({id(i, j), id(i + 1, j), id(i + 1, j + 1)});
      grid.triangles.push_back({id(i, j), id(i + 1, j + 1), id(i, j + 1)});
    }
  return grid;
}

float distanceToTorus(const Vec3f& p, float majorRadius, float minorRadius) {
  const float ring = std::hypot(p.x(), p.y()) - majorRadius;
  return std::abs(std::hypot(ring, p.z()) - minorRadius);
}

std::vector<Vec3f> randomCubePoints(std::size_t count, std::uint64_t seed) {
  std::mt19937_64 random(seed);
  std::uniform_real_distribution<float> uniform(-1.0f, 1.0f);
  std::vector<Vec3f> points(count);
  for (Vec3f& p : points) p = Vec3f(uniform(random), uniform(random), uniform(random));
  return points;
}

std::vector<Vec3f> fibonacciSpherePoints(std::size_t count) {
  std::vector<Vec3f> points;
  const double golden = std::numbers::pi * (3.0 - std::sqrt(5.0));
  for (std::size_t i = 0; i < count; ++i) {
    const double z = 1.0 - (2.0 * static_cast<double>(i) + 1.0) / static_cast<double>(count);
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    const double a = golden * static_cast<double>(i);
    points.emplace_back(static_cast<float>(r * std::cos(a)), static_cast<float>(r * std::sin(a)), static_cast<float>(z));
  }
  return points;
}

}  // namespace apo::test

// ---- Brute-force seams -------------------------------------------------------

namespace apo::test {
namespace {

using Vec3d = Eigen::Vector3d;

Vec3d wide(const Vec3f& v) { return v.cast<double>(); }

// Moller-Trumbore: t and the barycentrics (u, v) of b and c, if the line hits.
std::optional<std::array<double, 3>> lineTriangle(const Vec3d& origin, const Vec3d& direction, const Vec3d& a,
                                                  const Vec3d& b, const Vec3d& c) {
  const Vec3d e1 = b - a, e2 = c - a;
  const Vec3d p = direction.cross(e2);
  const double det = e1.dot(p);
  if (det == 0.0) return std::nullopt;  // parallel or degenerate
  const Vec3d s = origin - a;
  const double u = s.dot(p) / det;
  const Vec3d q = s.cross(e1);
  const double v = direction.dot(q) / det;
  if (u < 0.0 || v < 0.0 || u + v > 1.0) return std::nullopt;
  return std::array<double, 3>{e2.dot(q) / det, u, v};
}

// The line's parameter t where it crosses the disc, if it does.
std::optional<double> lineDisc(const Vec3d& origin, const Vec3d& direction, const Vec3d& centre, const Vec3d& normal,
                               double radius) {
  const double denominator = normal.dot(direction);
  if (denominator == 0.0) return std::nullopt;  // parallel to the disc's plane
  const double t = normal.dot(centre - origin) / denominator;
  if ((origin + t * direction - centre).squaredNorm() > radius * radius) return std::nullopt;
  return t;
}

// Closest point of a segment to q.
Vec3d closestOnSegment(const Vec3d& q, const Vec3d& from, const Vec3d& to) {
  const Vec3d edge = to - from;
  const double length2 = edge.squaredNorm();
  if (length2 == 0.0) return from;
  return from + std::clamp(edge.dot(q - from) / length2, 0.0, 1.0) * edge;
}

// Barycentrics of x (in the triangle's plane) from the signed sub-areas.
Vec3d barycentrics(const Vec3d& x, const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  const Vec3d n = (b - a).cross(c - a);
  const double area2 = n.squaredNorm();
  const double wa = (c - b).cross(x - b).dot(n) / area2;
  const double wb = (a - c).cross(x - c).dot(n) / area2;
  return {wa, wb, 1.0 - wa - wb};
}

// Closest point on a triangle: the plane projection when inside, else the
// nearest of the closest points of its three edges.
Vec3d closestOnTriangle(const Vec3d& q, const Vec3d& a, const Vec3d& b, const Vec3d& c) {
  const Vec3d n = (b - a).cross(c - a);
  if (n.squaredNorm() > 0.0) {
    const Vec3d projection = q - (q - a).dot(n) / n.squaredNorm() * n;
    if (barycentrics(projection, a, b, c).minCoeff() >= 0.0) return projection;
  }
  Vec3d best = closestOnSegment(q, a, b);
  for (const Vec3d& x : {closestOnSegment(q, b, c), closestOnSegment(q, c, a)})
    if ((q - x).squaredNorm() < (q - best).squaredNorm()) best = x;
  return best;
}

}  // namespace

BruteForceCaster::BruteForceCaster(const Scan& detail, std::vector<float> discRadii)
    : detail_(detail), radii_(std::move(discRadii)) {
  if (!detail_.isMesh() && (radii_.size() != detail_.points.size() || !detail_.points.hasNormals()))
    ADD_FAILURE() << "BruteForceCaster over points needs a normal and a radius per point";
}

void BruteForceCaster::intersect(const std::vector<Ray>& rays, std::vector<RayHit>& hits) const {
  hits.clear();
  for (const Ray& ray : rays) hits.push_back(castOne(ray));
}

RayHit BruteForceCaster::castOne(const Ray& ray) const {
  const Vec3d origin = wide(ray.origin), direction = wide(ray.direction);
  const auto& p = detail_.points.positions;
  RayHit best;
  double bestT = std::numeric_limits<double>::infinity();
  auto accept = [&](double t, std::size_t primitive) {
    if (t < ray.tNear || t > ray.tFar || t >= bestT) return false;
    bestT = t;
    best.primitive = static_cast<std::uint32_t>(primitive);
    best.t = static_cast<float>(t);
    return true;
  };
  if (detail_.isMesh()) {
    for (std::size_t i = 0; i < detail_.triangles.size(); ++i) {
      const Triangle& tri = detail_.triangles[i];
      const auto hit = lineTriangle(origin, direction, wide(p[tri[0]]), wide(p[tri[1]]), wide(p[tri[2]]));
      if (!hit || !accept((*hit)[0], i)) continue;
      best.u = static_cast<float>((*hit)[1]);
      best.v = static_cast<float>((*hit)[2]);
      best.geometricNormal = (p[tri[1]] - p[tri[0]]).cross(p[tri[2]] - p[tri[0]]);
    }
    return best;
  }
  for (std::size_t i = 0; i < p.size(); ++i) {
    const auto t = lineDisc(origin, direction, wide(p[i]), wide(detail_.points.normals[i]), radii_[i]);
    if (!t || !accept(*t, i)) continue;
    best.u = best.v = 0.0f;
    best.geometricNormal = detail_.points.normals[i];
  }
  return best;
}

BruteForceClosestPoint::BruteForceClosestPoint(const Scan& detail) : detail_(detail) {
  if (!detail_.points.hasNormals()) ADD_FAILURE() << "BruteForceClosestPoint needs normals";
}

std::optional<SurfacePoint> BruteForceClosestPoint::closest(const Vec3f& query) const {
  return detail_.isMesh() ? closestOnMesh(query) : closestPoint(query);
}

SurfacePoint BruteForceClosestPoint::closestOnMesh(const Vec3f& query) const {
  const auto& p = detail_.points.positions;
  const Vec3d q = wide(query);
  double bestDistance2 = std::numeric_limits<double>::infinity();
  Vec3d bestPoint = Vec3d::Zero();
  std::size_t bestTriangle = 0;
  for (std::size_t i = 0; i < detail_.triangles.size(); ++i) {
    const Triangle& t = detail_.triangles[i];
    const Vec3d x = closestOnTriangle(q, wide(p[t[0]]), wide(p[t[1]]), wide(p[t[2]]));
    if ((q - x).squaredNorm() < bestDistance2) {
      bestDistance2 = (q - x).squaredNorm();
      bestPoint = x;
      bestTriangle = i;
    }
  }
  const Triangle& t = detail_.triangles[bestTriangle];
  const Vec3d a = wide(p[t[0]]), b = wide(p[t[1]]), c = wide(p[t[2]]);
  const auto& n = detail_.points.normals;
  Vec3d weights = (b - a).cross(c - a).squaredNorm() > 0.0 ? barycentrics(bestPoint, a, b, c) : Vec3d(1, 0, 0);
  Vec3d normal = weights.x() * wide(n[t[0]]) + weights.y() * wide(n[t[1]]) + weights.z() * wide(n[t[2]]);
  if (normal.squaredNorm() < 1e-12) normal = (b - a).cross(c - a);  // opposite vertex normals cancel
  return {bestPoint.cast<float>(), normal.normalized().cast<float>()};
}

SurfacePoint BruteForceClosestPoint::closestPoint(const Vec3f& query) const {
  const auto& p = detail_.points.positions;
  std::size_t nearest = 0;
  for (std::size_t i = 1; i < p.size(); ++i)
    if ((wide(p[i]) - wide(query)).squaredNorm() < (wide(p[nearest]) - wide(query)).squaredNorm()) nearest = i;
  return {p[nearest], detail_.points.normals[nearest]};
}

std::array<float, 3> randomBarycentrics(std::mt19937& random) {
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  float a = unit(random), b = unit(random);
  if (a + b > 1.0f) a = 1.0f - a, b = 1.0f - b;
  return {1.0f - a - b, a, b};
}

}  // namespace apo::test
