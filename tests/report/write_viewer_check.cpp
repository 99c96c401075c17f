// Writes what tests/report/viewer_check.py compares: OUTDIR/viewer.html of a
// bumpy sphere (M, 81,920 triangles) onto an icosphere (m, 1,280), baked with
// the default settings and seen from the 14 standard views, under a hostile
// scan name; and the OSMesa passes' normal buffers of m with the APO at the
// same views (OUTDIR/expected_{plain,filtered}.f32: per view, rows from the
// top, RGBA float32: normal and coverage), with OUTDIR/expected.json saying
// their size. The static images the viewer falls back on go in a folder whose
// name needs percent-encoding.
#include "pipeline/pipeline.h"
#include "report/report.h"
#include "tests/bake/bumpy_sphere.h"
#include "tests/test_support.h"

#include "core/file_io.h"
#include "core/image_io.h"

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <cstdio>

namespace {

constexpr int kSize = 192;
constexpr const char* kHostileName = "<img src=x onerror=alert(1)></script><!--bumpy.ply";
constexpr const char* kImagesFolder = "render #1 & 'x'";

apo::Status writeExpected(const std::filesystem::path& path, const std::vector<apo::ViewImages>& views) {
  std::string bytes;
  for (const apo::ViewImages& view : views)
    bytes.append(reinterpret_cast<const char*>(view.apo.normals.data.data()), view.apo.normals.data.size() * sizeof(float));
  return apo::writeFileAtomically(path, bytes);
}

apo::Status run(const std::filesystem::path& out) {
  std::filesystem::create_directories(out / kImagesFolder);
  const apo::Scan detail = apo::test::BumpySphere().mesh(6);
  const apo::Scan coarse = apo::test::makeIcosphere(3);
  auto baked = apo::bakeApo(detail, coarse, apo::test::checked(apo::BakeOptions{}));
  if (!baked) return baked.error();
  apo::RenderOptions options;
  options.size = kSize;
  options.timedFrames = 0;
  std::vector<apo::Camera> cameras;
  for (const bool filtering : {false, true}) {
    options.filtering = filtering;
    auto views = apo::renderViews(&detail, coarse, baked->texture, apo::test::checked(options));
    if (!views) return views.error();
    APO_RETURN_IF_ERROR(writeExpected(out / (filtering ? "expected_filtered.f32" : "expected_plain.f32"), *views));
    cameras.clear();
    for (std::size_t i = 0; i < views->size(); ++i) {
      cameras.push_back((*views)[i].camera);
      const apo::Image& shaded = (*views)[i].apo.shaded;
      APO_RETURN_IF_ERROR(apo::writePngRgba8(out / kImagesFolder / fmt::format("view{:02d}_apo.png", i), shaded.width,
                                             shaded.height, shaded.rgba));
    }
  }
  auto scene = apo::viewerScene(coarse, baked->texture, &detail, cameras, options);
  if (!scene) return scene.error();
  std::vector<std::string> images;
  for (std::size_t i = 0; i < cameras.size(); ++i) images.push_back(fmt::format("{}/view{:02d}_apo.png", kImagesFolder, i));
  APO_RETURN_IF_ERROR(apo::writeFileAtomically(out / "viewer.html", apo::viewerHtml(*scene, kHostileName, images)));
  const nlohmann::json expected = {{"size", kSize}, {"views", cameras.size()}, {"name", kHostileName}};
  return apo::writeFileAtomically(out / "expected.json", expected.dump(2));
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: write_viewer_check OUTDIR\n");
    return 1;
  }
  const apo::Status status = run(argv[1]);
  if (!status.ok()) {
    std::fprintf(stderr, "write_viewer_check: %s\n", status.error().message.c_str());
    return 1;
  }
  return 0;
}
