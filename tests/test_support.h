// Helpers shared by the tests: a fresh temporary folder per test, file
// writing, and the one path to the real datasets.
#pragma once

#include <filesystem>
#include <string>
#include <string_view>

namespace apo::test {

// A new empty folder under the system temp dir, unique to the calling test.
std::filesystem::path freshTempDir();

// Writes bytes to a file (creating folders), for fixtures made by the tests.
void writeBytes(const std::filesystem::path& path, std::string_view bytes);

// Path of a file of the real datasets (datasets/<relative>). Runs
// datasets_scripts/fetch_datasets.sh once if the file is missing, so a test
// needing a dataset works on a fresh checkout. Fails the test if it cannot.
std::filesystem::path datasetPath(const std::string& relative);

// The `apo` executable under test (build/apo), set by CMake.
std::filesystem::path apoExecutable();

struct CommandResult {
  int exitCode = -1;
  std::string output;  // stdout and stderr interleaved
};
// Runs a shell command, capturing its output and exit code.
CommandResult runCommand(const std::string& command);
// Runs the `apo` under test with these arguments (shell syntax).
CommandResult runApo(const std::string& arguments);

}  // namespace apo::test

#include "core/checked.h"

#include <cstdio>
#include <cstdlib>

namespace apo::test {

// Options a test holds to be in range, as a stage takes them; the test stops
// at once, naming the option, when they are not (the checks are tested apart).
template <class Options>
Checked<Options> checked(const Options& options) {
  auto accepted = check(options);
  if (!accepted) {
    std::fprintf(stderr, "test options rejected: %s\n", accepted.error().message.c_str());
    std::abort();
  }
  return *accepted;
}

}  // namespace apo::test

#include "core/closest_point.h"
#include "core/geometry.h"
#include "core/ray_caster.h"

#include <array>
#include <random>

namespace apo::test {

// Brute-force ray caster, the independent reference for Embree: every ray
// against every primitive, in double precision. A mesh's triangles are hit by
// Moller-Trumbore (u, v barycentrics, geometricNormal (b-a) x (c-a)); a point
// cloud's points are oriented discs of the given radii, hit from either side
// (geometricNormal = the point's normal, u = v = 0). The nearest t in
// [tNear, tFar] wins; on equal t the lower primitive index. Copies its input.
class BruteForceCaster : public RayCaster {
 public:
  explicit BruteForceCaster(const Scan& detail, std::vector<float> discRadii = {});
  void intersect(const std::vector<Ray>& rays, std::vector<RayHit>& hits) const override;

 private:
  RayHit castOne(const Ray& ray) const;
  Scan detail_;
  std::vector<float> radii_;
};

// Brute-force closest point, the independent reference for FLANN, in double
// precision. Mesh: over ALL triangles, the plane projection when it falls
// inside the triangle, else the closest point of its three edges; the normal
// is the vertex normals interpolated by the barycentrics, normalised (the
// face normal where they cancel). Points: the nearest point and its normal.
// O(primitives) per query. Copies its input.
class BruteForceClosestPoint : public ClosestPointFinder {
 public:
  explicit BruteForceClosestPoint(const Scan& detail);
  std::optional<SurfacePoint> closest(const Vec3f& query) const override;

 private:
  SurfacePoint closestOnMesh(const Vec3f& query) const;
  SurfacePoint closestPoint(const Vec3f& query) const;
  Scan detail_;
};

// Unit-radius icosphere centred at the origin: an icosahedron whose faces are
// split in four `subdivisions` times, vertices pushed onto the sphere.
// Outward-facing triangles.
Scan makeIcosphere(int subdivisions);

// Torus around the z axis (major radius R, minor radius r), a grid of
// `segments` x `rings` quads split into outward-facing triangles.
Scan makeTorus(float majorRadius, float minorRadius, int segments, int rings);

// The unit square in z = 0 as two triangles {0, 1, 2}, {0, 2, 3} over the
// corners (0,0) (1,0) (1,1) (0,1), with intensities 0 to 3.
Scan squareOfTwoTriangles();

// The unit square in z = 0 as n x n quads, each split into two triangles
// facing +z.
Scan makeSquareGrid(int n);

// Distance from p to that torus's surface.
float distanceToTorus(const Vec3f& p, float majorRadius, float minorRadius);

// Points uniformly random in the cube [-1, 1]^3, repeatable for a seed.
std::vector<Vec3f> randomCubePoints(std::size_t count, std::uint64_t seed);

// Points on the unit sphere (Fibonacci lattice), deterministic.
std::vector<Vec3f> fibonacciSpherePoints(std::size_t count);

// Barycentrics of a point uniformly random on a triangle (the square's two
// halves folded onto one), drawn from `random`.
std::array<float, 3> randomBarycentrics(std::mt19937& random);

}  // namespace apo::test
