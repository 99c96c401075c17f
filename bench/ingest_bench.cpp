// Ingest throughput on the real datasets, with PCL's own PCD loader and
// Open3D's read + normal estimation as baselines in the same run. Run after datasets_scripts/fetch_datasets.sh:
//   build/ingest_bench --benchmark_min_time=1
#include "ingest/ingest.h"

#include <benchmark/benchmark.h>
#include <open3d/geometry/KDTreeSearchParam.h>
#include <open3d/geometry/PointCloud.h>
#include <open3d/io/PointCloudIO.h>
#include <pcl/io/pcd_io.h>
#include <pcl/point_types.h>

#include <spdlog/spdlog.h>

#include <filesystem>

namespace {
namespace fs = std::filesystem;

fs::path dataset(const char* relative) { return fs::path(APO_SOURCE_DIR) / "datasets" / relative; }

void readWithApo(benchmark::State& state, const char* relative) {
  for (auto _ : state) {
    auto scan = apo::readScan(dataset(relative));
    if (!scan.ok()) {
      state.SkipWithError(scan.error().message.c_str());
      return;
    }
    benchmark::DoNotOptimize(scan->points.positions.data());
    state.counters["points"] = static_cast<double>(scan->points.size());
  }
}

void readWithPcl(benchmark::State& state, const char* relative) {
  for (auto _ : state) {
    pcl::PointCloud<pcl::PointXYZI> cloud;
    if (pcl::io::loadPCDFile(dataset(relative).string(), cloud) != 0) {
      state.SkipWithError("PCL could not read the file");
      return;
    }
    benchmark::DoNotOptimize(cloud.data());
  }
}

// What an Open3D user would write: read, k-NN normals, face the sensor.
void ingestWithOpen3d(benchmark::State& state, const char* relative, int k) {
  for (auto _ : state) {
    open3d::geometry::PointCloud cloud;
    if (!open3d::io::ReadPointCloud(dataset(relative).string(), cloud)) {
      state.SkipWithError("Open3D could not read the file");
      return;
    }
    cloud.RemoveDuplicatedPoints();
    cloud.EstimateNormals(open3d::geometry::KDTreeSearchParamKNN(k));
    cloud.OrientNormalsTowardsCameraLocation(Eigen::Vector3d::Zero());
    state.counters["points_out"] = static_cast<double>(cloud.points_.size());
  }
}

void ingestWithApo(benchmark::State& state, const char* relative) {
  for (auto _ : state) {
    auto result = apo::ingestScan(dataset(relative), *apo::check(apo::IngestOptions{}));
    if (!result.ok()) {
      state.SkipWithError(result.error().message.c_str());
      return;
    }
    state.counters["points_out"] = static_cast<double>(result->report.pointsOut);
    state.counters["normal_s"] = result->report.normalSeconds;
  }
}

BENCHMARK_CAPTURE(readWithApo, table_scene_lms400, "pcl/table_scene_lms400.pcd")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(readWithPcl, table_scene_lms400, "pcl/table_scene_lms400.pcd")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(readWithApo, building_ply, "cgal/points_3/building.ply")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(readWithApo, bunny00_off, "cgal/meshes/bunny00.off")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(ingestWithApo, table_scene_lms400, "pcl/table_scene_lms400.pcd")->Unit(benchmark::kSecond)->Iterations(3);
BENCHMARK_CAPTURE(ingestWithOpen3d, table_scene_lms400_k48, "pcl/table_scene_lms400.pcd", 48)
    ->Unit(benchmark::kSecond)
    ->Iterations(3);
BENCHMARK_CAPTURE(ingestWithApo, kitten_xyz_with_normals, "cgal/points_3/kitten.xyz")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(ingestWithApo, building_ply_with_normals, "cgal/points_3/building.ply")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(ingestWithApo, bunny00_off_mesh, "cgal/meshes/bunny00.off")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(ingestWithApo, octomap_scan_mst, "octomap/scan.xyz")->Unit(benchmark::kSecond)->Iterations(3);

}  // namespace

int main(int argc, char** argv) {
  spdlog::set_level(spdlog::level::warn);  // keep the table readable
  benchmark::Initialize(&argc, argv);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
}
