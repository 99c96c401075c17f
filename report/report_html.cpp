// report.html and index.html (docs/report.md), built from manifests that may
// be partial (a failed run) or malformed: every field is read through
// type-checked accessors and every string from a manifest goes through
// htmlEscape (and urlPathEscape in src/href).
#include "report/report.h"

#include "core/text.h"

#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <exception>
#include <initializer_list>
#include <iterator>
#include <optional>

namespace apo {
namespace {

using Json = nlohmann::json;

// ---- Type-checked reading ----------------------------------------------------

const Json* child(const Json* json, const char* key) {
  if (json == nullptr || !json->is_object()) return nullptr;
  const auto it = json->find(key);
  return it == json->end() ? nullptr : &*it;
}

const Json* at(const Json* json, std::initializer_list<const char*> keys) {
  for (const char* key : keys) json = child(json, key);
  return json;
}

// A finite number (not a boolean), or nothing.
std::optional<double> number(const Json* json) {
  if (json == nullptr || !json->is_number()) return std::nullopt;
  const double value = json->get<double>();
  return std::isfinite(value) ? std::optional<double>(value) : std::nullopt;
}

std::optional<double> numberAt(const Json* json, std::initializer_list<const char*> keys) { return number(at(json, keys)); }

std::optional<std::string> text(const Json* json) {
  if (json == nullptr || !json->is_string()) return std::nullopt;
  return json->get<std::string>();
}

std::optional<std::string> textAt(const Json* json, std::initializer_list<const char*> keys) { return text(at(json, keys)); }

// Any value as text (for options): strings as they are, the rest as JSON.
std::string anyAsText(const Json& json) {
  if (json.is_string()) return json.get<std::string>();
  return json.dump(-1, ' ', false, Json::error_handler_t::replace);
}

// ---- Formatting ---------------------------------------------------------------

constexpr const char* kNone = "&ndash;";  // shown for a missing figure

std::string escaped(const std::optional<std::string>& s) { return s ? htmlEscape(*s) : kNone; }

std::string count(std::optional<double> n) {
  if (!n) return kNone;
  if (*n < 0.0 || *n >= 1.8e19) return fmt::format("{:g}", *n);
  return groupedDigits(static_cast<std::uint64_t>(std::llround(*n)));
}

std::string fixed(std::optional<double> x, int digits) { return x ? fmt::format("{:.{}f}", *x, digits) : kNone; }

std::string degrees(std::optional<double> x, int digits = 2) { return x ? fixed(x, digits) + "&deg;" : kNone; }

std::string bytesText(std::optional<double> bytes) {
  if (!bytes) return kNone;
  const double b = *bytes;
  if (b < 1024.0) return fmt::format("{:.0f} B", b);
  if (b < 1024.0 * 1024.0) return fmt::format("{:.1f} KiB", b / 1024.0);
  if (b < 1024.0 * 1024.0 * 1024.0) return fmt::format("{:.1f} MiB", b / (1024.0 * 1024.0));
  return fmt::format("{:.2f} GiB", b / (1024.0 * 1024.0 * 1024.0));
}

// The export's own decisions (docs/export.md): how its patches were sized,
// and whether the scan's colours became the base colour.
std::string patchSizingText(const Json* exported) {
  if (textAt(exported, {"patch_size", "rule"}).value_or("") != "detail") return "";
  return fmt::format(", each patch sized by the detail it covers, {} to {}&times; the density of a triangle of median detail",
                     fixed(numberAt(exported, {"patch_size", "smallest_scale"}), 2),
                     fixed(numberAt(exported, {"patch_size", "largest_scale"}), 2));
}

std::string baseColorText(const Json* exported) {
  const Json* color = at(exported, {"base_color"});
  if (color == nullptr || !color->is_object()) return "The scan has no colours (or --no-color): the base colour is grey.";
  return fmt::format("The scan's colours are its base colour map ({} of PNG).", bytesText(numberAt(color, {"png_bytes"})));
}

std::string seconds(std::optional<double> s) {
  if (!s) return kNone;
  return *s < 10.0 ? fmt::format("{:.2f} s", *s) : fmt::format("{:.1f} s", *s);
}

std::string percentText(std::optional<double> share) { return share ? fmt::format("{:.0f}%", 100.0 * *share) : kNone; }

std::string ratioText(double ratio) { return ratio < 10.0 ? fmt::format("{:.1f}", ratio) : fmt::format("{:.0f}", ratio); }

// ---- Manifest figures used by both pages ----------------------------------------

const Json* results(const Json& manifest, const char* stage) { return at(&manifest, {"results", stage}); }

std::string stageStatus(const Json& manifest, std::string_view name) {
  const Json* stages = child(&manifest, "stages");
  if (stages == nullptr || !stages->is_array()) return "";
  for (const Json& stage : *stages)
    if (textAt(&stage, {"name"}) == std::string(name)) return textAt(&stage, {"status"}).value_or("");
  return "";
}

std::string rendersFolder(const Json& manifest) {
  const std::optional<std::string> folder = textAt(&manifest, {"files", "renders"});
  return folder && !folder->empty() ? *folder : "render";
}

std::optional<double> pointsIn(const Json& manifest) { return numberAt(results(manifest, "ingest"), {"counts", "points_in"}); }

// M: the reconstructed mesh, or the input mesh itself when reconstruction was skipped.
std::optional<double> denseTriangles(const Json& manifest) {
  if (auto n = numberAt(results(manifest, "reconstruct"), {"mesh", "triangles"})) return n;
  const Json* ingest = results(manifest, "ingest");
  if (textAt(ingest, {"kind"}) == std::string("mesh")) return numberAt(ingest, {"counts", "triangles_out"});
  return numberAt(results(manifest, "bake"), {"detail", "primitives"});
}

std::optional<double> coarseTriangles(const Json& manifest) {
  const Json* simplify = results(manifest, "simplify");
  if (auto n = numberAt(simplify, {"faces", "out"})) return n;
  if (auto n = numberAt(simplify, {"mesh", "triangles"})) return n;
  return numberAt(results(manifest, "bake"), {"coarse_triangles"});
}

std::optional<double> totalSeconds(const Json& manifest) {
  const Json* stages = child(&manifest, "stages");
  if (stages == nullptr || !stages->is_array()) return std::nullopt;
  std::optional<double> total;
  for (const Json& stage : *stages)
    if (auto s = numberAt(&stage, {"seconds"})) total = total.value_or(0.0) + *s;
  return total;
}

// The stage and message of a failed run: the manifest's error, else the
// first stage marked failed.
struct Failure {
  std::string stage, message;
};

Failure failureOf(const Json& manifest) {
  Failure failure;
  const Json* error = child(&manifest, "error");
  failure.stage = textAt(error, {"stage"}).value_or("");
  failure.message = textAt(error, {"message"}).value_or("");
  if (failure.stage.empty()) {
    const Json* stages = child(&manifest, "stages");
    if (stages != nullptr && stages->is_array())
      for (const Json& stage : *stages)
        if (textAt(&stage, {"status"}) == std::string("failed")) {
          failure.stage = textAt(&stage, {"name"}).value_or("");
          break;
        }
  }
  return failure;
}

// "failed at stage bake: message", escaped. The index leaves out the
// message's leading "<input path>: ", which its row already names.
std::string failureHtml(const Json& manifest, bool withoutInputPath = false) {
  const Failure failure = failureOf(manifest);
  std::string message = failure.message;
  const std::string prefix = textAt(&manifest, {"input", "path"}).value_or("") + ": ";
  if (withoutInputPath && prefix.size() > 2 && message.rfind(prefix, 0) == 0) message.erase(0, prefix.size());
  std::string html = "failed";
  if (!failure.stage.empty()) html += " at stage <b>" + htmlEscape(failure.stage) + "</b>";
  if (!message.empty()) html += ": " + htmlEscape(message);
  return html;
}

// What stands in for a stage's missing results: always says "not run" unless
// the stage itself failed or was skipped.
std::string missingStage(const Json& manifest, const char* stage) {
  const std::string status = stageStatus(manifest, stage);
  std::string why;
  if (status == "failed") {
    const Failure failure = failureOf(manifest);
    why = fmt::format("failed: the {} stage stopped the run", stage);
    if (failure.stage == stage && !failure.message.empty()) why += ": " + htmlEscape(failure.message);
  } else if (status == "skipped") {
    why = fmt::format("skipped: the {} stage was not needed", stage);
  } else if (status == "succeeded") {
    why = fmt::format("no results recorded for the {} stage", stage);
  } else {
    why = fmt::format("not run (the {} stage did not run)", stage);
  }
  return "<p class=\"notrun\">" + why + "</p>\n";
}

// ---- Page skeleton ----------------------------------------------------------------

// No script may run and nothing may be fetched but images next to the page.
constexpr const char* kContentSecurityPolicy =
    "default-src 'none'; img-src 'self' file: data:; style-src 'unsafe-inline'; frame-src 'self' file:";

constexpr const char* kStyle = R"(
:root { color-scheme: light; --ok: #1b7f3b; --bad: #b3261e; --warn: #8a5a00; --apo: #3b528b; --base: #e07b39; }
* { box-sizing: border-box; }
body { font: 15px/1.45 system-ui, -apple-system, "Segoe UI", Roboto, "DejaVu Sans", sans-serif; color: #1d1d1f;
       background: #f6f6f4; margin: 0; padding: 24px 32px 48px; max-width: 1400px; }
h1 { font-size: 26px; margin: 0 0 6px; overflow-wrap: anywhere; }
h2 { font-size: 19px; margin: 32px 0 10px; padding-bottom: 4px; border-bottom: 1px solid #d0d0cc; }
h3 { font-size: 16px; margin: 0 0 6px; }
.meta { color: #555; font-size: 13px; overflow-wrap: anywhere; }
.meta code { font-size: 12px; }
.banner { padding: 10px 14px; border-radius: 6px; font-weight: 600; margin: 12px 0; overflow-wrap: anywhere; }
.banner.ok { background: #e3f4e8; color: var(--ok); border: 1px solid #a9d8b8; }
.banner.bad { background: #fbe7e6; color: var(--bad); border: 1px solid #eab0ab; }
.banner.warn { background: #fff3d6; color: var(--warn); border: 1px solid #e8cf8f; }
.verdict { font-size: 17px; background: #fff; border-left: 4px solid var(--apo); padding: 10px 14px; margin: 12px 0; }
.verdict p { margin: 4px 0; }
.notrun { color: #777; font-style: italic; }
table { border-collapse: collapse; background: #fff; font-size: 14px; margin: 6px 0; }
th, td { border: 1px solid #ddd; padding: 4px 10px; text-align: left; vertical-align: top; }
td.n, th.n { text-align: right; font-variant-numeric: tabular-nums; white-space: nowrap; }
thead th { background: #eeeeea; }
.view { background: #fff; border: 1px solid #ddd; border-radius: 6px; padding: 10px 12px; margin: 12px 0; }
.viewstats { margin: 0 0 8px; font-size: 14px; color: #333; }
.quad { display: grid; grid-template-columns: repeat(4, 1fr); gap: 10px; }
iframe.viewer { width: 100%; height: 860px; border: 1px solid #d0d0cc; background: #fff; }
figure { margin: 0; }
figure img, .noimg { width: 100%; height: auto; display: block; background: #fff; border: 1px solid #e2e2e2; }
.noimg { aspect-ratio: 1; display: flex; align-items: center; justify-content: center; color: #888; font-style: italic; }
figcaption { font-size: 13px; color: #444; text-align: center; margin-top: 4px; }
.legend { display: flex; align-items: center; gap: 12px; flex-wrap: wrap; font-size: 13px; color: #333; }
.charts { display: flex; flex-wrap: wrap; gap: 24px; }
.chart { background: #fff; border: 1px solid #ddd; border-radius: 6px; padding: 8px 12px; }
.chart svg { display: block; }
.chart text { font-family: inherit; }
.grid2 { display: flex; flex-wrap: wrap; gap: 24px; align-items: flex-start; }
.status-succeeded { color: var(--ok); font-weight: 600; }
.status-failed { color: var(--bad); font-weight: 600; }
.status-skipped, .status-not_run, .status-running, .status-unknown { color: #777; }
tr.failed td { background: #fdf3f2; }
td.thumb { width: 96px; padding: 2px; }
td.thumb img { width: 96px; height: 96px; object-fit: contain; display: block; }
.errmsg { color: var(--bad); overflow-wrap: anywhere; min-width: 16em; max-width: 520px; }
details { margin: 8px 0; }
summary { cursor: pointer; font-weight: 600; }
footer { margin-top: 36px; font-size: 12px; color: #777; }
a { color: #1f5fa8; }
)";

std::string pageStart(const std::string& escapedTitle) {
  std::string html = "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n";
  html += fmt::format("<meta http-equiv=\"Content-Security-Policy\" content=\"{}\">\n", kContentSecurityPolicy);
  html += "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n";
  html += "<title>" + escapedTitle + "</title>\n<style>" + kStyle + "</style>\n</head>\n<body>\n";
  return html;
}

constexpr const char* kPageEnd = "</body>\n</html>\n";

// ---- SVG charts ---------------------------------------------------------------------

// A round step for about `ticks` divisions of [0, max].
double niceStep(double max, int ticks) {
  if (!(max > 0.0)) return 1.0;
  const double raw = max / ticks;
  const double magnitude = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 2.5, 5.0, 10.0})
    if (m * magnitude >= raw) return m * magnitude;
  return 10.0 * magnitude;
}

std::string tickLabel(double value) { return fmt::format("{:g}", value); }

// Octree nodes per depth: one bar (class "bar depth") per entry of `perDepth`.
std::string nodesPerDepthSvg(const Json& perDepth) {
  const std::size_t n = perDepth.size();
  double max = 0.0;
  for (const Json& v : perDepth) max = std::max(max, number(&v).value_or(0.0));
  const double left = 64, right = 12, top = 22, bottom = 34, plotHeight = 190;
  const double slot = std::clamp(560.0 / static_cast<double>(std::max<std::size_t>(n, 1)), 14.0, 56.0);
  const double width = left + right + slot * static_cast<double>(n), height = top + plotHeight + bottom;
  const double step = niceStep(max, 4), top_value = max > 0.0 ? std::ceil(max / step) * step : 1.0;
  std::string svg = fmt::format(
      "<svg class=\"nodes-per-depth\" width=\"{0:.0f}\" height=\"{1:.0f}\" "
      "viewBox=\"0 0 {0:.0f} {1:.0f}\" role=\"img\" aria-label=\"octree nodes per depth\">\n",
      width, height);
  // Axis and grid lines
  for (double v = 0.0; v <= top_value + 1e-9; v += step) {
    const double y = top + plotHeight - v / top_value * plotHeight;
    svg += fmt::format("<line x1=\"{:.1f}\" y1=\"{:.1f}\" x2=\"{:.1f}\" y2=\"{:.1f}\" stroke=\"#e4e4e4\"/>", left, y, width - right, y);
    svg += fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" font-size=\"11\" text-anchor=\"end\" fill=\"#555\">{}</text>\n",
                       left - 6, y + 4, count(v));
  }
  for (std::size_t d = 0; d < n; ++d) {
    const double value = std::max(0.0, number(&perDepth[d]).value_or(0.0));
    double h = value / top_value * plotHeight;
    if (value > 0.0) h = std::max(h, 1.0);
    const double x = left + slot * static_cast<double>(d) + slot * 0.15, w = slot * 0.7;
    const double y = top + plotHeight - h;
    svg += fmt::format(
        "<rect class=\"bar depth\" x=\"{:.1f}\" y=\"{:.1f}\" width=\"{:.1f}\" height=\"{:.1f}\" fill=\"#3b528b\">"
        "<title>depth {}: {} nodes</title></rect>",
        x, y, w, h, d, count(value));
    if (slot >= 30.0 || value == max)
      svg += fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" font-size=\"10\" text-anchor=\"middle\" fill=\"#333\">{}</text>",
                         x + w / 2, y - 4, count(value));
    svg += fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" font-size=\"11\" text-anchor=\"middle\" fill=\"#555\">{}</text>\n",
                       x + w / 2, top + plotHeight + 15, d);
  }
  svg += fmt::format("<line x1=\"{0:.1f}\" y1=\"{1:.1f}\" x2=\"{2:.1f}\" y2=\"{1:.1f}\" stroke=\"#888\"/>", left,
                     top + plotHeight, width - right);
  svg += fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" font-size=\"12\" text-anchor=\"middle\" fill=\"#333\">depth</text>\n",
                     left + (width - left - right) / 2, height - 3);
  return svg + "</svg>\n";
}

struct ViewMeans {
  int index = 0;
  std::optional<double> apo, baseline;
  std::optional<double> apoScan, baselineScan;  // against the scan's own points (point scans)
};

// Mean angular error per view, the APO (class "bar apo") beside the baseline
// (class "bar baseline").
std::string viewErrorSvg(const std::vector<ViewMeans>& views) {
  const std::size_t n = views.size();
  double max = 0.0;
  for (const ViewMeans& v : views) max = std::max({max, v.apo.value_or(0.0), v.baseline.value_or(0.0)});
  const double left = 48, right = 12, top = 30, bottom = 34, plotHeight = 190;
  const double slot = std::clamp(560.0 / static_cast<double>(std::max<std::size_t>(n, 1)), 22.0, 70.0);
  const double width = std::max(left + right + slot * static_cast<double>(n), 300.0), height = top + plotHeight + bottom;
  const double step = niceStep(max, 4), topValue = max > 0.0 ? std::ceil(max / step) * step : 1.0;
  std::string svg = fmt::format(
      "<svg class=\"view-errors\" width=\"{0:.0f}\" height=\"{1:.0f}\" "
      "viewBox=\"0 0 {0:.0f} {1:.0f}\" role=\"img\" aria-label=\"mean angular error per view\">\n",
      width, height);
  for (double v = 0.0; v <= topValue + 1e-9; v += step) {
    const double y = top + plotHeight - v / topValue * plotHeight;
    svg += fmt::format("<line x1=\"{:.1f}\" y1=\"{:.1f}\" x2=\"{:.1f}\" y2=\"{:.1f}\" stroke=\"#e4e4e4\"/>", left, y, width - right, y);
    svg += fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" font-size=\"11\" text-anchor=\"end\" fill=\"#555\">{}&#176;</text>\n",
                       left - 6, y + 4, tickLabel(v));
  }
  // Legend
  svg += fmt::format(
      "<rect x=\"{0:.0f}\" y=\"6\" width=\"12\" height=\"12\" fill=\"#3b528b\"/><text x=\"{1:.0f}\" y=\"16\" "
      "font-size=\"12\">m with APO</text><rect x=\"{2:.0f}\" y=\"6\" width=\"12\" height=\"12\" fill=\"#e07b39\"/>"
      "<text x=\"{3:.0f}\" y=\"16\" font-size=\"12\">m alone (baseline)</text>\n",
      left, left + 16, left + 110, left + 126);
  for (std::size_t i = 0; i < n; ++i) {
    const double x0 = left + slot * static_cast<double>(i) + slot * 0.12, w = slot * 0.38;
    const auto bar = [&](const char* cls, const char* fill, std::optional<double> value, double x, const char* what) {
      const double h = value ? std::max(0.0, *value) / topValue * plotHeight : 0.0;
      svg += fmt::format(
          "<rect class=\"bar {}\" x=\"{:.1f}\" y=\"{:.1f}\" width=\"{:.1f}\" height=\"{:.1f}\" fill=\"{}\">"
          "<title>view {:02d}, {}: {}</title></rect>",
          cls, x, top + plotHeight - h, w, h, fill, views[i].index, what, degrees(value));
    };
    bar("apo", "#3b528b", views[i].apo, x0, "m with APO");
    bar("baseline", "#e07b39", views[i].baseline, x0 + w, "m alone");
    svg += fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" font-size=\"11\" text-anchor=\"middle\" fill=\"#555\">{:02d}</text>\n",
                       x0 + w, top + plotHeight + 15, views[i].index);
  }
  svg += fmt::format("<line x1=\"{0:.1f}\" y1=\"{1:.1f}\" x2=\"{2:.1f}\" y2=\"{1:.1f}\" stroke=\"#888\"/>", left,
                     top + plotHeight, width - right);
  svg += fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" font-size=\"12\" text-anchor=\"middle\" fill=\"#333\">view</text>\n",
                     left + (width - left - right) / 2, height - 3);
  return svg + "</svg>\n";
}

// The heat maps' scale: viridis (render/metrics.cpp) from 0 to kReportHeatMapDegrees.
std::string heatMapLegend() {
  constexpr std::array<const char*, 9> kStops = {"#440154", "#472d7b", "#3b528b", "#2c728e", "#21908c",
                                                 "#28ae80", "#5dc963", "#abdc32", "#fde725"};
  const double width = 300, left = 10;
  std::string svg =
      "<svg class=\"heat-legend\" width=\"320\" height=\"40\" viewBox=\"0 0 320 40\" "
      "role=\"img\" aria-label=\"heat map scale\">\n<defs><linearGradient id=\"viridis\" x1=\"0\" x2=\"1\" y1=\"0\" y2=\"0\">";
  for (std::size_t i = 0; i < kStops.size(); ++i)
    svg += fmt::format("<stop offset=\"{:.3f}\" stop-color=\"{}\"/>", static_cast<double>(i) / (kStops.size() - 1), kStops[i]);
  svg += fmt::format("</linearGradient></defs>\n<rect x=\"{}\" y=\"2\" width=\"{}\" height=\"16\" fill=\"url(#viridis)\"/>\n",
                     left, width);
  for (int t = 0; t <= 5; ++t) {
    const double value = kReportHeatMapDegrees * t / 5.0, x = left + width * t / 5.0;
    svg += fmt::format("<line x1=\"{0:.1f}\" y1=\"18\" x2=\"{0:.1f}\" y2=\"22\" stroke=\"#555\"/>"
                       "<text x=\"{0:.1f}\" y=\"34\" font-size=\"11\" text-anchor=\"{1}\">{2}&#176;{3}</text>\n",
                       x, t == 0 ? "start" : (t == 5 ? "end" : "middle"), tickLabel(value), t == 5 ? "+" : "");
  }
  return svg + "</svg>";
}

// ---- report.html sections ---------------------------------------------------------------

std::string statusBanner(const Json& manifest) {
  const std::string status = textAt(&manifest, {"status"}).value_or("");
  if (status == "succeeded") return "<div class=\"banner ok\">succeeded</div>\n";
  if (status == "failed") return "<div class=\"banner bad\">" + failureHtml(manifest) + "</div>\n";
  if (status == "running")
    return "<div class=\"banner warn\">incomplete: the run had not finished when this page was written "
           "(still running, or stopped)</div>\n";
  return "<div class=\"banner warn\">unknown status: " + (status.empty() ? std::string("none recorded") : htmlEscape(status)) +
         "</div>\n";
}

std::string header(const Json& manifest, const std::string& name) {
  const Json* input = child(&manifest, "input");
  std::string html = "<header>\n<h1>" + htmlEscape(name) + "</h1>\n";
  html += statusBanner(manifest);
  const std::optional<double> bytes = numberAt(input, {"bytes"});
  html += "<div class=\"meta\">input <code>" + escaped(textAt(input, {"path"})) + "</code>";
  html += " &middot; " + bytesText(bytes) + (bytes ? " (" + count(bytes) + " bytes)" : std::string());
  html += "<br>sha256 <code>" + escaped(textAt(input, {"sha256"})) + "</code>";
  html += "<br>" + escaped(textAt(&manifest, {"tool", "name"})) + " " + escaped(textAt(&manifest, {"tool", "version"}));
  html += ", manifest format " + fixed(numberAt(&manifest, {"format_version"}), 0);
  if (auto source = textAt(&manifest, {"options", "detail-source"})) html += ", detail source " + htmlEscape(*source);
  return html + "</div>\n</header>\n";
}

// A 1024 x 1024 RGB normal map at one byte per channel: what a textured
// coarse mesh would otherwise carry.
constexpr double kNormalMapBytes = 1024.0 * 1024.0 * 3.0;

// How the APO's mean error compares with m alone's (`ratio` = m's / the
// APO's), as the end of a sentence.
std::string beside(double ratio, double baselineMean) {
  if (ratio >= 1.05)
    return fmt::format(", <b>{}&times; closer</b> than the coarse mesh m alone ({}).", ratioText(ratio), degrees(baselineMean, 1));
  if (ratio > 0.95) return fmt::format(", about as close as the coarse mesh m alone ({}).", degrees(baselineMean, 1));
  if (ratio > 0.0)
    return fmt::format(", <b>{}&times; farther</b> than the coarse mesh m alone ({}): the APO does not help here.",
                       ratioText(1.0 / ratio), degrees(baselineMean, 1));
  return fmt::format(" (the coarse mesh m alone: {}).", degrees(baselineMean, 1));
}

std::vector<ViewMeans> viewMeans(const Json* views) {
  std::vector<ViewMeans> means;
  if (views == nullptr || !views->is_array()) return means;
  for (std::size_t i = 0; i < views->size(); ++i) {
    const Json& view = (*views)[i];
    ViewMeans m;
    const std::optional<double> index = numberAt(&view, {"index"});
    m.index = index && *index >= 0.0 && *index < 1e6 ? static_cast<int>(*index) : static_cast<int>(i);
    m.apo = numberAt(&view, {"apo", "angular_error_degrees", "mean"});
    m.baseline = numberAt(&view, {"baseline", "angular_error_degrees", "mean"});
    means.push_back(m);
  }
  return means;
}

// The render's views with, for a point scan, each view's figures against the
// scan's own points (render.against_scan.views, in the same order).
std::vector<ViewMeans> viewMeans(const Json* render, const Json* views) {
  std::vector<ViewMeans> means = viewMeans(views);
  const Json* scanViews = at(render, {"against_scan", "views"});
  if (scanViews == nullptr || !scanViews->is_array() || scanViews->size() != means.size()) return means;
  for (std::size_t i = 0; i < means.size(); ++i) {
    const Json& view = (*scanViews)[i];
    if (numberAt(&view, {"probes_seen"}).value_or(0.0) <= 0.0) continue;
    means[i].apoScan = numberAt(&view, {"apo_filtered", "mean"});
    means[i].baselineScan = numberAt(&view, {"m", "mean"});
  }
  return means;
}

bool hasScanMeans(const std::vector<ViewMeans>& means) {
  return std::any_of(means.begin(), means.end(), [](const ViewMeans& m) { return m.apoScan.has_value(); });
}

// "m with APO 1.2°, m alone 3.4° (2.8×)", or a dash for what is missing.
std::string meansText(const std::optional<double>& apo, const std::optional<double>& baseline) {
  std::string text = fmt::format("m with APO <b>{}</b>, m alone {}", degrees(apo), degrees(baseline));
  if (apo && baseline && *apo > 0.0) text += fmt::format(" ({}&times;)", ratioText(*baseline / *apo));
  return text;
}

// How many views, against the scan, show the APO closer than m alone.
std::string scanViewsVerdict(const std::vector<ViewMeans>& means) {
  if (!hasScanMeans(means)) return "";
  int seen = 0, closer = 0;
  for (const ViewMeans& m : means) {
    if (!m.apoScan || !m.baselineScan) continue;
    ++seen;
    closer += *m.apoScan < *m.baselineScan ? 1 : 0;
  }
  return fmt::format("<p>Against the scan's own points, view by view (the probes each view sees), the APO is closer "
                     "than m alone in <b>{} of {}</b> views.</p>\n",
                     closer, seen);
}

// A point scan's first verdict: against its own points (docs/render.md).
std::string scanVerdict(const Json* scan) {
  const std::optional<double> apo = numberAt(scan, {"apo_filtered", "mean"}), coarse = numberAt(scan, {"m", "mean"});
  if (!apo || !coarse || *apo <= 0.0) return "";
  return fmt::format("<p>Against the scan's own points, APO normals are <b>{}</b> from the scan's normals on average",
                     degrees(apo, 1)) +
         beside(*coarse / *apo, *coarse) + "</p>\n";
}

// The renders' reference: the scan's points when the APO was baked from
// them (results.render.reference), else M. Manifests before 2026-12-04 do
// not say: theirs was the points only with --detail-source points.
bool referenceIsPoints(const Json& manifest) {
  if (const std::optional<std::string> reference = textAt(results(manifest, "render"), {"reference"}))
    return *reference == "points";
  return textAt(&manifest, {"options", "detail-source"}) == "points";
}

std::string referenceName(const Json& manifest) {
  return referenceIsPoints(manifest) ? "the scan's points" : "the dense mesh M";
}

std::string verdict(const Json& manifest) {
  const Json* render = results(manifest, "render");
  const Json* bake = results(manifest, "bake");
  std::string html = "<section class=\"verdict\" id=\"verdict\">\n";
  const std::optional<double> apoMean = numberAt(render, {"overall", "apo", "mean"});
  const std::optional<double> baselineMean = numberAt(render, {"overall", "baseline", "mean"});
  const std::optional<double> pixels = numberAt(render, {"overall", "apo", "pixels"});
  if (render == nullptr) {
    html += std::string("<p>No verdict on the normals: ") +
            (stageStatus(manifest, "render") == "failed" ? "the render stage failed." : "not run (the render stage did not run).") +
            "</p>\n";
  } else if (pixels && *pixels == 0.0) {
    html += "<p>No angular figures: the render had no reference to compare with.</p>\n";
  } else if (apoMean && baselineMean) {
    html += scanVerdict(child(render, "against_scan"));
    html += scanViewsVerdict(viewMeans(render, child(render, "views")));
    html += fmt::format("<p>APO normals are <b>{}</b> from {} on average", degrees(apoMean, 1), referenceName(manifest));
    if (*apoMean > 0.0) {
      html += beside(numberAt(render, {"overall", "baseline_over_apo"}).value_or(*baselineMean / *apoMean), *baselineMean);
      if (textAt(at(bake, {"detail_source"}), {"chosen"}) == "points" && !referenceIsPoints(manifest) &&
          child(render, "against_scan") != nullptr)
        html += " The APO was baked from the scan's points, which M smooths: against M it also carries M's distance "
                "from the scan.";
    } else {
      html += fmt::format(": they match it exactly (the coarse mesh m alone: {}).", degrees(baselineMean, 1));
    }
    html += "</p>\n";
  } else {
    html += "<p>No verdict on the normals: the render results hold no mean angular error.</p>\n";
  }
  if (const std::optional<double> textureBytes = numberAt(bake, {"texture", "bytes"})) {
    html += fmt::format("<p>The APO texture takes <b>{}</b> ({} &times; {} texels): {}&times; the 3 MiB of a 1024 &times; 1024 RGB "
                        "normal map.</p>\n",
                        bytesText(textureBytes), count(numberAt(bake, {"texture", "width"})),
                        count(numberAt(bake, {"texture", "height"})), fixed(*textureBytes / kNormalMapBytes, 2));
  }
  const Json* exported = results(manifest, "export");
  if (const std::optional<double> glbBytes = numberAt(exported, {"glb_bytes"})) {
    html += fmt::format("<p>The glTF asset <a href=\"{}\">{}</a> ({}) carries m with a {} &times; {} tangent-space normal "
                        "map made from the APO, one patch per triangle ({} of the texels{}), for any glTF 2.0 viewer. {}</p>\n",
                        htmlEscape(urlPathEscape(textAt(&manifest, {"files", "glb"}).value_or("asset.glb"))),
                        escaped(textAt(&manifest, {"files", "glb"})), bytesText(glbBytes),
                        count(numberAt(exported, {"map", "width"})), count(numberAt(exported, {"map", "height"})),
                        percentText(numberAt(exported, {"used_share"})), patchSizingText(exported),
                        baseColorText(exported));
  }
  const std::optional<double> dense = denseTriangles(manifest), coarse = coarseTriangles(manifest);
  if (dense && coarse && *coarse > 0.0)
    html += fmt::format("<p>m has {} triangles against M's {} ({}&times; fewer).</p>\n", count(coarse), count(dense),
                        ratioText(*dense / *coarse));
  return html + "</section>\n";
}

std::string imageCell(const std::string& src, const std::string& alt, const std::string& caption, int size) {
  return fmt::format("<figure><img src=\"{}\" alt=\"{}\" width=\"{}\" height=\"{}\"><figcaption>{}</figcaption></figure>\n",
                     htmlEscape(urlPathEscape(src)), htmlEscape(alt), size, size, caption);
}

std::string missingImageCell(const std::string& caption, const std::string& why) {
  return "<figure><div class=\"noimg\">" + why + "</div><figcaption>" + caption + "</figcaption></figure>\n";
}

// The interactive view (viewer.html, its own page with its own script) in a
// frame: this page stays script-free.
std::string interactiveSection(const Json& manifest) {
  const std::optional<std::string> viewer = textAt(&manifest, {"files", "viewer"});
  if (!viewer) return {};
  const std::string src = htmlEscape(urlPathEscape(*viewer));
  std::string html = "<section id=\"interactive\">\n<h2>Interactive view</h2>\n";
  html += fmt::format("<p>m with the APO walked per pixel in WebGL2, beside m alone, {} and the heat map; turn, zoom, move "
                      "the light (<a href=\"{}\">open it alone</a>, {}). Without WebGL2 it shows the static views below "
                      "and says why.</p>\n",
                      escaped(textAt(&manifest, {"results", "viewer", "detail"})), src,
                      bytesText(numberAt(&manifest, {"results", "viewer", "bytes"})));
  html += "<iframe class=\"viewer\" src=\"" + src + "\" title=\"interactive view\"></iframe>\n";
  return html + "</section>\n";
}

std::string viewsSection(const Json& manifest) {
  std::string html = "<section id=\"views\">\n<h2>Views</h2>\n";
  const Json* render = results(manifest, "render");
  const Json* views = child(render, "views");
  if (views == nullptr || !views->is_array() || views->empty()) {
    if (render != nullptr) return html + "<p class=\"notrun\">no views recorded</p>\n</section>\n";
    return html + missingStage(manifest, "render") + "</section>\n";
  }
  const std::optional<double> referencePixels = numberAt(render, {"overall", "apo", "pixels"});
  const bool hasReference = !(referencePixels && *referencePixels == 0.0);
  const std::optional<double> sizeOption = numberAt(render, {"options", "size"});
  const int size = sizeOption && *sizeOption >= 1.0 && *sizeOption <= 16384.0 ? static_cast<int>(*sizeOption) : 512;
  const std::string folder = rendersFolder(manifest);
  const bool pointsReference = referenceIsPoints(manifest);

  html += "<p>Each row: " + referenceName(manifest) +
          " (reference), the coarse mesh m with its own normals (baseline), m with the APO, and the APO's angular "
          "error against the reference per pixel.</p>\n";
  html += "<div class=\"legend\"><span>heat map: angular error of m with the APO against the reference</span>" +
          heatMapLegend() +
          "<span>(10&deg;+: 10 degrees or more; transparent: pixel not covered by both)</span></div>\n";
  const std::vector<ViewMeans> means = viewMeans(render, views);
  for (std::size_t i = 0; i < views->size(); ++i) {
    const Json& view = (*views)[i];
    const std::string nn = fmt::format("{:02d}", means[i].index);
    const std::string prefix = folder + "/view" + nn + "_";
    // Its direction, and for a one-sided scan which side it sees (render.json).
    const std::optional<std::string> label = textAt(&view, {"label"});
    const Json* sees = child(&view, "sees_scanned_side");
    std::string side;
    if (sees != nullptr && sees->is_boolean())
      side = sees->get<bool>() ? ", scanned side" : ", unscanned side: back faces tinted";
    html += fmt::format("<div class=\"view\" id=\"view{}\">\n<h3>View {}{}</h3>\n<p class=\"viewstats\">", nn, nn,
                        label ? " (" + htmlEscape(*label) + side + ")" : std::string());
    if (means[i].apoScan)
      html += "mean angular error against the scan's points seen: " + meansText(means[i].apoScan, means[i].baselineScan) +
              (pointsReference ? " &middot; rendered against them: " : " &middot; against M: ");
    else
      html += "mean angular error: ";
    html += meansText(means[i].apo, means[i].baseline);
    html += fmt::format(" &middot; image MAE (of 255): m with APO <b>{}</b>, m alone {}",
                        fixed(numberAt(&view, {"apo", "image", "mean_absolute_error"}), 2),
                        fixed(numberAt(&view, {"baseline", "image", "mean_absolute_error"}), 2));
    html += "</p>\n<div class=\"quad\">\n";
    const std::string title = "View " + nn + ": ";
    const std::string reference = pointsReference ? "reference: the scan's points" : "reference M";
    if (hasReference)
      html += imageCell(prefix + "reference.png", title + reference, reference, size);
    else
      html += missingImageCell("reference", "no reference");
    html += imageCell(prefix + "baseline.png", title + "baseline m", "baseline: m alone", size);
    html += imageCell(prefix + "apo.png", title + "m with APO", "m with APO", size);
    if (hasReference)
      html += imageCell(prefix + "apo_error.png", title + "APO error heat map", "APO error (0&ndash;10&deg;)", size);
    else
      html += missingImageCell("APO error", "no reference");
    html += "</div>\n</div>\n";
  }
  return html + "</section>\n";
}

std::string chartsSection(const Json& manifest) {
  std::string html = "<section id=\"charts\">\n<h2>Charts</h2>\n<div class=\"charts\">\n";
  html += "<div class=\"chart\"><h3>Mean angular error per view</h3>\n";
  const Json* views = at(results(manifest, "render"), {"views"});
  if (views != nullptr && views->is_array() && !views->empty())
    html += viewErrorSvg(viewMeans(views));
  else
    html += missingStage(manifest, "render");
  html += "</div>\n<div class=\"chart\"><h3>Octree nodes per depth</h3>\n";
  const Json* bake = results(manifest, "bake");
  const Json* perDepth = at(bake, {"nodes", "per_depth"});
  if (perDepth != nullptr && perDepth->is_array() && !perDepth->empty()) {
    html += nodesPerDepthSvg(*perDepth);
    double total = 0.0;
    for (const Json& v : *perDepth) total += number(&v).value_or(0.0);
    html += fmt::format("<p class=\"meta\">{} nodes: {} leaves, {} internal; depth 0 is the root cell.</p>\n",
                        count(total), count(numberAt(bake, {"nodes", "leaves"})), count(numberAt(bake, {"nodes", "internal"})));
  } else if (bake != nullptr) {
    html += "<p class=\"notrun\">no nodes per depth recorded</p>\n";
  } else {
    html += missingStage(manifest, "bake");
  }
  return html + "</div>\n</div>\n</section>\n";
}

// Mean over the views of one image figure (nulls and missing values skipped).
std::optional<double> meanOverViews(const Json* views, const char* pass, const char* figure) {
  if (views == nullptr || !views->is_array()) return std::nullopt;
  double sum = 0.0;
  int n = 0;
  for (const Json& view : *views)
    if (auto v = numberAt(&view, {pass, "image", figure})) {
      sum += *v;
      ++n;
    }
  return n > 0 ? std::optional<double>(sum / n) : std::nullopt;
}

std::string psnrText(const Json& view, const char* pass) {
  const Json* psnr = at(&view, {pass, "image", "psnr_db"});
  if (psnr != nullptr && psnr->is_null()) return "&infin; (identical)";
  return fixed(number(psnr), 1);
}

// A point scan's asset judged against the scan's own points (probes on m,
// truth from the 8 nearest scan normals), beside the figures against M.
std::string againstScanTable(const Json* scan) {
  if (scan == nullptr || !scan->is_object()) return "";
  std::string html =
      "<table class=\"metrics\">\n<thead><tr><th>against the scan's own points</th><th class=\"n\">m with APO "
      "(filtered)</th><th class=\"n\">m alone</th><th class=\"n\">M</th></tr></thead>\n<tbody>\n";
  for (const auto& [label, key] : {std::pair{"mean", "mean"}, {"median", "median"}, {"95th percentile", "p95"}})
    html += fmt::format("<tr><td>angular error, {}</td><td class=\"n\">{}</td><td class=\"n\">{}</td><td class=\"n\">{}</td></tr>\n",
                        label, degrees(numberAt(scan, {"apo_filtered", key})), degrees(numberAt(scan, {"m", key})),
                        degrees(numberAt(scan, {"M", "normal_degrees", key})));
  html += fmt::format("<tr><td>probes on m (kept: over scan points)</td><td class=\"n\" colspan=\"2\">{} of {}</td>"
                      "<td class=\"n\">{} scan points</td></tr>\n",
                      count(numberAt(scan, {"probes_kept"})), count(numberAt(scan, {"probes"})),
                      count(numberAt(scan, {"M", "scan_points"})));
  html += fmt::format("<tr><td>scan points' distance to M, mean / 95th percentile (of the diagonal)</td>"
                      "<td class=\"n\" colspan=\"3\">{} / {}</td></tr>\n",
                      fixed(numberAt(scan, {"M", "mean_distance"}), 5), fixed(numberAt(scan, {"M", "p95_distance"}), 5));
  return html + "</tbody>\n</table>\n";
}

// Auto baked the APO from the points but the renders' reference was M (runs
// before 2026-12-04): the figures above measure M's distance from the scan
// as much as the APO's.
std::string bakedFromPointsNote(const Json& manifest) {
  const Json* choice = at(results(manifest, "bake"), {"detail_source"});
  if (textAt(choice, {"option"}) != "auto" || textAt(choice, {"chosen"}) != "points") return "";
  if (referenceIsPoints(manifest)) return "";
  return "<p class=\"meta\">The APO was baked from the scan's points, which it follows closer than M does (Bake "
         "section); these figures compare it with M, so they include M's own distance from the scan. The figures "
         "against the scan judge it.</p>\n";
}

std::string metricsSection(const Json& manifest) {
  std::string html = "<section id=\"metrics\">\n<h2>Metrics</h2>\n";
  const Json* render = results(manifest, "render");
  if (render == nullptr) return html + missingStage(manifest, "render") + "</section>\n";
  const Json* overall = child(render, "overall");
  const Json* views = child(render, "views");
  html += "<div class=\"grid2\">\n<table class=\"metrics\">\n<thead><tr><th>over all views</th><th class=\"n\">m with APO</th>"
          "<th class=\"n\">m alone (baseline)</th></tr></thead>\n<tbody>\n";
  const auto angleRow = [&](const char* label, const char* key) {
    html += fmt::format("<tr><td>angular error, {}</td><td class=\"n\">{}</td><td class=\"n\">{}</td></tr>\n", label,
                        degrees(numberAt(overall, {"apo", key})), degrees(numberAt(overall, {"baseline", key})));
  };
  angleRow("mean", "mean");
  angleRow("median", "median");
  angleRow("95th percentile", "p95");
  angleRow("max", "max");
  html += fmt::format("<tr><td>pixels compared</td><td class=\"n\">{}</td><td class=\"n\">{}</td></tr>\n",
                      count(numberAt(overall, {"apo", "pixels"})), count(numberAt(overall, {"baseline", "pixels"})));
  html += fmt::format("<tr><td>baseline mean / APO mean</td><td class=\"n\" colspan=\"2\">{}</td></tr>\n",
                      fixed(numberAt(overall, {"baseline_over_apo"}), 2));
  const auto imageRow = [&](const char* label, const char* figure, int digits) {
    html += fmt::format("<tr><td>{} (mean over views)</td><td class=\"n\">{}</td><td class=\"n\">{}</td></tr>\n", label,
                        fixed(meanOverViews(views, "apo", figure), digits), fixed(meanOverViews(views, "baseline", figure), digits));
  };
  imageRow("image MAE, of 255", "mean_absolute_error", 2);
  imageRow("image PSNR, dB", "psnr_db", 1);
  imageRow("image SSIM", "ssim", 3);
  imageRow("silhouette mismatch", "silhouette_mismatch", 4);
  html += "</tbody>\n</table>\n";
  html += bakedFromPointsNote(manifest);
  html += againstScanTable(child(render, "against_scan"));

  if (views != nullptr && views->is_array() && !views->empty()) {
    const std::vector<ViewMeans> means = viewMeans(render, views);
    const bool scanColumns = hasScanMeans(means);
    html += "<table class=\"per-view\">\n<thead><tr><th>view</th>";
    if (scanColumns) html += "<th class=\"n\">APO mean, against the scan</th><th class=\"n\">baseline mean, against the scan</th>";
    html += "<th class=\"n\">APO mean</th><th class=\"n\">baseline mean</th>"
            "<th class=\"n\">APO MAE</th><th class=\"n\">baseline MAE</th><th class=\"n\">APO PSNR dB</th>"
            "<th class=\"n\">baseline PSNR dB</th><th class=\"n\">APO SSIM</th><th class=\"n\">baseline SSIM</th></tr></thead>\n<tbody>\n";
    for (std::size_t i = 0; i < views->size(); ++i) {
      const Json& view = (*views)[i];
      const std::string scanCells =
          scanColumns ? fmt::format("<td class=\"n\">{}</td><td class=\"n\">{}</td>", degrees(means[i].apoScan),
                                    degrees(means[i].baselineScan))
                      : std::string();
      html += fmt::format(
          "<tr><td>{:02d}</td>{}<td class=\"n\">{}</td><td class=\"n\">{}</td><td class=\"n\">{}</td><td class=\"n\">{}</td>"
          "<td class=\"n\">{}</td><td class=\"n\">{}</td><td class=\"n\">{}</td><td class=\"n\">{}</td></tr>\n",
          means[i].index, scanCells, degrees(means[i].apo), degrees(means[i].baseline),
          fixed(numberAt(&view, {"apo", "image", "mean_absolute_error"}), 2),
          fixed(numberAt(&view, {"baseline", "image", "mean_absolute_error"}), 2), psnrText(view, "apo"),
          psnrText(view, "baseline"), fixed(numberAt(&view, {"apo", "image", "ssim"}), 3),
          fixed(numberAt(&view, {"baseline", "image", "ssim"}), 3));
    }
    html += "</tbody>\n</table>\n";
  }
  return html + "</div>\n</section>\n";
}

std::string stagesSection(const Json& manifest) {
  std::string html = "<section id=\"stages\">\n<h2>Stages: time and memory</h2>\n";
  const Json* stages = child(&manifest, "stages");
  if (stages == nullptr || !stages->is_array() || stages->empty()) return html + "<p class=\"notrun\">no stages recorded (not run)</p>\n</section>\n";
  html += "<table class=\"stages\">\n<thead><tr><th>stage</th><th>status</th><th class=\"n\">wall time</th>"
          "<th class=\"n\">peak memory</th></tr></thead>\n<tbody>\n";
  for (const Json& stage : *stages) {
    const std::string status = textAt(&stage, {"status"}).value_or("unknown");
    const bool known = status == "succeeded" || status == "failed" || status == "skipped" || status == "not_run";
    const bool ran = status == "succeeded" || status == "failed";
    html += fmt::format("<tr><td>{}</td><td class=\"status-{}\">{}</td><td class=\"n\">{}</td><td class=\"n\">{}</td></tr>\n",
                        escaped(textAt(&stage, {"name"})), known ? status : "unknown",
                        status == "not_run" ? "not run" : htmlEscape(status),
                        ran ? seconds(numberAt(&stage, {"seconds"})) : kNone,
                        ran ? bytesText(numberAt(&stage, {"peak_memory_bytes"})) : kNone);
  }
  html += fmt::format("<tr><td><b>total</b></td><td></td><td class=\"n\"><b>{}</b></td><td></td></tr>\n",
                      seconds(totalSeconds(manifest)));
  return html + "</tbody>\n</table>\n</section>\n";
}

std::string row(const std::string& label, const std::string& value) {
  return "<tr><td>" + label + "</td><td class=\"n\">" + value + "</td></tr>\n";
}

// What ingest decided on its own about a mesh (surface or scans, windings
// flipped) and about far coordinates, in words; empty when nothing to say.
std::string ingestDecisionRows(const Json* ingest) {
  std::string html;
  if (const Json* input = at(ingest, {"mesh_input"}); input != nullptr && input->is_object()) {
    const std::optional<double> overlap = numberAt(input, {"overlap_fraction"});
    html += row("mesh read as", escaped(textAt(input, {"decision"})) +
                                    fmt::format(" ({} pieces, {} of the vertices within 3 edge lengths of another piece)",
                                                count(numberAt(input, {"pieces"})),
                                                overlap ? fmt::format("{:.0f}%", 100.0 * *overlap) : kNone));
  }
  if (const Json* sheets = at(ingest, {"mesh_input", "coincident_sheets"});
      sheets != nullptr && sheets->is_object() && numberAt(sheets, {"turned_pieces"}).value_or(0) > 0)
    html += row("scans of a sheet seen from both sides, turned to face one way",
                count(numberAt(sheets, {"turned_points"})) + " points in " + count(numberAt(sheets, {"turned_pieces"})) +
                    " pieces");
  if (const Json* grid = at(ingest, {"grid_mesh"}); grid != nullptr && grid->is_object())
    html += row("organised cloud triangulated on its grid",
                count(numberAt(grid, {"width"})) + " x " + count(numberAt(grid, {"height"})) + " pixels, " +
                    count(numberAt(grid, {"pixels_without_return"})) + " without a return; " +
                    count(numberAt(grid, {"triangles"})) + " triangles facing the sensor (" +
                    escaped(textAt(grid, {"sensor_from"})) + "), " + count(numberAt(grid, {"refused_triangles"})) +
                    " refused across depth jumps (edges over " + fixed(numberAt(grid, {"max_edge_in_spacings"}), 1) +
                    " ray spacings) or grazing");
  if (const Json* faces = at(ingest, {"face_orientation"}); faces != nullptr && faces->is_object() &&
                                                             numberAt(faces, {"flipped_triangles"}).value_or(0) > 0)
    html += row("faces wound inward, flipped", count(numberAt(faces, {"flipped_triangles"})) + " triangles in " +
                                                   count(numberAt(faces, {"flipped_pieces"})) + " pieces");
  if (const Json* origin = at(ingest, {"origin"}); origin != nullptr && origin->is_array() && origin->size() == 3 &&
                                                   (*origin != Json::array({0, 0, 0})))
    html += row("local frame origin (file coordinates = origin + outputs')", escaped(anyAsText(*origin)));
  if (const Json* notes = at(ingest, {"read_notes"}); notes != nullptr && notes->is_array())
    for (const Json& note : *notes) html += row("reader note", escaped(text(&note)));
  return html;
}

std::string meshesSection(const Json& manifest) {
  std::string html = "<section id=\"meshes\">\n<h2>Scan and meshes</h2>\n<div class=\"grid2\">\n";
  const Json* ingest = results(manifest, "ingest");
  html += "<div><h3>Scan (ingest)</h3>\n";
  if (ingest != nullptr) {
    html += "<table>\n";
    html += row("kind", escaped(textAt(ingest, {"kind"})));
    html += row("format", escaped(textAt(ingest, {"input", "format"})));
    html += row("points read", count(numberAt(ingest, {"counts", "points_in"})));
    html += row("points after cleaning", count(numberAt(ingest, {"counts", "points_out"})));
    html += row("triangles read", count(numberAt(ingest, {"counts", "triangles_in"})));
    html += row("normals", escaped(textAt(ingest, {"normals", "source"})) + ", oriented by " +
                               escaped(textAt(ingest, {"normals", "orientation"})));
    html += ingestDecisionRows(ingest);
    html += row("bounding box diagonal", fixed(numberAt(ingest, {"bounding_box", "diagonal"}), 4));
    html += "</table>\n";
  } else {
    html += missingStage(manifest, "ingest");
  }
  html += "</div>\n<div><h3>Dense mesh M</h3>\n";
  const Json* reconstruct = results(manifest, "reconstruct");
  if (reconstruct != nullptr) {
    html += "<table>\n";
    html += row("triangles", count(numberAt(reconstruct, {"mesh", "triangles"})));
    html += row("vertices", count(numberAt(reconstruct, {"mesh", "vertices"})));
    html += row("method", escaped(textAt(reconstruct, {"method"})));
    html += row("points used", count(numberAt(reconstruct, {"points", "used"})));
    html += row("mean point-to-M distance (of bbox diagonal)", fixed(numberAt(reconstruct, {"points_to_mesh", "mean"}), 5));
    html += "</table>\n";
  } else if (stageStatus(manifest, "reconstruct") == "skipped" && denseTriangles(manifest)) {
    html += "<p>The scan is a mesh: M is the input mesh (reconstruction skipped).</p>\n<table>\n";
    html += row("triangles", count(denseTriangles(manifest)));
    html += "</table>\n";
  } else {
    html += missingStage(manifest, "reconstruct");
  }
  html += "</div>\n<div><h3>Coarse mesh m</h3>\n";
  const Json* simplify = results(manifest, "simplify");
  if (simplify != nullptr) {
    html += "<table>\n";
    html += row("triangles", count(coarseTriangles(manifest)));
    html += row("target", count(numberAt(simplify, {"faces", "target"})));
    html += row("vertices", count(numberAt(simplify, {"mesh", "vertices"})));
    html += row("policy", escaped(textAt(simplify, {"policy"})));
    html += row("Hausdorff distance to M (of bbox diagonal)", fixed(numberAt(simplify, {"distance_to_input", "hausdorff"}), 5));
    html += "</table>\n";
  } else {
    html += missingStage(manifest, "simplify");
  }
  return html + "</div>\n</div>\n</section>\n";
}

// Why the APO was baked from what it was baked from (--detail-source), with
// the two candidates' errors against the scan when auto compared them.
std::string detailChoiceRow(const Json* choice) {
  if (choice == nullptr || !choice->is_object()) return {};
  std::string text = escaped(textAt(choice, {"chosen"})) + " (" + escaped(textAt(choice, {"option"})) + ": " +
                     escaped(textAt(choice, {"reason"}));
  if (const Json* candidates = child(choice, "candidates"); candidates != nullptr && candidates->is_object())
    text += fmt::format("; against the scan, baked from M {} in {}, from the points {} in {}",
                        degrees(numberAt(candidates, {"mesh", "against_scan_mean_degrees"})),
                        bytesText(numberAt(candidates, {"mesh", "texture_bytes"})),
                        degrees(numberAt(candidates, {"points", "against_scan_mean_degrees"})),
                        bytesText(numberAt(candidates, {"points", "texture_bytes"})));
  return row("baked from", text + ")");
}

// When the bake took M's triangles in Morton order (bake.json
// detail.faces_reordered, docs/bake.md), a row saying so and why; nothing
// otherwise, or from a manifest made before the key.
std::string faceOrderRow(const Json* bake) {
  const Json* reordered = at(bake, {"detail", "faces_reordered"});
  if (reordered == nullptr || !reordered->is_boolean() || !reordered->get<bool>()) return {};
  const std::optional<double> spread = numberAt(bake, {"detail", "face_order_spread"});
  return row("M's triangles", fmt::format("taken in Morton order: the file lists them in no order in space "
                                          "(consecutive ones {} edges apart, median)",
                                          spread ? fmt::format("{:.0f}", *spread) : std::string(kNone)));
}

std::string bakeSection(const Json& manifest) {
  std::string html = "<section id=\"bake\">\n<h2>Bake</h2>\n";
  const Json* bake = results(manifest, "bake");
  if (bake == nullptr) return html + missingStage(manifest, "bake") + "</section>\n";
  const std::optional<double> rays = numberAt(bake, {"sampling", "rays"});
  const std::optional<double> hit = numberAt(bake, {"sampling", "samples_hit"});
  const std::optional<double> fallback = numberAt(bake, {"sampling", "samples_fallback"});
  const Json* perDepth = at(bake, {"nodes", "per_depth"});
  html += "<div class=\"grid2\">\n<table>\n";
  html += row("detail M", escaped(textAt(bake, {"detail", "kind"})) + ", " + count(numberAt(bake, {"detail", "primitives"})) + " primitives");
  html += detailChoiceRow(child(bake, "detail_source"));
  html += faceOrderRow(bake);
  html += row("rays cast", count(rays));
  html += row("samples hit by a ray", count(hit));
  std::string fallbackText = count(fallback);
  if (hit && fallback && *hit + *fallback > 0.0)
    fallbackText += fmt::format(" ({:.2f}%)", 100.0 * *fallback / (*hit + *fallback));
  html += row("samples by closest point (ray missed)", fallbackText);
  html += row("octree depth", perDepth != nullptr && perDepth->is_array() && !perDepth->empty()
                                  ? std::to_string(perDepth->size() - 1)
                                  : std::string(kNone));
  html += row("leaves", count(numberAt(bake, {"nodes", "leaves"})));
  html += row("texture", count(numberAt(bake, {"texture", "width"})) + " &times; " + count(numberAt(bake, {"texture", "height"})) +
                             " texels, " + bytesText(numberAt(bake, {"texture", "bytes"})));
  html += "</table>\n<table>\n<thead><tr><th>bake step</th><th class=\"n\">seconds</th></tr></thead>\n";
  for (const char* step : {"setup", "build", "sample", "encode", "total"})
    html += row(step, seconds(numberAt(bake, {"seconds", step})));
  html += row("peak memory", bytesText(numberAt(bake, {"peak_memory_bytes"})));
  return html + "</table>\n</div>\n</section>\n";
}

std::string renderCostSection(const Json& manifest) {
  std::string html = "<section id=\"render-cost\">\n<h2>Render cost</h2>\n";
  const Json* render = results(manifest, "render");
  if (render == nullptr) return html + missingStage(manifest, "render") + "</section>\n";
  const Json* cost = at(render, {"overall", "cost"});
  const Json* options = child(render, "options");
  const auto flag = [&](const char* key) {
    const Json* v = child(options, key);
    return v != nullptr && v->is_boolean() ? std::string(v->get<bool>() ? "on" : "off") : std::string(kNone);
  };
  html += "<p class=\"meta\">Median wall time of one frame (Mesa llvmpipe, software rendering), mean over the views.</p>\n";
  html += "<table>\n";
  html += row("image size", count(numberAt(options, {"size"})) + " px, " + count(numberAt(options, {"views"})) + " views");
  html += row("mip-mapping / filtering", flag("mipmapping") + " / " + flag("filtering"));
  // What the APO pass walked (docs/render.md): the APO texture, or the same
  // octree as GPU Gems 2's N^3-tree (--layout n3tree).
  const std::optional<std::string> layout = textAt(render, {"layout", "name"});
  if (layout && *layout == "n3tree")
    html += row("octree drawn as", "GPU Gems 2's N^3-tree, N = " + count(numberAt(render, {"layout", "n"})) + " (scan.n3t)");
  html += row("frame, reference", fixed(numberAt(cost, {"reference_frame_ms"}), 2) + " ms");
  // M as points goes through the point LOD: what it sent and drew.
  const std::optional<double> sent = numberAt(cost, {"reference_primitives", "sent"});
  if (sent)
    html += row("reference primitives, sent / drawn per view", count(sent) + " / " +
                                                                 count(numberAt(cost, {"reference_primitives", "drawn"})));
  html += row("frame, m alone", fixed(numberAt(cost, {"baseline_frame_ms"}), 2) + " ms");
  html += row("frame, m with APO", fixed(numberAt(cost, {"apo_frame_ms"}), 2) + " ms");
  html += row("texel reads per fragment, mean / max", fixed(numberAt(cost, {"apo_texel_fetches", "mean"}), 2) + " / " +
                                                          count(numberAt(cost, {"apo_texel_fetches", "max"})));
  html += row("fragments counted", count(numberAt(cost, {"apo_texel_fetches", "fragments"})));
  return html + "</table>\n</section>\n";
}

std::string optionsSection(const Json& manifest) {
  const Json* options = child(&manifest, "options");
  std::string html = "<section id=\"options\">\n<h2>Options</h2>\n";
  if (options == nullptr || !options->is_object() || options->empty())
    return html + "<p class=\"notrun\">no options recorded</p>\n</section>\n";
  html += "<details><summary>every option of every stage, as run</summary>\n<table>\n";
  for (const auto& [stage, values] : options->items()) {
    if (values.is_object()) {
      for (const auto& [key, value] : values.items())
        html += "<tr><td>" + htmlEscape(stage) + "</td><td>" + htmlEscape(key) + "</td><td>" + htmlEscape(anyAsText(value)) +
                "</td></tr>\n";
    } else {
      html += "<tr><td>" + htmlEscape(stage) + "</td><td></td><td>" + htmlEscape(anyAsText(values)) + "</td></tr>\n";
    }
  }
  return html + "</table>\n</details>\n</section>\n";
}

std::string filesFooter(const Json& manifest) {
  std::string html = "<footer>\n";
  const Json* files = child(&manifest, "files");
  if (files != nullptr && files->is_object() && !files->empty()) {
    html += "files:";
    for (const auto& [key, value] : files->items())
      if (value.is_string())
        html += " <a href=\"" + htmlEscape(urlPathEscape(value.get<std::string>())) + "\">" + htmlEscape(key) + "</a>";
    html += " &middot; ";
  }
  return html + "<a href=\"manifest.json\">manifest.json</a> &middot; written by apo run; works offline.\n</footer>\n";
}

std::string scanName(const Json& manifest) {
  if (auto name = textAt(&manifest, {"input", "name"}); name && !name->empty()) return *name;
  if (auto path = textAt(&manifest, {"input", "path"}); path && !path->empty()) {
    const std::size_t slash = path->find_last_of('/');
    return slash == std::string::npos ? *path : path->substr(slash + 1);
  }
  return "unnamed scan";
}

// The page shown if building the real one failed (it should not): the
// exception's message, escaped.
std::string fallbackPage(const std::string& what) {
  return pageStart("apo QA report") + "<h1>apo QA report</h1>\n<div class=\"banner bad\">this manifest could not be shown: " +
         htmlEscape(what) + "</div>\n" + kPageEnd;
}

// ---- index.html ----------------------------------------------------------------------

std::string indexStatus(const Json& manifest) {
  const std::string status = textAt(&manifest, {"status"}).value_or("");
  if (status == "succeeded") return "<span class=\"status-succeeded\">succeeded</span>";
  if (status == "failed")
    return "<span class=\"status-failed\">FAILED</span><div class=\"errmsg\">" + failureHtml(manifest, true) + "</div>";
  if (status == "running") return "<span class=\"status-running\">did not finish</span>";
  if (status == "not_processed")
    return "<span class=\"status-skipped\">not processed</span><div class=\"errmsg\">" +
           escaped(textAt(&manifest, {"reason"})) + "</div>";
  if (!manifest.is_object() || manifest.empty()) return "<span class=\"status-unknown\">no manifest</span>";
  return "<span class=\"status-unknown\">" + (status.empty() ? std::string("unknown") : htmlEscape(status)) + "</span>";
}

std::string indexRow(const BatchRow& scan) {
  const Json& manifest = scan.manifest;
  const std::string status = textAt(&manifest, {"status"}).value_or("");
  std::string dir = scan.relativeDir;
  while (!dir.empty() && dir.back() == '/') dir.pop_back();
  const std::string base = dir.empty() ? std::string() : dir + "/";
  std::string html =
      status == "failed" || status == "running" || status == "not_processed" || manifest.empty() ? "<tr class=\"failed\">"
                                                                                                  : "<tr>";

  // Thumbnail
  const Json* render = results(manifest, "render");
  const Json* views = child(render, "views");
  const bool rendered = stageStatus(manifest, "render") == "succeeded" && views != nullptr && views->is_array() && !views->empty();
  if (rendered)
  {
    // The thumbnail opens the scan's interactive view when the run made one.
    const std::optional<std::string> viewer = textAt(&manifest, {"files", "viewer"});
    const std::string image = "<img src=\"" + htmlEscape(urlPathEscape(base + rendersFolder(manifest) + "/view00_apo.png")) +
                              "\" alt=\"" + htmlEscape(dir) + ", view 00 with APO\" width=\"96\" height=\"96\">";
    html += "<td class=\"thumb\">" +
            (viewer ? "<a href=\"" + htmlEscape(urlPathEscape(base + *viewer)) + "\" title=\"interactive view\">" + image + "</a>"
                    : image) +
            "</td>";
  }
  else
    html += "<td class=\"thumb\"></td>";

  // Name and link
  const bool hasReport = textAt(&manifest, {"files", "report"}).has_value() || status == "succeeded";
  const std::string name = dir.empty() || dir == "." ? scanName(manifest) : dir;
  if (status == "not_processed")
    html += "<td>" + htmlEscape(name) + "</td>";  // nothing was written for it
  else if (hasReport)
    html += "<td><a href=\"" + htmlEscape(urlPathEscape(base + "report.html")) + "\">" + htmlEscape(name) + "</a></td>";
  else
    html += "<td>" + htmlEscape(name) + " <a class=\"meta\" href=\"" + htmlEscape(urlPathEscape(base + "manifest.json")) +
            "\">manifest</a> <a class=\"meta\" href=\"" + htmlEscape(urlPathEscape(base + "run.log")) + "\">log</a></td>";

  html += "<td>" + indexStatus(manifest) + "</td>";
  html += "<td class=\"n\">" + count(pointsIn(manifest)) + "</td>";
  html += "<td class=\"n\">" + count(denseTriangles(manifest)) + "</td>";
  html += "<td class=\"n\">" + count(coarseTriangles(manifest)) + "</td>";
  html += "<td class=\"n\">" + bytesText(numberAt(results(manifest, "bake"), {"texture", "bytes"})) + "</td>";
  const std::optional<double> apoMean = numberAt(render, {"overall", "apo", "mean"});
  const std::optional<double> baselineMean = numberAt(render, {"overall", "baseline", "mean"});
  html += "<td class=\"n\">" + degrees(apoMean) + " / " + degrees(baselineMean);
  const Json* simplify = results(manifest, "simplify");
  const std::optional<double> facesIn = numberAt(simplify, {"faces", "in"}), facesOut = numberAt(simplify, {"faces", "out"});
  if (facesIn && facesOut && *facesIn == *facesOut)
    html += " (m is M)";  // nothing was simplified: m's own normals are M's
  else if (apoMean && baselineMean && *apoMean > 0.0)
    html += " (" + ratioText(*baselineMean / *apoMean) + "&times;)";
  html += "</td>";
  html += "<td class=\"n\">" + seconds(totalSeconds(manifest)) + "</td>";
  return html + "</tr>\n";
}

}  // namespace

std::string htmlEscape(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&#39;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string urlPathEscape(std::string_view path) {
  std::string out;
  if (!path.empty() && path.front() == '/') out = "./";  // "//host/x" would name another host
  for (const char c : path) {
    const auto byte = static_cast<unsigned char>(c);
    const bool unreserved = (byte >= 'A' && byte <= 'Z') || (byte >= 'a' && byte <= 'z') || (byte >= '0' && byte <= '9') ||
                            byte == '-' || byte == '.' || byte == '_' || byte == '~' || byte == '/';
    if (unreserved)
      out += c;
    else
      out += fmt::format("%{:02X}", byte);
  }
  return out;
}

std::string qaReportHtml(const nlohmann::json& manifest) {
  try {
    const std::string name = scanName(manifest);
    std::string html = pageStart("apo QA report: " + htmlEscape(name));
    html += header(manifest, name);
    html += verdict(manifest);
    html += interactiveSection(manifest);
    html += viewsSection(manifest);
    html += chartsSection(manifest);
    html += metricsSection(manifest);
    html += meshesSection(manifest);
    html += bakeSection(manifest);
    html += renderCostSection(manifest);
    html += stagesSection(manifest);
    html += optionsSection(manifest);
    html += filesFooter(manifest);
    return html + kPageEnd;
  } catch (const std::exception& e) {
    return fallbackPage(e.what());
  }
}

std::string batchIndexHtml(const std::vector<BatchRow>& rows, const nlohmann::json& summary) {
  try {
    std::string html = pageStart("apo batch: " + count(numberAt(&summary, {"scans"})) + " scans");
    html += "<header>\n<h1>apo batch</h1>\n";
    const std::optional<double> failed = numberAt(&summary, {"failed"});
    const std::optional<double> notProcessed = numberAt(&summary, {"not_processed"});
    const bool bad = (failed && *failed > 0.0) || (notProcessed && *notProcessed > 0.0);
    html += fmt::format("<div class=\"banner {}\">{} scans: {} succeeded, {} failed, {} up to date (not redone){} &middot; {}</div>\n",
                        bad ? "bad" : "ok", count(numberAt(&summary, {"scans"})),
                        count(numberAt(&summary, {"succeeded"})), count(failed),
                        count(numberAt(&summary, {"skipped_up_to_date"})),
                        notProcessed && *notProcessed > 0.0 ? "; " + count(notProcessed) + " files not processed" : "",
                        seconds(numberAt(&summary, {"seconds"})));
    html += "</header>\n<table class=\"index\">\n<thead><tr><th></th><th>scan</th><th>status</th><th class=\"n\">points</th>"
            "<th class=\"n\">M triangles</th><th class=\"n\">m triangles</th><th class=\"n\">APO texture</th>"
            "<th class=\"n\">mean angular error<br>APO / m alone</th><th class=\"n\">time</th></tr></thead>\n<tbody>\n";
    for (const BatchRow& scan : rows) html += indexRow(scan);
    if (rows.empty()) html += "<tr><td colspan=\"9\" class=\"notrun\">no scans</td></tr>\n";
    html += "</tbody>\n</table>\n<footer>Each scan's folder holds its report.html, manifest.json and run.log; "
            "summary.json holds the counts above.</footer>\n";
    return html + kPageEnd;
  } catch (const std::exception& e) {
    return fallbackPage(e.what());
  }
}

}  // namespace apo
