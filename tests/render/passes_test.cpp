// The passes on the bumpy sphere: the GLSL walk lands on the same node as
// bake/'s CPU walk on every covered pixel.
#include "render/render.h"

#include "tests/bake/bumpy_sphere.h"
#include "tests/test_support.h"

#include <gtest/gtest.h>


namespace apo {
namespace {

class BumpySphereRender : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    detail_ = new Scan(test::BumpySphere().mesh(6));
    coarse_ = new Scan(test::makeIcosphere(3));
    auto bake = bakeApo(*detail_, *coarse_, BakeOptions{});  // the default settings
    ASSERT_TRUE(bake.ok()) << bake.error().message;
    texture_ = new ApoTexture(std::move(bake->texture));
  }
  static void TearDownTestSuite() {
    delete texture_;
    delete coarse_;
    delete detail_;
  }
  static Scan* detail_;
  static Scan* coarse_;
  static ApoTexture* texture_;
};

Scan* BumpySphereRender::detail_ = nullptr;
Scan* BumpySphereRender::coarse_ = nullptr;
ApoTexture* BumpySphereRender::texture_ = nullptr;

TEST_F(BumpySphereRender, GlslWalkAgreesWithTheCpuWalkOnEveryPixel) {
  auto agreement = compareWalkWithCpu(*coarse_, *texture_, 256, 14);
  ASSERT_TRUE(agreement.ok()) << agreement.error().message;
  EXPECT_GT(agreement->pixels, 14u * 14000u);
  EXPECT_EQ(agreement->mismatches, 0u);
}

TEST_F(BumpySphereRender, EveryViewHasItsThreePassesOverTheSameSilhouette) {
  RenderOptions options;
  options.size = 128;
  auto views = renderViews(detail_, *coarse_, *texture_, options);
  ASSERT_TRUE(views.ok()) << views.error().message;
  ASSERT_EQ(views->size(), 14u);
  for (const ViewImages& view : *views) {
    // The baseline and the APO pass draw the same m: same pixels covered.
    const ImageMetrics same = compareImages(view.apo.shaded, view.baseline.shaded, view.apo.normals, view.baseline.normals);
    EXPECT_GT(same.pixels, 3000u);
    EXPECT_EQ(same.silhouetteMismatch, 0.0);
    // M is m plus bumps of 4% of the radius: nearly the same silhouette.
    const ImageMetrics reference =
        compareImages(view.baseline.shaded, view.reference.shaded, view.baseline.normals, view.reference.normals);
    EXPECT_LT(reference.silhouetteMismatch, 0.1);
  }
}

// Mean angle between the APO pass's normals and the reference's, all views.
double meanApoError(const std::vector<ViewImages>& views) {
  std::vector<float> all;
  for (const ViewImages& view : views) {
    std::vector<float> angles;
    angularErrors(view.apo.normals, view.reference.normals, &angles);
    all.insert(all.end(), angles.begin(), angles.end());
  }
  return statsOfAngles(all).mean;
}

TEST_F(BumpySphereRender, TrilinearFilteringFollowsMsSmoothNormalsCloser) {
  // Unfiltered, each leaf is one flat normal; on the sphere's smooth parts the
  // interpolated reference turns inside every leaf (measured: 1.6 degrees
  // mean unfiltered, 0.7 filtered, at the default bake settings).
  RenderOptions options;
  options.size = 128;
  auto flat = renderViews(detail_, *coarse_, *texture_, options);
  options.filtering = true;
  auto filtered = renderViews(detail_, *coarse_, *texture_, options);
  ASSERT_TRUE(flat.ok() && filtered.ok());
  EXPECT_LT(meanApoError(*filtered), 0.6 * meanApoError(*flat));
}

}  // namespace
}  // namespace apo
