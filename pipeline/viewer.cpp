// The scene of the report's interactive view (report.h viewerHtml): render/
// gives the shaders and the geometry as WebGL2 takes them; M is cut down to
// what a page can carry (pipeline.h kViewerMostTriangles, kViewerMostPoints).
#include "pipeline/pipeline.h"

#include "core/text.h"

#include <fmt/format.h>

namespace apo {
namespace {

// M, or a preview of it small enough for the page, with what it is.
Result<ViewerGeometry> detailGeometry(const Scan& detail) {
  if (!detail.isMesh()) return webglPoints(detail.points, kViewerMostPoints);
  if (detail.triangles.size() <= kViewerMostTriangles) {
    ViewerGeometry g = webglMesh(detail);
    g.description = fmt::format("M, {} triangles", groupedDigits(detail.triangles.size()));
    return g;
  }
  auto preview = previewMesh(detail, kViewerMostTriangles);
  if (!preview) return preview.error();
  ViewerGeometry g = webglMesh(*preview);
  g.description = fmt::format("M simplified for the viewer: {} of its {} triangles", groupedDigits(preview->triangles.size()),
                              groupedDigits(detail.triangles.size()));
  return g;
}

// m's extent about the first view's target, for the viewer's near and far
// planes once the eye moves.
float radiusAbout(const Scan& coarse, const Vec3f& centre) {
  float radius = 0.0f;
  for (const Vec3f& p : coarse.points.positions) radius = std::max(radius, (p - centre).norm());
  return radius > 0.0f ? radius : 1.0f;
}

}  // namespace

Result<ViewerScene> viewerScene(const Scan& coarse, const ApoTexture& apo, const Scan* detail,
                                const std::vector<Camera>& views, const RenderOptions& options) {
  ViewerScene scene;
  scene.shaders = webglShaders();
  setWebglApo(apo, scene);
  scene.coarse = webglMesh(coarse);
  scene.coarse.description = fmt::format("m, {} triangles", groupedDigits(coarse.triangles.size()));
  if (detail) {
    auto geometry = detailGeometry(*detail);
    if (!geometry) return geometry.error();
    scene.detail = std::move(*geometry);
  }
  scene.views = views;
  scene.mipmapping = options.mipmapping;
  scene.filtering = options.filtering;
  scene.heatMapDegrees = kHeatMapDegrees;
  scene.boundingRadius = radiusAbout(coarse, views.empty() ? Vec3f::Zero() : views.front().target);
  return scene;
}

}  // namespace apo
