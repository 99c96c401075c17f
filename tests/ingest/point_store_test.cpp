// A large scan's every point in its store (ingest.h, PointStore): every
// finite point of the file, once; a box gives exactly the points inside it
// (brute force), in the store's one order; the normals follow the surface's
// analytic normal and the oriented points' side; a complete store is reused,
// a damaged one refused, and a write that fails (a full disk) leaves no store.
#include "ingest/ingest.h"

#include "tests/test_support.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <sys/resource.h>

#include <algorithm>
#include <cmath>
#include <csignal>
#include <filesystem>
#include <limits>
#include <random>

namespace apo {
namespace {
namespace fs = std::filesystem;
using ::testing::HasSubstr;

// A wavy sheet z = sin(0.3 x) cos(0.2 y) with a little noise, and its exact
// upward normal.
Vec3f sheetNormal(const Vec3f& p) {
  const float dx = 0.3f * std::cos(0.3f * p.x()) * std::cos(0.2f * p.y());
  const float dy = -0.2f * std::sin(0.3f * p.x()) * std::sin(0.2f * p.y());
  return Vec3f(-dx, -dy, 1.0f).normalized();
}

Scan wavySheet(std::size_t count) {
  std::mt19937 random(3);
  std::uniform_real_distribution<float> x(-20.0f, 20.0f), y(-15.0f, 15.0f), noise(-0.002f, 0.002f);
  Scan scan;
  for (std::size_t i = 0; i < count; ++i) {
    const float px = x(random), py = y(random);
    scan.points.positions.emplace_back(px, py, std::sin(0.3f * px) * std::cos(0.2f * py) + noise(random));
  }
  return scan;
}

// What ingest would hand the store: a subsample with oriented normals.
Scan orientedSubsample(const Scan& scan) {
  Scan oriented;
  for (std::size_t i = 0; i < scan.points.size(); i += 8) {
    oriented.points.positions.push_back(scan.points.positions[i]);
    oriented.points.normals.push_back(sheetNormal(scan.points.positions[i]));
  }
  return oriented;
}

bool lessXyz(const Vec3f& a, const Vec3f& b) {
  return std::lexicographical_compare(a.data(), a.data() + 3, b.data(), b.data() + 3);
}

class PointStoreTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test::freshTempDir();
    scan_ = wavySheet(120000);
    ASSERT_TRUE(writePly(dir_ / "sheet.ply", scan_).ok());
    oriented_ = orientedSubsample(scan_);
  }
  Result<PointStore> write() { return writePointStore(dir_ / "sheet.ply", oriented_, 16, dir_ / "store"); }

  fs::path dir_;
  Scan scan_, oriented_;
};

TEST_F(PointStoreTest, HoldsEveryPointOnceWithNormalsAlongTheSurface) {
  auto store = write();
  ASSERT_TRUE(store.ok()) << store.error().message;
  EXPECT_EQ(store->size(), scan_.points.size());
  EXPECT_FALSE(store->report().reused);
  Aabb everything;
  everything.min = Vec3f::Constant(-1e30f);
  everything.max = Vec3f::Constant(1e30f);
  auto all = store->pointsIn(everything);
  ASSERT_TRUE(all.ok()) << all.error().message;
  std::vector<Vec3f> stored = all->positions, given = scan_.points.positions;
  std::sort(stored.begin(), stored.end(), lessXyz);
  std::sort(given.begin(), given.end(), lessXyz);
  EXPECT_EQ(stored, given);
  double angle = 0.0;
  std::size_t flipped = 0;
  for (std::size_t i = 0; i < all->size(); ++i) {
    const Vec3f truth = sheetNormal(all->positions[i]);
    const float cosine = std::clamp(all->normals[i].dot(truth), -1.0f, 1.0f);
    flipped += cosine < 0.0f ? 1 : 0;
    angle += std::acos(std::abs(cosine)) * 180.0 / 3.14159265358979;
  }
  EXPECT_EQ(flipped, 0u);
  EXPECT_LT(angle / static_cast<double>(all->size()), 2.0);
  EXPECT_EQ(store->report().unfittedNormals, 0u);
}

