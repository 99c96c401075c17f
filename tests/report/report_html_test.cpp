// report.html and index.html from manifests: escaping of everything that
// comes from a file, percent-encoded image paths, every view's images, a
// failed run's "not run" sections, the charts' bars, the batch index rows,
// and no exception on manifests of unexpected shape.
#include "report/report.h"
#include "render/render.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <fmt/format.h>

#include <string>

namespace apo {
namespace {

// The legend the pages draw is the scale the heat maps were coloured with.
static_assert(kReportHeatMapDegrees == kHeatMapDegrees);

using Json = nlohmann::json;
using ::testing::HasSubstr;
using ::testing::Not;

std::size_t occurrences(const std::string& text, const std::string& what) {
  std::size_t n = 0;
  for (std::size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + what.size())) ++n;
  return n;
}

Json stage(const char* name, const char* status, double seconds = 1.0) {
  return {{"name", name}, {"status", status}, {"seconds", seconds}, {"peak_memory_bytes", 100'000'000}};
}

Json passFigures(double meanDegrees, double mae) {
  return {{"angular_error_degrees", {{"pixels", 1000}, {"mean", meanDegrees}, {"median", meanDegrees * 0.8},
                                     {"p95", meanDegrees * 3}, {"max", 40.0}}},
          {"image", {{"pixels", 1100}, {"mean_absolute_error", mae}, {"psnr_db", 31.5}, {"ssim", 0.93},
                     {"silhouette_mismatch", 0.01}}}};
}

// A run that went through every stage, with `views` rendered views.
Json succeededManifest(const std::string& name, int views) {
  Json m;
  m["format_version"] = 1;
  m["tool"] = {{"name", "apo"}, {"version", "0.6.0"}};
  m["input"] = {{"path", "scans/" + name}, {"name", name}, {"sha256", std::string(64, 'a')}, {"bytes", 123456}};
  m["options"] = {{"detail-source", "mesh"}, {"simplify", {{"faces", "3000"}}}};
  m["status"] = "succeeded";
  m["error"] = nullptr;
  m["stages"] = {stage("ingest", "succeeded"), stage("reconstruct", "succeeded"), stage("simplify", "succeeded"),
                 stage("bake", "succeeded"),   stage("render", "succeeded"),      stage("report", "succeeded")};
  m["results"]["ingest"] = {{"kind", "point_cloud"}, {"counts", {{"points_in", 460400}, {"points_out", 452119}}}};
  m["results"]["reconstruct"] = {{"method", "advancing_front"}, {"mesh", {{"vertices", 600000}, {"triangles", 1204332}}}};
  m["results"]["simplify"] = {{"policy", "gh"}, {"faces", {{"in", 1204332}, {"target", 3000}, {"out", 3000}}}};
  m["results"]["bake"] = {{"nodes", {{"per_depth", {1, 8, 64, 300, 1200, 4000, 9000}}, {"leaves", 11000}, {"internal", 3573}}},
                          {"sampling", {{"rays", 1000000}, {"samples_hit", 990000}, {"samples_fallback", 10000}}},
                          {"texture", {{"width", 2048}, {"height", 128}, {"bytes", 1048576}}},
                          {"seconds", {{"total", 4.2}}},
                          {"peak_memory_bytes", 600000000}};
  Json render;
  render["options"] = {{"size", 512}, {"views", views}, {"mipmapping", true}, {"filtering", false}};
  render["overall"] = {{"apo", {{"pixels", 1000 * views}, {"mean", 2.4}, {"median", 1.9}, {"p95", 7.0}, {"max", 40.0}}},
                       {"baseline", {{"pixels", 1000 * views}, {"mean", 4.8}, {"median", 4.0}, {"p95", 12.0}, {"max", 60.0}}},
                       {"baseline_over_apo", 2.0},
                       {"cost", {{"reference_frame_ms", 12.0}, {"baseline_frame_ms", 1.5}, {"apo_frame_ms", 3.25},
                                 {"apo_texel_fetches", {{"fragments", 90000}, {"mean", 6.5}, {"max", 11}}}}}};
  render["views"] = Json::array();
  for (int i = 0; i < views; ++i)
    render["views"].push_back({{"index", i}, {"eye", {0, 0, 2}}, {"apo", passFigures(2.0 + i, 3.0)},
                               {"baseline", passFigures(5.0 + i, 6.0)}, {"cost", Json::object()}});
  m["results"]["render"] = render;
  m["files"] = {{"m", "m.ply"}, {"apo", "scan.apo"}, {"renders", "render"}, {"report", "report.html"}};
  return m;
}

// A run whose reconstruction failed: only ingest has results.
Json failedAfterIngest(const std::string& name, const std::string& message) {
  Json m = succeededManifest(name, 0);
  m["status"] = "failed";
  m["error"] = {{"stage", "reconstruct"}, {"message", message}};
  m["stages"] = {stage("ingest", "succeeded"), stage("reconstruct", "failed"), stage("simplify", "not_run", 0),
                 stage("bake", "not_run", 0),  stage("render", "not_run", 0),  stage("report", "not_run", 0)};
  const Json ingest = m["results"]["ingest"];
  m["results"] = {{"ingest", ingest}};
  m["files"] = Json::object();
  return m;
}

TEST(ReportHtml, EscapesTheFiveCharacters) {
  EXPECT_EQ(htmlEscape("<a href=\"x\">'&'</a>"), "&lt;a href=&quot;x&quot;&gt;&#39;&amp;&#39;&lt;/a&gt;");
  EXPECT_EQ(htmlEscape("plain caf\xc3\xa9"), "plain caf\xc3\xa9");
}

TEST(ReportHtml, PercentEncodesPaths) {
  EXPECT_EQ(urlPathEscape("a #1/render/view00_apo.png"), "a%20%231/render/view00_apo.png");
  EXPECT_EQ(urlPathEscape("q?x=%\"'"), "q%3Fx%3D%25%22%27");
  EXPECT_EQ(urlPathEscape("Az09-._~/"), "Az09-._~/");
  EXPECT_EQ(urlPathEscape("caf\xc3\xa9"), "caf%C3%A9");
  EXPECT_EQ(urlPathEscape("javascript:alert(1)"), "javascript%3Aalert%281%29");  // stays a relative path
  EXPECT_EQ(urlPathEscape("//evil.example/x.png"), ".///evil.example/x.png");  // a path under the page's folder
}

TEST(ReportHtml, HostileScanNameAndErrorMessageShowAsText) {
  const std::string name = "<img src=x onerror=alert(1)>.ply";
  const std::string html = qaReportHtml(failedAfterIngest(name, "bad header <script>alert('x')</script> & \"more\""));
  EXPECT_THAT(html, Not(HasSubstr("<img src=x")));
  EXPECT_THAT(html, Not(HasSubstr("<script")));
  EXPECT_THAT(html, HasSubstr("<h1>&lt;img src=x onerror=alert(1)&gt;.ply</h1>"));
  EXPECT_THAT(html, HasSubstr("<title>apo QA report: &lt;img src=x onerror=alert(1)&gt;.ply</title>"));
  EXPECT_THAT(html, HasSubstr("bad header &lt;script&gt;alert(&#39;x&#39;)&lt;/script&gt; &amp; &quot;more&quot;"));
  EXPECT_THAT(html, HasSubstr("scans/&lt;img src=x onerror=alert(1)&gt;.ply"));  // the input path
}

TEST(ReportHtml, HasNoScriptAndNothingFromTheNetwork) {
  const std::string html = qaReportHtml(succeededManifest("bunny.ply", 2));
  EXPECT_THAT(html, Not(HasSubstr("<script")));
  EXPECT_THAT(html, Not(HasSubstr("http:")));
  EXPECT_THAT(html, Not(HasSubstr("https:")));
  EXPECT_THAT(html, Not(HasSubstr("=\"//")));
  EXPECT_THAT(html, Not(HasSubstr("<link")));
  EXPECT_THAT(html, HasSubstr("<style>"));
  EXPECT_THAT(html, HasSubstr("</html>"));
}

TEST(ReportHtml, ReferencesEveryViewsFourImages) {
  const std::string html = qaReportHtml(succeededManifest("bunny.ply", 3));
  for (int view = 0; view < 3; ++view)
    for (const char* pass : {"reference", "baseline", "apo", "apo_error"})
      EXPECT_THAT(html, HasSubstr(fmt::format("src=\"render/view{:02d}_{}.png\"", view, pass))) << view << " " << pass;
  EXPECT_EQ(occurrences(html, "<img "), 12u);
  EXPECT_THAT(html, HasSubstr("0&#176;"));         // the heat map legend's scale
  EXPECT_THAT(html, HasSubstr("10&#176;+"));
}

TEST(ReportHtml, PercentEncodesTheRendersFolderInSrc) {
  Json manifest = succeededManifest("bunny.ply", 1);
  manifest["files"]["renders"] = "a #1 & 'x' ?%";
  const std::string html = qaReportHtml(manifest);
  EXPECT_THAT(html, HasSubstr("src=\"a%20%231%20%26%20%27x%27%20%3F%25/view00_apo.png\""));
  EXPECT_THAT(html, Not(HasSubstr("src=\"a #1")));
}

TEST(ReportHtml, StatesTheVerdictInPlainWords) {
  const std::string html = qaReportHtml(succeededManifest("bunny.ply", 2));
  EXPECT_THAT(html, HasSubstr("APO normals are <b>2.4&deg;</b> from the dense mesh M on average, <b>2.0&times; closer</b>"));
  EXPECT_THAT(html, HasSubstr("<b>1.0 MiB</b>"));  // the texture
  EXPECT_THAT(html, HasSubstr("0.33&times; the 3 MiB of a 1024 &times; 1024 RGB normal map"));
  EXPECT_THAT(html, HasSubstr("class=\"banner ok\">succeeded"));
}

TEST(ReportHtml, ShowsTheFiguresOfEverySection) {
  const std::string html = qaReportHtml(succeededManifest("bunny.ply", 2));
  EXPECT_THAT(html, HasSubstr("460,400"));    // points read
  EXPECT_THAT(html, HasSubstr("1,204,332"));  // M triangles
  EXPECT_THAT(html, HasSubstr("1,000,000"));  // rays
  EXPECT_THAT(html, HasSubstr("990,000"));    // samples hit
  EXPECT_THAT(html, HasSubstr("10,000 (1.00%)"));  // by closest point
  EXPECT_THAT(html, HasSubstr("3.25 ms"));    // APO frame
  EXPECT_THAT(html, HasSubstr("6.50 / 11"));  // texel reads
  EXPECT_THAT(html, HasSubstr("95.4 MiB"));   // a stage's peak memory
  EXPECT_THAT(html, HasSubstr("6.00 s"));     // total of six 1 s stages
  EXPECT_THAT(html, Not(HasSubstr("not run")));
}

// What ingest decided on its own is shown: a soup read as scans, faces
// flipped, the local frame's origin, the readers' notes (escaped).
TEST(ReportHtml, ShowsTheDecisionsIngestTookOnItsOwn) {
  Json m = succeededManifest("statue_scans.ply", 1);
  m["results"]["ingest"]["normals"] = {{"source", "computed_from_faces"}, {"orientation", "faces"}};
  m["results"]["ingest"]["mesh_input"] = {{"requested", "auto"}, {"decision", "scans"}, {"pieces", 12},
                                          {"overlap_fraction", 0.873}};
  m["results"]["ingest"]["face_orientation"] = {{"pieces", 12}, {"flipped_pieces", 3}, {"flipped_triangles", 210455}};
  m["results"]["ingest"]["origin"] = {512000.0, 5403000.0, 300.0};
  m["results"]["ingest"]["read_notes"] = {"element 'edge' (2 items) skipped <b>"};
  m["results"]["ingest"]["large_scan"] = {{"points_in_file", 100024484}, {"voxel_centroids", 8967129},
                                          {"voxel_size", 0.0009765625}};
  const std::string html = qaReportHtml(m);
  EXPECT_THAT(html, HasSubstr("computed_from_faces, oriented by faces"));
  EXPECT_THAT(html, HasSubstr("scans (12 pieces, 87% of the vertices within 3 edge lengths of another piece)"));
  EXPECT_THAT(html, HasSubstr("210,455 triangles in 3 pieces"));
  EXPECT_THAT(html, HasSubstr("[512000.0,5403000.0,300.0]"));
  EXPECT_THAT(html, HasSubstr("element &#39;edge&#39; (2 items) skipped &lt;b&gt;"));
  EXPECT_THAT(html, HasSubstr("100,024,484 points in the file, 8,967,129 centroids of voxels of 0.000976562 file units"));
  EXPECT_THAT(html, HasSubstr("M and the APO are made from them"));
  // --all-points: every point in a store, the APO baked from it in bricks.
  m["results"]["ingest"]["point_store"] = {{"written", true}, {"reused", false}, {"points", 100024484}, {"neighbours", 48},
                                           {"occupied_cells", 15566}, {"cut_neighbourhoods", 12}, {"unfitted_normals", 3},
                                           {"bytes", 2400587616}};
  m["results"]["bake"]["detail_source"] = {{"option", "points"}, {"chosen", "points"}, {"reason", "--detail-source points"},
                                           {"points_baked", 100024484}, {"points_from", "store"}};
  m["results"]["bake"]["bricks"] = {{"depth", 2}, {"bricks", 42}, {"refinement_runs", 43}, {"largest_brick_points", 9123456},
                                    {"discs_wider_than_reach", 0}};
  const std::string stored = qaReportHtml(m);
  EXPECT_THAT(stored, HasSubstr("M is made from them, the points' APO from every point"));
  EXPECT_THAT(stored, HasSubstr("100,024,484 points with normals fitted over 48 neighbours in 15,566 cells"));
  EXPECT_THAT(stored, HasSubstr("the points' APO read 100,024,484 points, every point of the scan"));
  EXPECT_THAT(stored, HasSubstr("42 bricks of depth 2, 43 brick builds, at most 9,123,456 points held at once"));
  EXPECT_THAT(stored, Not(HasSubstr("resumed")));
  // The default: each point its nearest centroid's normal; a resumed bake.
  m["results"]["ingest"]["point_store"]["neighbours"] = 0;
  m["results"]["bake"]["bricks"]["journal"] = {{"entries_reused", 97}, {"entries_written", 51}};
  const std::string centroids = qaReportHtml(m);
  EXPECT_THAT(centroids, HasSubstr("100,024,484 points, each with its nearest centroid's normal (--point-normals centroids) "
                                   "in 15,566 cells"));
  EXPECT_THAT(centroids, Not(HasSubstr("neighbourhoods cut")));
  EXPECT_THAT(centroids, HasSubstr("resumed: 97 cells' and bricks' work read back"));
  EXPECT_THAT(centroids, Not(HasSubstr("Split across tasks")));
  // A split run's merge: the stages its prepared part ran.
  m["split"] = {{"prepared_stages", {"ingest", "reconstruct", "simplify"}}};
  EXPECT_THAT(qaReportHtml(m), HasSubstr("Split across tasks: ingest, reconstruct, simplify ran once, in the prepared part"));
  // Nothing decided, nothing said.
  const std::string plain = qaReportHtml(succeededManifest("bunny.ply", 1));
  EXPECT_THAT(plain, Not(HasSubstr("mesh read as")));
  EXPECT_THAT(plain, Not(HasSubstr("flipped")));
  EXPECT_THAT(plain, Not(HasSubstr("local frame origin")));
  EXPECT_THAT(plain, Not(HasSubstr("voxel centroids")));
}

// A point scan's figures against its own points sit beside those against
// M; a mesh input (against_scan null) shows no such table.
TEST(ReportHtml, ShowsTheFiguresAgainstTheScanForPointScans) {
  Json m = succeededManifest("kitten.xyz", 1);
  m["results"]["render"]["against_scan"] = {
      {"probes", 200000},
      {"probes_kept", 180000},
      {"m", {{"mean", 3.139}, {"median", 2.181}, {"p95", 9.42}}},
      {"apo_filtered", {{"mean", 2.827}, {"median", 1.777}, {"p95", 9.47}}},
      {"M",
       {{"scan_points", 5210},
        {"normal_degrees", {{"mean", 3.66}, {"median", 2.04}, {"p95", 13.15}}},
        {"mean_distance", 0.00102},
        {"p95_distance", 0.00378}}}};
  const std::string html = qaReportHtml(m);
  EXPECT_THAT(html, HasSubstr("against the scan's own points"));
  EXPECT_THAT(html, HasSubstr("<td>angular error, mean</td><td class=\"n\">2.83&deg;</td><td class=\"n\">3.14&deg;</td>"
                              "<td class=\"n\">3.66&deg;</td>"));
  EXPECT_THAT(html, HasSubstr("180,000 of 200,000"));
  EXPECT_THAT(html, HasSubstr("5,210 scan points"));
  // The verdict leads with the scan: 3.139 / 2.827 = 1.11 times.
  EXPECT_THAT(html, HasSubstr("Against the scan's own points, APO normals are <b>2.8&deg;</b> from the scan's normals "
                              "on average, <b>1.1&times; closer</b> than the coarse mesh m alone (3.1&deg;).</p>\n"
                              "<p>APO normals are"));
  EXPECT_THAT(html, HasSubstr("0.00102 / 0.00378"));
  m["results"]["render"]["against_scan"] = nullptr;
  EXPECT_THAT(qaReportHtml(m), Not(HasSubstr("against the scan's own points")));
}

// View by view against the scan: each view's probes it sees, in the view's
// line, in the per-view table and counted in the verdict; figures that do
// not match the views one for one are not shown.
TEST(ReportHtml, JudgesEachViewAgainstTheScanForPointScans) {
  Json m = succeededManifest("kitten.xyz", 2);
  const auto view = [](double apo, double coarse, int seen) {
    return Json{{"probes_seen", seen}, {"m", {{"mean", coarse}}}, {"apo_filtered", {{"mean", apo}}}};
  };
  m["results"]["render"]["against_scan"] = {{"m", {{"mean", 2.0}}},
                                            {"apo_filtered", {{"mean", 1.5}}},
                                            {"views", {view(1.0, 2.0, 900), view(3.0, 2.0, 700)}}};
  const std::string html = qaReportHtml(m);
  EXPECT_THAT(html, HasSubstr("the APO is closer than m alone in <b>1 of 2</b> views."));
  EXPECT_THAT(html, HasSubstr("against the scan's points seen: m with APO <b>1.00&deg;</b>, m alone 2.00&deg; "
                              "(2.0&times;) &middot; against M: m with APO"));
  EXPECT_THAT(html, HasSubstr("<th class=\"n\">APO mean, against the scan</th>"));
  EXPECT_THAT(html, HasSubstr("<tr><td>01</td><td class=\"n\">3.00&deg;</td><td class=\"n\">2.00&deg;</td>"));

  m["results"]["render"]["against_scan"]["views"].push_back(view(1.0, 2.0, 5));
  const std::string mismatched = qaReportHtml(m);
  EXPECT_THAT(mismatched, Not(HasSubstr("view by view")));
  EXPECT_THAT(mismatched, Not(HasSubstr("APO mean, against the scan")));
  EXPECT_THAT(mismatched, Not(HasSubstr("against the scan's points seen")));
}

TEST(ReportHtml, SaysWhatTheApoWasBakedFromAndWhy) {
  Json m = succeededManifest("kitten.xyz", 1);
  m["results"]["bake"]["detail_source"] = {
      {"option", "auto"},
      {"chosen", "points"},
      {"reason", "the APO baked from the <points> is closer"},
      {"candidates",
       {{"mesh", {{"against_scan_mean_degrees", 4.521}, {"texture_bytes", 278528}}},
        {"points", {{"against_scan_mean_degrees", 3.104}, {"texture_bytes", 2097152}}}}}};
  const std::string html = qaReportHtml(m);
  EXPECT_THAT(html, HasSubstr("<td>baked from</td><td class=\"n\">points (auto: the APO baked from the &lt;points&gt; is "
                              "closer; against the scan, baked from M 4.52&deg; in 272.0 KiB, from the points 3.10&deg; "
                              "in 2.0 MiB)</td>"));
  EXPECT_THAT(html, HasSubstr("these figures compare it with M"));
  // Against M, the verdict says why the APO carries M's distance (when
  // there are figures against the scan to read instead).
  EXPECT_THAT(html, Not(HasSubstr("which M smooths")));
  m["results"]["render"]["against_scan"] = {{"m", {{"mean", 3.1}}}, {"apo_filtered", {{"mean", 2.5}}}};
  EXPECT_THAT(qaReportHtml(m), HasSubstr("The APO was baked from the scan's points, which M smooths"));
  // Since 2026-12-04 the renders draw the points the APO was baked from
  // (results.render.reference): the report names them, and the notes about
  // M's distance from the scan have no place.
  m["results"]["render"]["reference"] = "points";
  const std::string againstPoints = qaReportHtml(m);
  EXPECT_THAT(againstPoints, HasSubstr("from the scan's points on average"));
  EXPECT_THAT(againstPoints, HasSubstr("Each row: the scan's points (reference)"));
  EXPECT_THAT(againstPoints, Not(HasSubstr("which M smooths")));
  EXPECT_THAT(againstPoints, Not(HasSubstr("these figures compare it with M")));
  m["results"]["render"]["reference"] = "M";
  EXPECT_THAT(qaReportHtml(m), HasSubstr("from the dense mesh M on average"));
  // A manifest from before results.render.reference: the points were the
  // reference only with --detail-source points.
  m["results"]["render"].erase("reference");
  EXPECT_THAT(qaReportHtml(m), HasSubstr("from the dense mesh M on average"));
  Json explicitPoints = m;
  explicitPoints["options"]["detail-source"] = "points";
  EXPECT_THAT(qaReportHtml(explicitPoints), HasSubstr("from the scan's points on average"));
  m["results"]["bake"]["detail_source"] = {{"option", "auto"}, {"chosen", "mesh"}, {"reason", "the scan is a mesh"}};
  EXPECT_THAT(qaReportHtml(m), Not(HasSubstr("these figures compare it with M")));
  EXPECT_THAT(qaReportHtml(m), HasSubstr("<td>baked from</td><td class=\"n\">mesh (auto: the scan is a mesh)</td>"));
}

// The bake's own decision to take M's triangles in Morton order
// (bake.json detail.faces_reordered): a row when it did, none otherwise.
TEST(ReportHtml, SaysWhenTheBakeTookMsTrianglesInMortonOrder) {
  Json m = succeededManifest("shuffled.ply", 1);
  m["results"]["bake"]["detail"] = {{"kind", "mesh"}, {"primitives", 1206528}, {"face_order_spread", 288.1},
                                    {"faces_reordered", true}};
  EXPECT_THAT(qaReportHtml(m), HasSubstr("<td>M's triangles</td><td class=\"n\">taken in Morton order: the file lists "
                                         "them in no order in space (consecutive ones 288 edges apart, median)</td>"));
  m["results"]["bake"]["detail"]["faces_reordered"] = false;
  EXPECT_THAT(qaReportHtml(m), Not(HasSubstr("M's triangles")));
  m["results"]["bake"]["detail"].erase("faces_reordered");
  EXPECT_THAT(qaReportHtml(m), Not(HasSubstr("M's triangles")));
}

// The export's own decisions: patches sized by detail, the scan's colours
// as the base colour map, or grey without them.
TEST(ReportHtml, SaysHowTheGlbWasMade) {
  Json m = succeededManifest("mug.pcd", 1);
  m["files"]["glb"] = "asset.glb";
  m["results"]["export"] = {{"glb_bytes", 3246236},
                            {"map", {{"width", 1024}, {"height", 1024}}},
                            {"used_share", 0.33},
                            {"patch_size", {{"rule", "detail"}, {"smallest_scale", 0.5}, {"largest_scale", 2.0}}},
                            {"base_color", {{"source", "scan colours"}, {"png_bytes", 1424420}}}};
  std::string html = qaReportHtml(m);
  EXPECT_THAT(html, HasSubstr("each patch sized by the detail it covers, 0.50 to 2.00&times;"));
  EXPECT_THAT(html, HasSubstr("The scan's colours are its base colour map (1.4 MiB of PNG)."));
  m["results"]["export"]["base_color"] = nullptr;
  m["results"]["export"]["patch_size"]["rule"] = "uniform";
  html = qaReportHtml(m);
  EXPECT_THAT(html, HasSubstr("the base colour is grey"));
  EXPECT_THAT(html, Not(HasSubstr("sized by the detail")));
}

TEST(ReportHtml, FailedRunShowsTheErrorAndNotRunSections) {
  const std::string html = qaReportHtml(failedAfterIngest("scan.pcd", "no point left after cleaning"));
  EXPECT_THAT(html, HasSubstr("class=\"banner bad\">failed at stage <b>reconstruct</b>: no point left after cleaning"));
  EXPECT_THAT(html, HasSubstr("460,400"));  // ingest's figures are still shown
  // Views, both charts, metrics, m, bake and render cost have nothing to show;
  // the simplify, bake, render and report stages are listed as not run.
  EXPECT_GE(occurrences(html, "not run"), 10u);
  EXPECT_THAT(html, HasSubstr("not run (the bake stage did not run)"));
  EXPECT_THAT(html, HasSubstr("failed: the reconstruct stage stopped the run: no point left after cleaning"));
  EXPECT_EQ(occurrences(html, "<img"), 0u);
  EXPECT_EQ(occurrences(html, "class=\"bar"), 0u);
}

TEST(ReportHtml, NodesPerDepthChartHasOneBarPerDepth) {
  const std::string html = qaReportHtml(succeededManifest("bunny.ply", 2));
  EXPECT_EQ(occurrences(html, "class=\"bar depth\""), 7u);
  EXPECT_THAT(html, HasSubstr("<title>depth 6: 9,000 nodes</title>"));
}

TEST(ReportHtml, ViewErrorChartHasTwoBarsPerView) {
  const std::string html = qaReportHtml(succeededManifest("bunny.ply", 4));
  EXPECT_EQ(occurrences(html, "class=\"bar apo\""), 4u);
  EXPECT_EQ(occurrences(html, "class=\"bar baseline\""), 4u);
}

TEST(ReportHtml, IdenticalImagesHaveAnInfinitePsnr) {
  Json manifest = succeededManifest("bunny.ply", 1);
  manifest["results"]["render"]["views"][0]["apo"]["image"]["psnr_db"] = nullptr;
  EXPECT_THAT(qaReportHtml(manifest), HasSubstr("&infin; (identical)"));
}

TEST(ReportHtml, WithoutAReferenceNoReferenceImageIsLinked) {
  Json manifest = succeededManifest("bunny.ply", 2);
  manifest["results"]["render"]["overall"]["apo"]["pixels"] = 0;
  const std::string html = qaReportHtml(manifest);
  EXPECT_THAT(html, Not(HasSubstr("_reference.png")));
  EXPECT_THAT(html, Not(HasSubstr("_apo_error.png")));
  EXPECT_EQ(occurrences(html, "<img "), 4u);
}

TEST(ReportHtml, ManifestsOfUnexpectedShapeDoNotThrow) {
  Json mistyped = succeededManifest("bunny.ply", 2);
  mistyped["input"]["name"] = 42;
  mistyped["stages"][1] = "bake";
  mistyped["stages"][2]["seconds"] = "fast";
  mistyped["results"]["bake"]["nodes"]["per_depth"] = {1, "x", nullptr, Json::object(), -5, 1e300};
  mistyped["results"]["render"]["views"][0] = 7;
  mistyped["results"]["render"]["views"][1]["index"] = -3;
  mistyped["results"]["render"]["overall"] = "none";
  mistyped["options"]["render"] = {{"size", {1, 2}}, {"bad\xff", "\xfe"}};  // invalid UTF-8 too
  mistyped["files"] = {{"renders", 5}, {"m", nullptr}};
  const std::vector<Json> manifests = {nullptr, Json::array(), "text", 42, Json::object(), {{"input", 5}},
                                       {{"stages", Json::object()}, {"results", Json::array()}},
                                       {{"status", "failed"}, {"error", "oops"}}, mistyped};
  for (const Json& manifest : manifests) {
    std::string html;
    EXPECT_NO_THROW(html = qaReportHtml(manifest)) << manifest.dump(-1, ' ', false, Json::error_handler_t::replace);
    EXPECT_THAT(html, HasSubstr("</html>"));
    EXPECT_NO_THROW(html = batchIndexHtml({{"x", manifest}}, manifest));
    EXPECT_THAT(html, HasSubstr("</html>"));
  }
  EXPECT_THAT(qaReportHtml(Json::object()), HasSubstr("unnamed scan"));
}

TEST(BatchIndexHtml, RowsForASuccessAndAFailure) {
  const Json summary = {{"scans", 2}, {"succeeded", 1}, {"failed", 1}, {"skipped_up_to_date", 0}, {"seconds", 12.5}};
  const std::vector<BatchRow> rows = {
      {"lab #1/bunny.ply", succeededManifest("bunny.ply", 2)},
      {"bad/<b>x</b>.pcd", failedAfterIngest("<b>x</b>.pcd", "line 3: expected 3 fields, found <2>")}};
  const std::string html = batchIndexHtml(rows, summary);
  EXPECT_THAT(html, HasSubstr("2 scans: 1 succeeded, 1 failed, 0 up to date"));
  EXPECT_THAT(html, HasSubstr("12.5 s"));
  EXPECT_EQ(occurrences(html, "<tr"), 3u);  // header and two scans

  // The success: thumbnail, report link, figures
  EXPECT_THAT(html, HasSubstr("<img src=\"lab%20%231/bunny.ply/render/view00_apo.png\""));
  EXPECT_THAT(html, HasSubstr("<a href=\"lab%20%231/bunny.ply/report.html\">lab #1/bunny.ply</a>"));
  EXPECT_THAT(html, HasSubstr("460,400"));
  EXPECT_THAT(html, HasSubstr("1,204,332"));
  EXPECT_THAT(html, HasSubstr("3,000"));
  EXPECT_THAT(html, HasSubstr("1.0 MiB"));
  EXPECT_THAT(html, HasSubstr("2.40&deg; / 4.80&deg; (2.0&times;)"));
  EXPECT_THAT(html, HasSubstr("6.00 s"));

  // The failure: stage and message, escaped, no thumbnail, no report link
  EXPECT_THAT(html, HasSubstr("<tr class=\"failed\">"));
  EXPECT_THAT(html, HasSubstr("failed at stage <b>reconstruct</b>: line 3: expected 3 fields, found &lt;2&gt;"));
  EXPECT_THAT(html, HasSubstr("bad/&lt;b&gt;x&lt;/b&gt;.pcd"));
  EXPECT_THAT(html, Not(HasSubstr("<b>x</b>")));
  EXPECT_THAT(html, Not(HasSubstr("bad/%3Cb%3Ex%3C/b%3E.pcd/report.html")));
  EXPECT_THAT(html, HasSubstr("href=\"bad/%3Cb%3Ex%3C/b%3E.pcd/manifest.json\""));
  EXPECT_EQ(occurrences(html, "<img"), 1u);
}

// The row names the scan: the message does not repeat the input's path. A
// scan whose mesh was not simplified says m is M rather than a ratio to an
// error of zero.
TEST(BatchIndexHtml, FailureWithoutThePathAndMIsMWithoutARatio) {
  Json failed = failedAfterIngest("a.ply", "scans/a.ply: line 3: expected 3 fields");
  Json same = succeededManifest("small.off", 1);
  same["results"]["simplify"]["faces"] = {{"in", 2000}, {"target", 3000}, {"out", 2000}};
  same["results"]["render"]["overall"]["baseline"]["mean"] = 0.0;
  const std::string html = batchIndexHtml({{"a.ply", failed}, {"small.off", same}}, Json::object());
  EXPECT_THAT(html, HasSubstr("failed at stage <b>reconstruct</b>: line 3: expected 3 fields"));
  EXPECT_THAT(html, Not(HasSubstr("scans/a.ply: line 3")));
  EXPECT_THAT(html, HasSubstr("2.40&deg; / 0.00&deg; (m is M)"));
  // The scan's own report keeps the whole message.
  EXPECT_THAT(qaReportHtml(failed), HasSubstr("scans/a.ply: line 3: expected 3 fields"));
}

TEST(BatchIndexHtml, AScanWithoutManifestIsListed) {
  const std::string html = batchIndexHtml({{"lost.ply", Json::object()}}, Json::object());
  EXPECT_THAT(html, HasSubstr("no manifest"));
  EXPECT_THAT(html, HasSubstr("lost.ply"));
}

// A run that wrote viewer.html: report.html frames it (and links it) without
// a script of its own; index.html's thumbnail opens it.
TEST(ReportHtml, FramesTheViewerWhenTheRunWroteOne) {
  Json m = succeededManifest("bunny.ply", 1);
  EXPECT_THAT(qaReportHtml(m), Not(HasSubstr("<iframe")));
  m["files"]["viewer"] = "viewer #1.html";
  m["results"]["viewer"] = {{"bytes", 6739615}, {"detail", "M simplified <for> the viewer"}};
  const std::string html = qaReportHtml(m);
  EXPECT_THAT(html, HasSubstr("<iframe class=\"viewer\" src=\"viewer%20%231.html\""));
  EXPECT_THAT(html, HasSubstr("<a href=\"viewer%20%231.html\">open it alone</a>"));
  EXPECT_THAT(html, HasSubstr("M simplified &lt;for&gt; the viewer"));
  EXPECT_THAT(html, HasSubstr("6.4 MiB"));
  EXPECT_THAT(html, HasSubstr("frame-src 'self' file:"));
  EXPECT_THAT(html, Not(HasSubstr("<script")));

  const std::string index = batchIndexHtml({{"lab #1", m}}, Json::object());
  EXPECT_THAT(index, HasSubstr("<a href=\"lab%20%231/viewer%20%231.html\" title=\"interactive view\"><img src=\"lab%20%231/render/view00_apo.png\""));
}

ViewerScene smallScene() {
  ViewerScene scene;
  scene.shaders.meshVertex = "vertex </script> text";
  scene.textureWidth = 2;
  scene.textureHeight = 1;
  scene.texture = {0, 1, 2, 3, 250, 251, 252, 253};
  scene.coarse.positions = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  scene.coarse.normals = {0, 0, 1, 0, 0, 1, 0, 0, 1};
  scene.coarse.indices = {0, 1, 2};
  Camera view;
  view.label = "+x</script>";
  scene.views = {view};
  return scene;
}

// The page's data is JSON inside a script element: nothing from the scan
// (its name, a label, a shader) can end that element or become markup.
TEST(ViewerHtml, HostileTextStaysInsideTheData) {
  const std::string html = viewerHtml(smallScene(), "<img src=x onerror=alert(1)></script><!--.ply", {"render #1/view00_apo.png"});
  EXPECT_THAT(html, HasSubstr("<title>&lt;img src=x onerror=alert(1)&gt;&lt;/script&gt;&lt;!--.ply: interactive view</title>"));
  EXPECT_THAT(html, Not(HasSubstr("<img src=x")));
  EXPECT_THAT(html, Not(HasSubstr("<!--.ply")));
  EXPECT_EQ(occurrences(html, "</script>"), 2u);  // the data's and the script's own ends
  EXPECT_THAT(html, HasSubstr("\\u003c/script>"));
  EXPECT_THAT(html, HasSubstr("render%20%231/view00_apo.png"));
  EXPECT_THAT(html, HasSubstr("script-src 'unsafe-inline'"));
  EXPECT_THAT(html, Not(HasSubstr("http:")));
  EXPECT_THAT(html, Not(HasSubstr("https:")));
}

// The binary arrays travel as base64 of their little-endian bytes: checked
// against the RFC 4648 encoding of the same bytes (by Python's base64).
TEST(ViewerHtml, CarriesTheTextureAndTheMeshAsBase64) {
  const std::string html = viewerHtml(smallScene(), "s.ply", {});
  EXPECT_THAT(html, HasSubstr("\"texels\":\"AAECA/r7/P0=\""));                 // 00 01 02 03 fa fb fc fd
  EXPECT_THAT(html, HasSubstr("\"indices\":\"AAAAAAEAAAACAAAA\""));              // uint32 0 1 2
  EXPECT_THAT(html, HasSubstr("\"positions\":\"AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA\""));
  EXPECT_THAT(html, HasSubstr("\"detail\":null"));
}

}  // namespace
}  // namespace apo
