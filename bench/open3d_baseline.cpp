// The Open3D calls a user would make instead of `apo reconstruct` and
// `apo simplify`, timed the same way, for docs/benchmarks.md:
//   open3d_baseline poisson POINTS.ply OUT.ply [depth]
//   open3d_baseline decimate MESH.ply FACES OUT.ply
//   open3d_baseline subdivide MESH.ply ITERATIONS OUT.ply   (makes the ~1M-face input)
#include <open3d/geometry/PointCloud.h>
#include <open3d/geometry/TriangleMesh.h>
#include <open3d/io/PointCloudIO.h>
#include <open3d/io/TriangleMeshIO.h>

#include <chrono>
#include <cstdio>
#include <limits>
#include <string>

namespace {

double secondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

int poisson(const std::string& input, const std::string& output, int depth) {
  open3d::geometry::PointCloud cloud;
  if (!open3d::io::ReadPointCloud(input, cloud) || !cloud.HasNormals()) {
    std::fprintf(stderr, "%s: cannot read points with normals\n", input.c_str());
    return 2;
  }
  const auto start = std::chrono::steady_clock::now();
  auto [mesh, densities] = open3d::geometry::TriangleMesh::CreateFromPointCloudPoisson(cloud, static_cast<size_t>(depth));
  std::printf("open3d poisson depth %d: %zu points -> %zu triangles in %.3f s\n", depth, cloud.points_.size(),
              mesh->triangles_.size(), secondsSince(start));
  return open3d::io::WriteTriangleMesh(output, *mesh) ? 0 : 3;
}

int decimate(const std::string& input, int faces, const std::string& output) {
  open3d::geometry::TriangleMesh mesh;
  if (!open3d::io::ReadTriangleMesh(input, mesh)) return 2;
  const auto start = std::chrono::steady_clock::now();
  auto simplified = mesh.SimplifyQuadricDecimation(faces, std::numeric_limits<double>::infinity(), 1.0);
  std::printf("open3d quadric decimation: %zu -> %zu triangles in %.3f s\n", mesh.triangles_.size(),
              simplified->triangles_.size(), secondsSince(start));
  return open3d::io::WriteTriangleMesh(output, *simplified) ? 0 : 3;
}

int subdivide(const std::string& input, int iterations, const std::string& output) {
  open3d::geometry::TriangleMesh mesh;
  if (!open3d::io::ReadTriangleMesh(input, mesh)) return 2;
  auto finer = mesh.SubdivideLoop(iterations);
  std::printf("open3d loop subdivision: %zu -> %zu triangles\n", mesh.triangles_.size(), finer->triangles_.size());
  return open3d::io::WriteTriangleMesh(output, *finer) ? 0 : 3;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string command = argc > 1 ? argv[1] : "";
  if (command == "poisson" && (argc == 4 || argc == 5)) return poisson(argv[2], argv[3], argc == 5 ? std::stoi(argv[4]) : 8);
  if (command == "decimate" && argc == 5) return decimate(argv[2], std::stoi(argv[3]), argv[4]);
  if (command == "subdivide" && argc == 5) return subdivide(argv[2], std::stoi(argv[3]), argv[4]);
  std::fprintf(stderr, "usage: open3d_baseline poisson IN OUT [depth] | decimate IN FACES OUT | subdivide IN N OUT\n");
  return 1;
}
