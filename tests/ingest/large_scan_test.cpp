// Scans above --max-scan-points (ingest/large_scan.h): runs of records read
// as files of their own give the whole file's points; the voxel centroids
// equal a brute-force grouping of every point at the voxel size found, which
// is the finest power of two keeping at most the limit; the result does not
// depend on the run length; a truncated file is refused with its byte.
#include "core/file_io.h"
#include "ingest/ingest.h"
#include "ingest/large_scan.h"
#include "ingest/readers.h"
#include "tests/test_support.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <gtest/gtest.h>
#include <pcl/io/lzf.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <set>
#include <string>

namespace apo {
namespace {
namespace fs = std::filesystem;

// Points on a wavy sheet with noise, far from zero (a georeferenced tile), with
// normals, colours and intensities: the sheet keeps the voxels of a surface.
Scan wavySheet(std::size_t count, std::uint64_t seed) {
  std::mt19937_64 random(seed);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  Scan scan;
  scan.origin = {500000.0, 4000000.0, 100.0};
  for (std::size_t i = 0; i < count; ++i) {
    const double x = 40.0 * unit(random), y = 30.0 * unit(random);
    const double z = std::sin(x * 0.3) * std::cos(y * 0.2) + 0.01 * unit(random);
    scan.points.positions.emplace_back(static_cast<float>(x - 20.0), static_cast<float>(y - 15.0), static_cast<float>(z));
    scan.points.normals.emplace_back(0.0f, 0.0f, 1.0f);
    scan.points.colors.push_back({static_cast<std::uint8_t>(i % 256), 128, 7});
    scan.points.intensities.push_back(static_cast<float>(i % 1000));
  }
  return scan;
}

std::array<double, 3> world(const Scan& scan, std::size_t i) {
  const Vec3f& p = scan.points.positions[i];
  return {scan.origin[0] + p.x(), scan.origin[1] + p.y(), scan.origin[2] + p.z()};
}

using Key = std::array<std::int64_t, 3>;
struct Sum {
  std::array<double, 3> position{};
  std::uint64_t count = 0;
};

// Every point of the scan grouped by voxel of `size`, brute force.
std::map<Key, Sum> groupByVoxel(const Scan& scan, double size) {
  std::map<Key, Sum> voxels;
  for (std::size_t i = 0; i < scan.points.size(); ++i) {
    const auto p = world(scan, i);
    Sum& sum = voxels[{static_cast<std::int64_t>(std::floor(p[0] / size)), static_cast<std::int64_t>(std::floor(p[1] / size)),
                       static_cast<std::int64_t>(std::floor(p[2] / size))}];
    for (int axis = 0; axis < 3; ++axis) sum.position[axis] += p[axis];
    ++sum.count;
  }
  return voxels;
}

large_scan::PointRuns open(const fs::path& path) {
  auto file = large_scan::openPointRuns(path, *formatFromExtension(path), 0);
  EXPECT_TRUE(file.ok()) << (file ? "" : file.error().message);
  EXPECT_TRUE(file && file->has_value());
  return **file;
}

template <class T>
void appendRaw(std::string& out, T value) {
  out.append(reinterpret_cast<const char*>(&value), sizeof(T));
}

// A sensor above the sheet, in the file's coordinates.
constexpr std::array<double, 3> kSheetSensor = {500010.0, 4000005.0, 150.0};

enum class PcdData { Ascii, Binary, Compressed };

// The scan as PCL writes a PCD of one row (no PCD writer of ours): world
// coordinates in doubles, normals, packed colour, intensity, and a VIEWPOINT
// at kSheetSensor; ASCII, binary, or binary_compressed (LZF by PCL's own
// compressor, the values field by field, with a 4-byte padding field "_" in
// the header, as PCL pads records, which the compressed body leaves out).
bool writePcd(const fs::path& path, const Scan& scan, PcdData data) {
  const PointSet& points = scan.points;
  const bool compressed = data == PcdData::Compressed;
  std::string bytes = "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\n";
  bytes += compressed ? "FIELDS x y z normal_x normal_y normal_z _ rgb intensity\nSIZE 8 8 8 4 4 4 1 4 4\n"
                        "TYPE F F F F F F U U F\nCOUNT 1 1 1 1 1 1 4 1 1\n"
                      : "FIELDS x y z normal_x normal_y normal_z rgb intensity\nSIZE 8 8 8 4 4 4 4 4\n"
                        "TYPE F F F F F F U F\nCOUNT 1 1 1 1 1 1 1 1\n";
  const char* encoding = data == PcdData::Ascii ? "ascii" : data == PcdData::Binary ? "binary" : "binary_compressed";
  bytes += fmt::format("WIDTH {}\nHEIGHT 1\nVIEWPOINT {} {} {} 1 0 0 0\nPOINTS {}\nDATA {}\n", points.size(),
                       kSheetSensor[0], kSheetSensor[1], kSheetSensor[2], points.size(), encoding);
  const auto rgbOf = [&](std::size_t i) {
    const Rgb8& c = points.colors[i];
    return (std::uint32_t{c.r} << 16) | (std::uint32_t{c.g} << 8) | std::uint32_t{c.b};
  };
  std::array<std::string, 8> fields;  // field by field, for the compressed body
  for (std::size_t i = 0; i < points.size(); ++i) {
    const auto p = world(scan, i);
    const Vec3f& n = points.normals[i];
    if (data == PcdData::Ascii) {
      bytes += fmt::format("{:.6f} {:.6f} {:.6f} {} {} {} {} {}\n", p[0], p[1], p[2], n.x(), n.y(), n.z(), rgbOf(i),
                           points.intensities[i]);
      continue;
    }
    std::array<std::string*, 8> out;
    for (std::size_t f = 0; f < 8; ++f) out[f] = compressed ? &fields[f] : &bytes;
    for (int axis = 0; axis < 3; ++axis) appendRaw(*out[axis], p[axis]);
    for (int axis = 0; axis < 3; ++axis) appendRaw(*out[3 + axis], n[axis]);
    appendRaw(*out[6], rgbOf(i));
    appendRaw(*out[7], points.intensities[i]);
  }
  if (compressed) {
    std::string plain;
    for (const std::string& field : fields) plain += field;
    std::string lzf(plain.size() * 2 + 64, '\0');
    const unsigned size = pcl::lzfCompress(plain.data(), static_cast<unsigned>(plain.size()), lzf.data(),
                                           static_cast<unsigned>(lzf.size()));
    if (size == 0) return false;
    appendRaw(bytes, static_cast<std::uint32_t>(size));
    appendRaw(bytes, static_cast<std::uint32_t>(plain.size()));
    bytes += lzf.substr(0, size);
  }
  return writeFileAtomically(path, bytes).ok();
}

// The scan as CloudCompare exports a CSV: a header behind "//", world
// coordinates, normals, colours, intensity; a comment and a blank line among
// the points (readers skip them: runs count points, not lines).
bool writeCsv(const fs::path& path, const Scan& scan) {
  const PointSet& points = scan.points;
  std::string text = "//X,Y,Z,Nx,Ny,Nz,R,G,B,Intensity\n";
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (i == 1000) text += "# the second station\n\n";
    const auto p = world(scan, i);
    const Vec3f& n = points.normals[i];
    const Rgb8& c = points.colors[i];
    text += fmt::format("{:.5f},{:.5f},{:.5f},{},{},{},{},{},{},{}\n", p[0], p[1], p[2], n.x(), n.y(), n.z(), c.r, c.g,
                        c.b, points.intensities[i]);
  }
  return writeFileAtomically(path, text).ok();
}

// Binary PLY, LAS, LAZ (LASzip compressor 2, chunks of 50,000 points),
// binary PCD, CSV, ASCII PLY, ASCII PCD, E57 and binary_compressed PCD
// ("zpcd").
class LargeScanTest : public ::testing::TestWithParam<std::string> {
 protected:
  // The sheet written in the parameter's format (world coordinates in the
  // file but for ASCII PLY, whose apo_origin comment gives them).
  fs::path writeSheet(const Scan& scan) {
    const std::string extension = GetParam() == "asciiply"                               ? "ply"
                                  : GetParam() == "asciipcd" || GetParam() == "zpcd" ? "pcd"
                                                                                     : GetParam();
    const fs::path path = test::freshTempDir() / ("sheet." + extension);
    const bool written = GetParam() == "ply"        ? writePly(path, scan, /*worldCoordinates=*/true).ok()
                         : GetParam() == "asciiply" ? writePlyAscii(path, scan).ok()
                         : GetParam() == "pcd"      ? writePcd(path, scan, PcdData::Binary)
                         : GetParam() == "asciipcd" ? writePcd(path, scan, PcdData::Ascii)
                         : GetParam() == "zpcd"     ? writePcd(path, scan, PcdData::Compressed)
                         : GetParam() == "csv" ? writeCsv(path, scan)
                         : GetParam() == "e57" ? writeE57(path, scan).ok()
                                               : writeLas(path, scan, /*compressed=*/GetParam() == "laz").ok();
    EXPECT_TRUE(written);
    return path;
  }
};

TEST_P(LargeScanTest, RunsReadAsTheWholeFile) {
  const Scan sheet = wavySheet(120000, 1);
  const fs::path path = writeSheet(sheet);
  const large_scan::PointRuns file = open(path);
  ASSERT_EQ(file.count, 120000u);
  auto whole = readScan(path);
  ASSERT_TRUE(whole.ok());
  std::size_t compared = 0, runs = 0;
  auto notes = file.read(35000, [&](Scan& run) {
    // Records come in runs of the length asked; LAZ in whole chunks of 50,000.
    EXPECT_EQ(run.points.size(), std::min<std::size_t>(GetParam() == "laz" ? 50000 : 35000, 120000 - compared));
    ++runs;
    for (std::size_t i = 0; i < run.points.size(); ++i, ++compared) {
      const auto a = world(run, i), b = world(*whole, compared);
      for (int axis = 0; axis < 3; ++axis) ASSERT_NEAR(a[axis], b[axis], 1e-3) << "point " << compared;
      ASSERT_EQ(run.points.colors[i], whole->points.colors[compared]);
      ASSERT_EQ(run.points.intensities[i], whole->points.intensities[compared]);
    }
  });
  ASSERT_TRUE(notes.ok()) << notes.error().message;
  EXPECT_EQ(compared, 120000u);
  EXPECT_EQ(runs, GetParam() == "laz" ? 3u : 4u);
  if (GetParam() == "laz") {
    EXPECT_NE(notes->front().find("decompressed from LAZ"), std::string::npos);
  }
}

TEST_P(LargeScanTest, CentroidsAreEveryPointGroupedAtTheFinestVoxelWithinTheLimit) {
  const Scan sheet = wavySheet(60000, 2);
  const fs::path path = writeSheet(sheet);
  auto whole = readScan(path);
  ASSERT_TRUE(whole.ok());
  const std::uint64_t limit = 4000;
  auto subsample = large_scan::voxelSubsample(open(path), limit, 7000, nullptr);
  ASSERT_TRUE(subsample.ok()) << subsample.error().message;
  EXPECT_EQ(subsample->pointsRead, 60000u);
  EXPECT_EQ(subsample->nonFinite, 0u);
  EXPECT_EQ(subsample->runs, 1u);  // runs hold kStartPoints at least
  // The voxel is a power of two, within the limit, and the next finer one is not.
  const double size = subsample->voxelSize;
  EXPECT_EQ(std::exp2(std::round(std::log2(size))), size);
  const auto voxels = groupByVoxel(*whole, size);
  EXPECT_LE(voxels.size(), limit);
  EXPECT_GT(groupByVoxel(*whole, size / 2).size(), limit);
  // Each centroid is its voxel's, brute force.
  ASSERT_EQ(subsample->scan.points.size(), voxels.size());
  std::size_t i = 0;
  for (const auto& [key, sum] : voxels) {
    const auto centroid = world(subsample->scan, i++);
    for (int axis = 0; axis < 3; ++axis)
      ASSERT_NEAR(centroid[axis], sum.position[axis] / static_cast<double>(sum.count), 1e-3) << "voxel " << i;
  }
  // Averaged attributes: the sheet's normals (PLY, PCD and CSV hold them, LAS does not) all point up.
  if (GetParam() != "las" && GetParam() != "laz") {
    ASSERT_EQ(subsample->scan.points.normals.size(), voxels.size());
    EXPECT_GT(subsample->scan.points.normals.front().normalized().z(), 0.999f);
  }
  ASSERT_EQ(subsample->scan.points.colors.size(), voxels.size());
  // A PCD's VIEWPOINT comes with the centroids, in their frame.
  if (GetParam() == "pcd" || GetParam() == "asciipcd" || GetParam() == "zpcd") {
    ASSERT_TRUE(subsample->scan.viewpoint.has_value());
    for (int axis = 0; axis < 3; ++axis)
      EXPECT_NEAR(subsample->scan.origin[axis] + subsample->scan.viewpoint->origin[axis], kSheetSensor[axis], 1e-3);
    EXPECT_FALSE(subsample->scan.viewpoint->isFormatDefault);
  } else {
    EXPECT_FALSE(subsample->scan.viewpoint.has_value());
  }
}

TEST_P(LargeScanTest, SameCentroidsWhateverTheRunLength) {
  const fs::path path = writeSheet(wavySheet(150000, 3));
  const large_scan::PointRuns file = open(path);
  auto a = large_scan::voxelSubsample(file, 3000, 1000, nullptr);
  auto b = large_scan::voxelSubsample(file, 3000, 150000, nullptr);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_GT(a->runs, b->runs);
  EXPECT_EQ(a->voxelSize, b->voxelSize);
  EXPECT_EQ(a->scan.origin, b->scan.origin);
  EXPECT_EQ(a->scan.points.positions, b->scan.points.positions);
  EXPECT_EQ(a->scan.points.colors, b->scan.points.colors);
}

TEST_P(LargeScanTest, TruncatedFileIsRefusedWithItsByte) {
  const fs::path path = writeSheet(wavySheet(3000, 4));
  auto bytes = readFileBytes(path);
  ASSERT_TRUE(bytes.ok());
  const fs::path cut = path.parent_path() / ("cut" + path.extension().string());
  test::writeBytes(cut, std::string_view(*bytes).substr(0, bytes->size() - 100));
  if (GetParam() == "e57") {
    // Its XML, which declares the points, is its last section: read whole,
    // which refuses it.
    auto file = large_scan::openPointRuns(cut, ScanFormat::E57, 0);
    ASSERT_TRUE(file.ok());
    EXPECT_FALSE(file->has_value());
    auto whole = readScan(cut);
    ASSERT_FALSE(whole.ok());
    EXPECT_NE(whole.error().message.find("byte 16: the header gives the file's length as"), std::string::npos)
        << whole.error().message;
    return;
  }
  auto subsample = large_scan::voxelSubsample(open(cut), 1000, 1000, nullptr);
  ASSERT_FALSE(subsample.ok());
  EXPECT_EQ(subsample.error().kind, ErrorKind::BadInput);
  EXPECT_NE(subsample.error().message.find(cut.string()), std::string::npos);
  const char* expected = GetParam() == "laz"   ? "LAZ chunk"
                         : GetParam() == "csv" ? "line 3002: expected 10 columns"  // the cut line: a header, a comment, a blank, 2999 points
                         : GetParam() == "asciiply" ? "line 3015: the file ends after 2999 of the 3000 points"  // 16 header lines
                         : GetParam() == "asciipcd" ? "line 3010: the file ends after 2999 of the 3000 points"  // 11 header lines
                         : GetParam() == "zpcd" ? "runs past the end of the file"
                                               : "the file ends inside point record";
  const bool named = subsample.error().message.find(expected) != std::string::npos;
  EXPECT_TRUE(named) << subsample.error().message;
}

INSTANTIATE_TEST_SUITE_P(Formats, LargeScanTest,
                         ::testing::Values("ply", "las", "laz", "pcd", "csv", "asciiply", "asciipcd", "e57", "zpcd"),
                         [](const auto& info) { return info.param; });

TEST(LargeScan, PlyMeshesAreReadWhole) {
  const fs::path dir = test::freshTempDir();
  Scan sheet = wavySheet(100, 5);
  sheet.triangles.push_back({0, 1, 2});
  ASSERT_TRUE(writePly(dir / "mesh.ply", sheet).ok());
  ASSERT_TRUE(writePlyAscii(dir / "ascii-mesh.ply", sheet).ok());
  for (const char* name : {"mesh.ply", "ascii-mesh.ply"}) {
    auto file = large_scan::openPointRuns(dir / name, ScanFormat::Ply, 0);
    ASSERT_TRUE(file.ok());
    EXPECT_FALSE(file->has_value()) << name;
  }
}

// An ASCII PLY's lines beyond its header's count are refused, and so are
// too few, naming the file's line; an error inside a later run names the
// file's line and vertex.
TEST(LargeScan, AsciiPlyRunsAreCheckedAgainstTheHeadersCount) {
  const fs::path dir = test::freshTempDir();
  std::string body;
  for (int i = 0; i < 3000; ++i) body += fmt::format("{} {} 1\n", i, i % 5);
  const std::string header = "ply\nformat ascii 1.0\nelement vertex 3000\nproperty float x\nproperty float y\n"
                             "property float z\nend_header\n";  // 7 lines
  auto readAll = [&](const std::string& name, const std::string& text) {
    test::writeBytes(dir / name, text);
    auto file = large_scan::openPointRuns(dir / name, ScanFormat::Ply, 0);
    EXPECT_TRUE(file.ok() && file->has_value());
    std::uint64_t points = 0;
    auto read = (*file)->read(1000, [&](Scan& run) { points += run.points.size(); });
    return read.ok() ? fmt::format("{} points", points) : read.error().message;
  };
  EXPECT_EQ(readAll("exact.ply", header + body), "3000 points");
  EXPECT_NE(readAll("more.ply", header + body + "7 7 7\n").find("line 3008: unexpected data after the last element"),
            std::string::npos);
  EXPECT_NE(readAll("fewer.ply", header + body.substr(0, body.rfind("2999 "))).find("line 3006: the file ends after 2999 of the 3000"),
            std::string::npos);
  std::string bad = body;
  bad.replace(bad.find("2500 "), 4, "25z0");
  EXPECT_NE(readAll("bad.ply", header + bad).find("line 2508: non-numeric token '25z0' in vertex 2500"),
            std::string::npos);
}

// An organised PCD (its grid is triangulated whole) and a compressed one
// are read whole; the same points in one row, binary or ASCII, in runs.
TEST(LargeScan, OrganisedPcdsAreReadWhole) {
  const fs::path dir = test::freshTempDir();
  const std::string head = "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n";
  std::string records;
  for (int i = 0; i < 4; ++i)
    for (const float v : {static_cast<float>(i), 1.0f, 2.0f}) appendRaw(records, v);
  test::writeBytes(dir / "ascii.pcd", head + "WIDTH 4\nHEIGHT 1\nPOINTS 4\nDATA ascii\n0 1 2\n1 1 2\n2 1 2\n3 1 2\n");
  test::writeBytes(dir / "organised.pcd", head + "WIDTH 2\nHEIGHT 2\nPOINTS 4\nDATA binary\n" + records);
  test::writeBytes(dir / "organised-ascii.pcd", head + "WIDTH 2\nHEIGHT 2\nPOINTS 4\nDATA ascii\n0 1 2\n1 1 2\n2 1 2\n3 1 2\n");
  test::writeBytes(dir / "compressed.pcd", head + "WIDTH 4\nHEIGHT 1\nPOINTS 4\nDATA binary_compressed\n");
  test::writeBytes(dir / "row.pcd", head + "WIDTH 4\nHEIGHT 1\nPOINTS 4\nDATA binary\n" + records);
  for (const std::string name : {"ascii.pcd", "organised.pcd", "organised-ascii.pcd", "compressed.pcd", "row.pcd"}) {
    auto file = large_scan::openPointRuns(dir / name, ScanFormat::Pcd, 0);
    ASSERT_TRUE(file.ok()) << file.error().message;
    EXPECT_EQ(file->has_value(), name != "organised.pcd" && name != "organised-ascii.pcd") << name;
  }
}

// An ASCII PCD's bad value in a later run names the file's line and point.
TEST(LargeScan, AsciiPcdRunsNameTheFilesLineAndPoint) {
  const fs::path dir = test::freshTempDir();
  std::string text = "VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 3000\nHEIGHT 1\n"
                     "POINTS 3000\nDATA ascii\n";  // 9 lines
  for (int i = 0; i < 3000; ++i) text += fmt::format("{} {} 1\n", i == 2500 ? std::string("2q00") : std::to_string(i), i % 5);
  test::writeBytes(dir / "bad.pcd", text);
  auto file = large_scan::openPointRuns(dir / "bad.pcd", ScanFormat::Pcd, 0);
  ASSERT_TRUE(file.ok() && file->has_value());
  auto read = (*file)->read(1000, [](Scan&) {});
  ASSERT_FALSE(read.ok());
  EXPECT_NE(read.error().message.find("line 2510: non-numeric token '2q00' in point 2500"), std::string::npos)
      << read.error().message;
}

// A coordinate of 10^38 (a corrupt file) after the first points has no voxel
// key in 64 bits: it is counted with the non-finite points, not cast into one.
TEST(LargeScan, AFarOutlierIsCountedNotKeyed) {
  Scan sheet = wavySheet(large_scan::kStartPoints + 2000, 7);
  sheet.origin = {0.0, 0.0, 0.0};
  sheet.points.positions.emplace_back(1e38f, 0.0f, 0.0f);
  sheet.points.normals.emplace_back(0.0f, 0.0f, 1.0f);
  sheet.points.colors.push_back({});
  sheet.points.intensities.push_back(0.0f);
  const fs::path path = test::freshTempDir() / "far.ply";
  ASSERT_TRUE(writePly(path, sheet).ok());
  auto subsample = large_scan::voxelSubsample(open(path), 1000, 1000, nullptr);
  ASSERT_TRUE(subsample.ok()) << subsample.error().message;
  EXPECT_EQ(subsample->pointsRead, large_scan::kStartPoints + 2001);
  EXPECT_EQ(subsample->nonFinite, 1u);
  EXPECT_LE(subsample->scan.points.size(), 1000u);
}

// The sheet as two scans, from two positions above it, each about half of
// it (split off the voxels' boundaries), without normals.
Scan twoStationSheet(std::size_t count, std::uint64_t seed) {
  Scan scan = wavySheet(count, seed);
  scan.points.normals.clear();
  for (const char* name : {"west", "east"}) {
    ScanStation station;
    station.name = name;
    station.position = Vec3f(scan.stations.empty() ? -10.0f : 10.0f, 0.0f, 30.0f);
    station.hasPose = true;
    scan.stations.push_back(station);
  }
  for (const Vec3f& p : scan.points.positions) scan.points.stations.push_back(p.x() < 0.3f ? 0 : 1);
  return scan;
}

TEST(LargeScan, E57RunsKeepEveryScanPositionAndEachCentroidOneOfItsPoints) {
  const Scan sheet = twoStationSheet(80000, 8);
  const fs::path path = test::freshTempDir() / "stations.e57";
  ASSERT_TRUE(writeE57(path, sheet).ok());
  auto whole = readScan(path);
  ASSERT_TRUE(whole.ok()) << whole.error().message;
  ASSERT_EQ(whole->stations.size(), 2u);
  // Runs cut inside the first scan and across the two: the same points, the
  // same scan of each, the same stations and notes in every run.
  std::size_t compared = 0;
  auto notes = open(path).read(30000, [&](Scan& run) {
    EXPECT_EQ(run.readNotes, whole->readNotes);
    ASSERT_EQ(run.stations.size(), 2u);
    ASSERT_EQ(run.points.stations.size(), run.points.size());
    for (std::size_t i = 0; i < run.points.size(); ++i, ++compared) {
      ASSERT_EQ(run.points.stations[i], whole->points.stations[compared]) << "point " << compared;
      ASSERT_EQ(run.points.positions[i], whole->points.positions[compared]) << "point " << compared;
      ASSERT_EQ(run.points.colors[i], whole->points.colors[compared]) << "point " << compared;
    }
  });
  ASSERT_TRUE(notes.ok()) << notes.error().message;
  EXPECT_EQ(compared, 80000u);
  // The centroids keep both positions, in their own frame, and each one the
  // scan of one of its voxel's points.
  auto subsample = large_scan::voxelSubsample(open(path), 3000, 7000, nullptr);
  ASSERT_TRUE(subsample.ok()) << subsample.error().message;
  const Scan& centroids = subsample->scan;
  ASSERT_EQ(centroids.stations.size(), 2u);
  for (std::size_t s = 0; s < 2; ++s) {
    EXPECT_EQ(centroids.stations[s].name, whole->stations[s].name);
    for (int axis = 0; axis < 3; ++axis)
      EXPECT_NEAR(centroids.origin[axis] + centroids.stations[s].position[axis],
                  whole->origin[axis] + whole->stations[s].position[axis], 1e-3);
  }
  std::map<Key, std::set<std::uint16_t>> scansOf;
  const double size = subsample->voxelSize;
  for (std::size_t i = 0; i < whole->points.size(); ++i) {
    const auto p = world(*whole, i);
    scansOf[{static_cast<std::int64_t>(std::floor(p[0] / size)), static_cast<std::int64_t>(std::floor(p[1] / size)),
             static_cast<std::int64_t>(std::floor(p[2] / size))}]
        .insert(whole->points.stations[i]);
  }
  ASSERT_EQ(centroids.points.stations.size(), scansOf.size());
  std::size_t i = 0, mixed = 0;
  std::array<std::size_t, 2> perScan{};
  for (const auto& [key, scans] : scansOf) {
    const std::uint16_t scan = centroids.points.stations[i++];
    ASSERT_TRUE(scans.count(scan)) << "voxel " << i;
    ++perScan[scan];
    mixed += scans.size() > 1;
  }
  EXPECT_GT(perScan[0], 500u);
  EXPECT_GT(perScan[1], 500u);
  EXPECT_GT(mixed, 0u);  // voxels on the seam hold points of both
  // Ingest above the limit orients the centroids' normals towards their scans.
  IngestOptions options;
  options.maxScanPoints = 3000;
  auto ingested = ingestScan(path, test::checked(options));
  ASSERT_TRUE(ingested.ok()) << ingested.error().message;
  EXPECT_TRUE(ingested->report.largeScan.subsampled);
  const auto json = nlohmann::json::parse(ingestReportJson(ingested->report));
  EXPECT_EQ(json["normals"]["orientation"], "scan_positions") << json["normals"].dump();
  const std::vector<std::string>& ingestNotes = ingested->report.readNotes;
  EXPECT_TRUE(std::any_of(ingestNotes.begin(), ingestNotes.end(), [](const std::string& note) {
    return note.find("each voxel given the scan position of one of its points") != std::string::npos;
  }));
}

TEST(LargeScan, IngestReadsAScanAboveTheLimitIntoCentroidsAndSaysSo) {
  const fs::path dir = test::freshTempDir();
  ASSERT_TRUE(writePly(dir / "sheet.ply", wavySheet(20000, 6), true).ok());
  IngestOptions options;
  options.maxScanPoints = 1500;
  auto result = ingestScan(dir / "sheet.ply", test::checked(options));
  ASSERT_TRUE(result.ok()) << result.error().message;
  const IngestReport& report = result->report;
  EXPECT_TRUE(report.largeScan.subsampled);
  EXPECT_EQ(report.pointsIn, 20000u);
  EXPECT_EQ(report.largeScan.pointsInFile, 20000u);
  EXPECT_LE(report.largeScan.kept, 1500u);
  EXPECT_GT(report.largeScan.kept, 1500u / 4);  // a halving of a surface's voxels keeps about a quarter
  EXPECT_LE(result->scan.points.size(), report.largeScan.kept);
  const auto json = nlohmann::json::parse(ingestReportJson(report));
  EXPECT_EQ(json["large_scan"]["points_in_file"], 20000);
  EXPECT_EQ(json["large_scan"]["voxel_centroids"], report.largeScan.kept);
  // Under the limit: read whole, no large_scan.
  options.maxScanPoints = 20000;
  auto whole = ingestScan(dir / "sheet.ply", test::checked(options));
  ASSERT_TRUE(whole.ok());
  EXPECT_FALSE(whole->report.largeScan.subsampled);
  EXPECT_TRUE(nlohmann::json::parse(ingestReportJson(whole->report))["large_scan"].is_null());
}

TEST(LargeScan, LimitBelowAThousandIsAUsageError) {
  IngestOptions options;
  options.maxScanPoints = 999;
  auto checked = check(options);
  ASSERT_FALSE(checked.ok());
  EXPECT_EQ(checked.error().kind, ErrorKind::Usage);
  EXPECT_NE(checked.error().message.find("--max-scan-points"), std::string::npos);
  options.maxScanPoints = 0;
  EXPECT_TRUE(check(options).ok());
}

}  // namespace
}  // namespace apo
