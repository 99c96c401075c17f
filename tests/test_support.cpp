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

}  // namespace apo::test

#include <cmath>
#include <map>
#include <numbers>
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
