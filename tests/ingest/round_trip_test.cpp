// Every reader against our writer: a scan read from format X, written as PLY
// and read back, is the same scan (positions bit for bit, every attribute,
// every triangle). Fixtures are small files in each format made here, plus
// real files of each format from the datasets.
#include "ingest/ingest.h"

#include "tests/test_support.h"

#include <gtest/gtest.h>

#include <cstring>

namespace apo {
namespace {
namespace fs = std::filesystem;

// Bit for bit, so that NaN coordinates (kept by the readers) compare equal.
bool sameBits(const std::vector<Vec3f>& a, const std::vector<Vec3f>& b) {
  return a.size() == b.size() && std::memcmp(a.data(), b.data(), a.size() * sizeof(Vec3f)) == 0;
}

void expectSameScan(const Scan& a, const Scan& b) {
  EXPECT_TRUE(sameBits(a.points.positions, b.points.positions));
  EXPECT_TRUE(sameBits(a.points.normals, b.points.normals));
  EXPECT_EQ(a.points.colors, b.points.colors);
  EXPECT_EQ(a.points.intensities, b.points.intensities);
  EXPECT_EQ(a.triangles, b.triangles);
}

void expectRoundTrip(const fs::path& input) {
  auto original = readScan(input);
  ASSERT_TRUE(original.ok()) << original.error().message;
  ASSERT_GT(original->points.size(), 0u);
  for (bool binary : {true, false}) {
    const fs::path copy = test::freshTempDir() / (binary ? "copy.ply" : "copy_ascii.ply");
    ASSERT_TRUE((binary ? writePly(copy, *original) : writePlyAscii(copy, *original)).ok());
    auto reread = readScan(copy);
    ASSERT_TRUE(reread.ok()) << reread.error().message;
    expectSameScan(*original, *reread);
  }
}

struct Fixture {
  const char* name;
  const char* bytes;
};

class MadeFixtureRoundTrip : public ::testing::TestWithParam<Fixture> {};

TEST_P(MadeFixtureRoundTrip, ReadWriteReadIsIdentity) {
  const fs::path path = test::freshTempDir() / GetParam().name;
  test::writeBytes(path, GetParam().bytes);
  expectRoundTrip(path);
}

INSTANTIATE_TEST_SUITE_P(
    EachFormat, MadeFixtureRoundTrip,
    ::testing::Values(
        Fixture{"cloud.xyz", "0.1 0.2 0.3\n-1e-3 4 5.5\n7 8 9\n"},
        Fixture{"cloud.xyzn", "0 0 0 0 0 1\n1 0 0 0 1 0\n0 1 0 1 0 0\n"},
        Fixture{"cloud.pts", "2\n1 2 3 0.5 10 20 30\n4 5 6 0.25 40 50 60\n"},
        Fixture{"quad.off", "OFF\n4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n"},
        Fixture{"quad.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1 4//1\n"},
        Fixture{"tri.stl", "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nvertex 0 1 0\n"
                           "endloop\nendfacet\nendsolid t\n"},
        Fixture{"cloud.pcd", "VERSION 0.7\nFIELDS x y z intensity\nSIZE 4 4 4 4\nTYPE F F F F\nCOUNT 1 1 1 1\n"
                             "WIDTH 2\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 2\nDATA ascii\n1 2 3 0.5\n4 5 6 0.75\n"},
        Fixture{"mesh.ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\nproperty double y\n"
                            "property double z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n"
                            "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
                            "0 0 0 255 0 0\n1 0 0 0 255 0\n0 1 0 0 0 255\n3 0 1 2\n"}),
    [](const auto& info) {
      std::string name = info.param.name;
      for (char& c : name)
        if (c == '.') c = '_';
      return name;
    });

class DatasetRoundTrip : public ::testing::TestWithParam<const char*> {};

TEST_P(DatasetRoundTrip, ReadWriteReadIsIdentity) { expectRoundTrip(test::datasetPath(GetParam())); }

INSTANTIATE_TEST_SUITE_P(RealFiles, DatasetRoundTrip,
                         ::testing::Values("pcl/table_scene_mug_stereo_textured.pcd", "cgal/points_3/kitten.xyz",
                                           "cgal/points_3/building.ply", "cgal/meshes/bunny00.off",
                                           "cgal/meshes/pig.stl"),
                         [](const auto& info) {
                           std::string name = fs::path(info.param).stem().string();
                           for (char& c : name)
                             if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
                           return name;
                         });

}  // namespace
}  // namespace apo