TEST_F(PointStoreTest, WithoutAPlaneEachPointTakesItsNearestOrientedPointsNormal) {
  auto store = writePointStore(dir_ / "sheet.ply", oriented_, 0, dir_ / "nearest");
  ASSERT_TRUE(store.ok()) << store.error().message;
  EXPECT_EQ(store->report().neighbours, 0);
  Aabb everything;
  everything.min = Vec3f::Constant(-1e30f);
  everything.max = Vec3f::Constant(1e30f);
  const PointSet all = store->pointsIn(everything).value();
  ASSERT_EQ(all.size(), scan_.points.size());
  // Brute force over a stride of the points: the nearest oriented point's
  // normal (ties in distance aside: a point of the subsample is its own).
  std::size_t differing = 0, checked = 0;
  for (std::size_t i = 0; i < all.size(); i += 97, ++checked) {
    float best = std::numeric_limits<float>::max();
    Vec3f normal = Vec3f::Zero();
    for (std::size_t j = 0; j < oriented_.points.size(); ++j) {
      const float d = (oriented_.points.positions[j] - all.positions[i]).squaredNorm();
      if (d < best) {
        best = d;
        normal = oriented_.points.normals[j];
      }
    }
    differing += (all.normals[i] - normal).norm() > 1e-6f ? 1 : 0;
  }
  EXPECT_GT(checked, 1000u);
  EXPECT_EQ(differing, 0u);
  // Another k is another store: not reused.
  auto fitted = writePointStore(dir_ / "sheet.ply", oriented_, 16, dir_ / "nearest");
  ASSERT_TRUE(fitted.ok());
  EXPECT_FALSE(fitted->report().reused);
  EXPECT_EQ(fitted->report().neighbours, 16);
}

TEST_F(PointStoreTest, ABoxGivesExactlyItsPointsInTheStoresOrder) {
  auto store = write();
  ASSERT_TRUE(store.ok()) << store.error().message;
  Aabb everything;
  everything.min = Vec3f::Constant(-1e30f);
  everything.max = Vec3f::Constant(1e30f);
  const PointSet all = store->pointsIn(everything).value();
  for (const auto& [low, high] : {std::pair{Vec3f(-3, -2, -1), Vec3f(4, 5, 1)}, std::pair{Vec3f(10, -15, -2), Vec3f(20, 0, 0)}}) {
    Aabb box;
    box.min = low;
    box.max = high;
    auto inside = store->pointsIn(box);
    ASSERT_TRUE(inside.ok());
    // Brute force: the whole store's points inside the box, in its order.
    PointSet expected;
    for (std::size_t i = 0; i < all.size(); ++i)
      if ((all.positions[i].array() >= low.array()).all() && (all.positions[i].array() <= high.array()).all()) {
        expected.positions.push_back(all.positions[i]);
        expected.normals.push_back(all.normals[i]);
      }
    EXPECT_GT(expected.size(), 1000u);
    EXPECT_EQ(inside->positions, expected.positions);
    EXPECT_EQ(inside->normals, expected.normals);
  }
}

TEST_F(PointStoreTest, ACompleteStoreIsReusedAndADamagedOneRefused) {
  auto first = write();
  ASSERT_TRUE(first.ok()) << first.error().message;
  auto again = write();
  ASSERT_TRUE(again.ok()) << again.error().message;
  EXPECT_TRUE(again->report().reused);
  EXPECT_EQ(again->size(), first->size());
  fs::resize_file(dir_ / "store" / "normals.bin", 100);
  auto damaged = PointStore::open(dir_ / "store");
  ASSERT_FALSE(damaged.ok());
  EXPECT_EQ(damaged.error().kind, ErrorKind::BadInput);
  EXPECT_THAT(damaged.error().message, HasSubstr("disagree with store.json"));
  // Written anew, not reused, when damaged.
  auto rewritten = write();
  ASSERT_TRUE(rewritten.ok()) << rewritten.error().message;
  EXPECT_FALSE(rewritten->report().reused);
}

TEST_F(PointStoreTest, AWriteThatFailsLeavesNoStoreAndARerunCompletes) {
  // A file-size limit makes the store's writes fail as a full disk does
  // (EFBIG where ENOSPC would be), past the first megabyte.
  std::signal(SIGXFSZ, SIG_IGN);
  rlimit saved{};
  ASSERT_EQ(getrlimit(RLIMIT_FSIZE, &saved), 0);
  rlimit limit = saved;
  limit.rlim_cur = 1 << 20;
  ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &limit), 0);
  auto failed = write();
  ASSERT_EQ(setrlimit(RLIMIT_FSIZE, &saved), 0);
  ASSERT_FALSE(failed.ok());
  EXPECT_EQ(failed.error().kind, ErrorKind::Internal);
  EXPECT_THAT(failed.error().message, HasSubstr("writing the point store"));
  EXPECT_FALSE(fs::exists(dir_ / "store" / "store.json"));
  EXPECT_FALSE(PointStore::open(dir_ / "store").ok());
  auto rerun = write();
  ASSERT_TRUE(rerun.ok()) << rerun.error().message;
  EXPECT_EQ(rerun->size(), scan_.points.size());
}

TEST_F(PointStoreTest, FilesReadWholeAreRefused) {
  Scan mesh = scan_;
  mesh.triangles.push_back({0, 1, 2});
  ASSERT_TRUE(writePly(dir_ / "mesh.ply", mesh).ok());
  auto store = writePointStore(dir_ / "mesh.ply", oriented_, 16, dir_ / "mesh-store");
  ASSERT_FALSE(store.ok());
  EXPECT_EQ(store.error().kind, ErrorKind::BadInput);
  EXPECT_THAT(store.error().message, HasSubstr("PLY of vertices alone"));
}

}  // namespace
}  // namespace apo
