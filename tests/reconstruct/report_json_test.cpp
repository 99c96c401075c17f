#include "reconstruct/reconstruct.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace apo {
namespace {

TEST(ReconstructReportJson, CarriesEveryFigure) {
  ReconstructReport report;
  report.method = "poisson";
  report.pointsIn = 1000;
  report.pointsUsed = 800;
  report.trimmedTriangles = 12;
  report.quality.components = 1;
  report.quality.eulerCharacteristic = 2;
  report.pointToMeshP95 = 0.004;
  const auto json = nlohmann::json::parse(reconstructReportJson(report));
  EXPECT_EQ(json["format_version"], 1);
  EXPECT_EQ(json["method"], "poisson");
  EXPECT_EQ(json["points"]["subsampled"], true);
  EXPECT_EQ(json["trimmed"]["triangles"], 12);
  EXPECT_EQ(json["mesh"]["euler_characteristic"], 2);
  EXPECT_DOUBLE_EQ(json["points_to_mesh"]["p95"].get<double>(), 0.004);
}

TEST(SimplifyReportJson, CarriesEveryFigure) {
  SimplifyReport report;
  report.policy = "garland-heckbert";
  report.facesIn = 75000;
  report.targetFaces = 3000;
  report.facesOut = 2999;
  report.hausdorff = 0.01;
  const auto json = nlohmann::json::parse(simplifyReportJson(report));
  EXPECT_EQ(json["faces"]["out"], 2999);
  EXPECT_EQ(json["faces"]["target"], 3000);
  EXPECT_DOUBLE_EQ(json["distance_to_input"]["hausdorff"].get<double>(), 0.01);
}

}  // namespace
}  // namespace apo
