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

}  // namespace apo::test

#include "core/geometry.h"

namespace apo::test {

// Unit-radius icosphere centred at the origin: an icosahedron whose faces are
// split in four `subdivisions` times, vertices pushed onto the sphere.
// Outward-facing triangles.
Scan makeIcosphere(int subdivisions);

// Torus around the z axis (major radius R, minor radius r), a grid of
// `segments` x `rings` quads split into outward-facing triangles.
Scan makeTorus(float majorRadius, float minorRadius, int segments, int rings);

// Distance from p to that torus's surface.
float distanceToTorus(const Vec3f& p, float majorRadius, float minorRadius);

// Points uniformly random in the cube [-1, 1]^3, repeatable for a seed.
std::vector<Vec3f> randomCubePoints(std::size_t count, std::uint64_t seed);

// Points on the unit sphere (Fibonacci lattice), deterministic.
std::vector<Vec3f> fibonacciSpherePoints(std::size_t count);

}  // namespace apo::test
