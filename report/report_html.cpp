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

// A non-empty array.
bool isFilledArray(const Json* json) { return json != nullptr && json->is_array() && !json->empty(); }

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

// ---- Sections and tables ----------------------------------------------------------------

std::string section(const char* id, const char* title, const std::string& body) {
  return fmt::format("<section id=\"{}\">\n<h2>{}</h2>\n", id, title) + body + "</section>\n";
}

// What stands in for something the manifest does not have.
std::string notRunParagraph(const std::string& why) { return "<p class=\"notrun\">" + why + "</p>\n"; }

std::string figureCell(const std::string& figure) { return "<td class=\"n\">" + figure + "</td>"; }

// A table row: a label, then its figures aligned right.
std::string figuresRow(const std::string& label, const std::vector<std::string>& figures) {
  std::string html = "<tr><td>" + label + "</td>";
  for (const std::string& figure : figures) html += figureCell(figure);
  return html + "</tr>\n";
}

std::string row(const std::string& label, const std::string& figure) { return figuresRow(label, {figure}); }

// A table's start and head: the text columns (left-aligned), then the
// figure columns (right-aligned); the rows and kTableEnd follow.
std::string tableStart(const char* cssClass, const std::vector<std::string>& textColumns,
                       const std::vector<std::string>& figureColumns) {
  std::string html = fmt::format("<table class=\"{}\">\n<thead><tr>", cssClass);
  for (const std::string& column : textColumns) html += "<th>" + column + "</th>";
  for (const std::string& column : figureColumns) html += "<th class=\"n\">" + column + "</th>";
  return html + "</tr></thead>\n<tbody>\n";
}

constexpr const char* kTableEnd = "</tbody>\n</table>\n";

// A table of label-and-figure rows (row()), without a head.
std::string rowsTable(const std::string& rows) { return "<table>\n" + rows + "</table>\n"; }

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
  return notRunParagraph(why);
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

// One bar: its height (none: an empty bar, still there for its tooltip) and
// its tooltip, already escaped.
struct Bar {
  std::optional<double> value;
  std::string title;
};

// Bars of one colour, one per category; `name` is its legend entry.
struct BarSeries {
  const char* cssClass;  // the rect's class is "bar " + cssClass
  const char* colour;
  std::string name;
  std::vector<Bar> bars;
};

// A bar chart: per category (x axis) one bar of each series side by side,
// on a y axis from 0 with round ticks. More than one series gets a legend.
struct BarChart {
  const char* cssClass;
  const char* ariaLabel;
  const char* xTitle;
  std::vector<std::string> categories;  // the x labels, escaped
  std::vector<BarSeries> series;
  std::string (*tickText)(double);  // a y tick's label; also the bars' own labels
  double tickWidth;                 // room left of the plot for the tick labels, px
  double minSlot, maxSlot;          // the width of a category, px
  bool labelBars;                   // each bar's value above it (when there is room, and always the tallest)
};

// The chart's largest value, 0 when it has none.
double maxValue(const BarChart& chart) {
  double max = 0.0;
  for (const BarSeries& series : chart.series)
    for (const Bar& bar : series.bars) max = std::max(max, bar.value.value_or(0.0));
  return max;
}

std::string legendSvg(const std::vector<BarSeries>& series, double left) {
  std::string svg;
  for (std::size_t s = 0; s < series.size(); ++s) {
    const double x = left + 110.0 * static_cast<double>(s);
    svg += fmt::format("<rect x=\"{:.0f}\" y=\"6\" width=\"12\" height=\"12\" fill=\"{}\"/><text x=\"{:.0f}\" y=\"16\" "
                       "font-size=\"12\">{}</text>",
                       x, series[s].colour, x + 16, series[s].name);
  }
  return svg + "\n";
}

std::string barChartSvg(const BarChart& chart) {
  const std::size_t n = chart.categories.size();
  const bool legend = chart.series.size() > 1;
  const double left = chart.tickWidth, right = 12, top = legend ? 30 : 22, bottom = 34, plotHeight = 190;
  const double minWidth = legend ? 300.0 : 0.0;  // the legend's own width
  const double slot = std::clamp(560.0 / static_cast<double>(std::max<std::size_t>(n, 1)), chart.minSlot, chart.maxSlot);
  const double width = std::max(left + right + slot * static_cast<double>(n), minWidth), height = top + plotHeight + bottom;
  const double max = maxValue(chart), step = niceStep(max, 4), topValue = max > 0.0 ? std::ceil(max / step) * step : 1.0;
  const double groupShare = chart.series.size() == 1 ? 0.7 : 0.76;  // of a slot, the rest is the gap between categories
  const double barWidth = slot * groupShare / static_cast<double>(std::max<std::size_t>(chart.series.size(), 1));
  std::string svg = fmt::format(
      "<svg class=\"{2}\" width=\"{0:.0f}\" height=\"{1:.0f}\" "
      "viewBox=\"0 0 {0:.0f} {1:.0f}\" role=\"img\" aria-label=\"{3}\">\n",
      width, height, chart.cssClass, chart.ariaLabel);
  // Grid lines and y ticks
  for (double v = 0.0; v <= topValue + 1e-9; v += step) {
    const double y = top + plotHeight - v / topValue * plotHeight;
    svg += fmt::format("<line x1=\"{:.1f}\" y1=\"{:.1f}\" x2=\"{:.1f}\" y2=\"{:.1f}\" stroke=\"#e4e4e4\"/>", left, y, width - right, y);
    svg += fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" font-size=\"11\" text-anchor=\"end\" fill=\"#555\">{}</text>\n",
                       left - 6, y + 4, chart.tickText(v));
  }
  if (legend) svg += legendSvg(chart.series, left);
  // Bars, grouped per category; a value above 0 gets at least a pixel
  for (std::size_t c = 0; c < n; ++c) {
    const double groupLeft = left + slot * static_cast<double>(c) + slot * (1.0 - groupShare) / 2.0;
    for (std::size_t s = 0; s < chart.series.size(); ++s) {
      const BarSeries& series = chart.series[s];
      const Bar& bar = series.bars[c];
      const double value = std::max(0.0, bar.value.value_or(0.0));
      const double h = value > 0.0 ? std::max(value / topValue * plotHeight, 1.0) : 0.0;
      const double x = groupLeft + barWidth * static_cast<double>(s), y = top + plotHeight - h;
      svg += fmt::format(
          "<rect class=\"bar {}\" x=\"{:.1f}\" y=\"{:.1f}\" width=\"{:.1f}\" height=\"{:.1f}\" fill=\"{}\">"
          "<title>{}</title></rect>",
          series.cssClass, x, y, barWidth, h, series.colour, bar.title);
      if (chart.labelBars && (slot >= 30.0 || value == max))
        svg += fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" font-size=\"10\" text-anchor=\"middle\" fill=\"#333\">{}</text>",
                           x + barWidth / 2, y - 4, chart.tickText(value));
    }
    svg += fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" font-size=\"11\" text-anchor=\"middle\" fill=\"#555\">{}</text>\n",
                       left + slot * (static_cast<double>(c) + 0.5), top + plotHeight + 15, chart.categories[c]);
  }
  // x axis and its title
  svg += fmt::format("<line x1=\"{0:.1f}\" y1=\"{1:.1f}\" x2=\"{2:.1f}\" y2=\"{1:.1f}\" stroke=\"#888\"/>", left,
                     top + plotHeight, width - right);
  svg += fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" font-size=\"12\" text-anchor=\"middle\" fill=\"#333\">{}</text>\n",
                     left + (width - left - right) / 2, height - 3, chart.xTitle);
  return svg + "</svg>\n";
}

std::string countTick(double value) { return count(value); }

std::string degreesTick(double value) { return tickLabel(value) + "&#176;"; }

// Octree nodes per depth: one bar (class "bar depth") per entry of `perDepth`.
std::string nodesPerDepthSvg(const Json& perDepth) {
  BarSeries nodes{"depth", "#3b528b", "octree nodes", {}};
  std::vector<std::string> depths;
  for (std::size_t d = 0; d < perDepth.size(); ++d) {
    const double value = std::max(0.0, number(&perDepth[d]).value_or(0.0));
    nodes.bars.push_back({value, fmt::format("depth {}: {} nodes", d, count(value))});
    depths.push_back(std::to_string(d));
  }
  return barChartSvg({"nodes-per-depth", "octree nodes per depth", "depth", depths, {nodes}, countTick, 64, 14, 56, true});
}

struct ViewMeans {
  int index = 0;
  std::optional<double> apo, baseline;
  std::optional<double> apoScan, baselineScan;  // against the scan's own points (point scans)
};

// Mean angular error per view, the APO (class "bar apo") beside the baseline
// (class "bar baseline").
std::string viewErrorSvg(const std::vector<ViewMeans>& views) {
  BarSeries apo{"apo", "#3b528b", "m with APO", {}}, baseline{"baseline", "#e07b39", "m alone (baseline)", {}};
  std::vector<std::string> labels;
  for (const ViewMeans& view : views) {
    apo.bars.push_back({view.apo, fmt::format("view {:02d}, m with APO: {}", view.index, degrees(view.apo))});
    baseline.bars.push_back({view.baseline, fmt::format("view {:02d}, m alone: {}", view.index, degrees(view.baseline))});
    labels.push_back(fmt::format("{:02d}", view.index));
  }
  return barChartSvg(
      {"view-errors", "mean angular error per view", "view", labels, {apo, baseline}, degreesTick, 48, 22, 70, false});
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
  std::string html = fmt::format(
      "<p>m with the APO walked per pixel in WebGL2, beside m alone, {} and the heat map; turn, zoom, move "
      "the light (<a href=\"{}\">open it alone</a>, {}). Without WebGL2 it shows the static views below "
      "and says why.</p>\n",
      escaped(textAt(&manifest, {"results", "viewer", "detail"})), src, bytesText(numberAt(&manifest, {"results", "viewer", "bytes"})));
  html += "<iframe class=\"viewer\" src=\"" + src + "\" title=\"interactive view\"></iframe>\n";
  return section("interactive", "Interactive view", html);
}

std::string viewsSection(const Json& manifest) {
  const Json* render = results(manifest, "render");
  const Json* views = child(render, "views");
  if (!isFilledArray(views))
    return section("views", "Views", render != nullptr ? notRunParagraph("no views recorded") : missingStage(manifest, "render"));
  const std::optional<double> referencePixels = numberAt(render, {"overall", "apo", "pixels"});
  const bool hasReference = !(referencePixels && *referencePixels == 0.0);
  const std::optional<double> sizeOption = numberAt(render, {"options", "size"});
  const int size = sizeOption && *sizeOption >= 1.0 && *sizeOption <= 16384.0 ? static_cast<int>(*sizeOption) : 512;
  const std::string folder = rendersFolder(manifest);
  const bool pointsReference = referenceIsPoints(manifest);

  std::string html = "<p>Each row: " + referenceName(manifest) +
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
  return section("views", "Views", html);
}

std::string chartsSection(const Json& manifest) {
  std::string html = "<div class=\"charts\">\n<div class=\"chart\"><h3>Mean angular error per view</h3>\n";
  const Json* views = at(results(manifest, "render"), {"views"});
  if (isFilledArray(views))
    html += viewErrorSvg(viewMeans(views));
  else
    html += missingStage(manifest, "render");
  html += "</div>\n<div class=\"chart\"><h3>Octree nodes per depth</h3>\n";
  const Json* bake = results(manifest, "bake");
  const Json* perDepth = at(bake, {"nodes", "per_depth"});
  if (isFilledArray(perDepth)) {
    html += nodesPerDepthSvg(*perDepth);
    double total = 0.0;
    for (const Json& v : *perDepth) total += number(&v).value_or(0.0);
    html += fmt::format("<p class=\"meta\">{} nodes: {} leaves, {} internal; depth 0 is the root cell.</p>\n",
                        count(total), count(numberAt(bake, {"nodes", "leaves"})), count(numberAt(bake, {"nodes", "internal"})));
  } else if (bake != nullptr) {
    html += notRunParagraph("no nodes per depth recorded");
  } else {
    html += missingStage(manifest, "bake");
  }
  return section("charts", "Charts", html + "</div>\n</div>\n");
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
  std::string html = tableStart("metrics", {"against the scan's own points"}, {"m with APO (filtered)", "m alone", "M"});
  for (const auto& [label, key] : {std::pair{"mean", "mean"}, {"median", "median"}, {"95th percentile", "p95"}})
    html += figuresRow(std::string("angular error, ") + label,
                       {degrees(numberAt(scan, {"apo_filtered", key})), degrees(numberAt(scan, {"m", key})),
                        degrees(numberAt(scan, {"M", "normal_degrees", key}))});
  html += fmt::format("<tr><td>probes on m (kept: over scan points)</td><td class=\"n\" colspan=\"2\">{} of {}</td>"
                      "<td class=\"n\">{} scan points</td></tr>\n",
                      count(numberAt(scan, {"probes_kept"})), count(numberAt(scan, {"probes"})),
                      count(numberAt(scan, {"M", "scan_points"})));
  html += fmt::format("<tr><td>scan points' distance to M, mean / 95th percentile (of the diagonal)</td>"
                      "<td class=\"n\" colspan=\"3\">{} / {}</td></tr>\n",
                      fixed(numberAt(scan, {"M", "mean_distance"}), 5), fixed(numberAt(scan, {"M", "p95_distance"}), 5));
  return html + kTableEnd;
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

// The APO's and the baseline's figures over all views.
std::string overallTable(const Json* overall, const Json* views) {
  std::string html = tableStart("metrics", {"over all views"}, {"m with APO", "m alone (baseline)"});
  for (const auto& [label, key] : {std::pair{"mean", "mean"}, {"median", "median"}, {"95th percentile", "p95"}, {"max", "max"}})
    html += figuresRow(std::string("angular error, ") + label,
                       {degrees(numberAt(overall, {"apo", key})), degrees(numberAt(overall, {"baseline", key}))});
  html += figuresRow("pixels compared",
                     {count(numberAt(overall, {"apo", "pixels"})), count(numberAt(overall, {"baseline", "pixels"}))});
  html += fmt::format("<tr><td>baseline mean / APO mean</td><td class=\"n\" colspan=\"2\">{}</td></tr>\n",
                      fixed(numberAt(overall, {"baseline_over_apo"}), 2));
  struct ImageFigure {
    const char* label;
    const char* key;
    int digits;
  };
  for (const ImageFigure& figure : {ImageFigure{"image MAE, of 255", "mean_absolute_error", 2}, {"image PSNR, dB", "psnr_db", 1},
                                    {"image SSIM", "ssim", 3}, {"silhouette mismatch", "silhouette_mismatch", 4}})
    html += figuresRow(std::string(figure.label) + " (mean over views)",
                       {fixed(meanOverViews(views, "apo", figure.key), figure.digits),
                        fixed(meanOverViews(views, "baseline", figure.key), figure.digits)});
  return html + kTableEnd;
}

// One row per view; the columns against the scan only for a point scan.
std::string perViewTable(const Json& views, const std::vector<ViewMeans>& means) {
  const bool scanColumns = hasScanMeans(means);
  std::vector<std::string> columns;
  if (scanColumns) columns = {"APO mean, against the scan", "baseline mean, against the scan"};
  columns.insert(columns.end(), {"APO mean", "baseline mean", "APO MAE", "baseline MAE", "APO PSNR dB", "baseline PSNR dB",
                                 "APO SSIM", "baseline SSIM"});
  std::string html = tableStart("per-view", {"view"}, columns);
  for (std::size_t i = 0; i < views.size(); ++i) {
    const Json& view = views[i];
    std::vector<std::string> figures;
    if (scanColumns) figures = {degrees(means[i].apoScan), degrees(means[i].baselineScan)};
    figures.insert(figures.end(),
                   {degrees(means[i].apo), degrees(means[i].baseline),
                    fixed(numberAt(&view, {"apo", "image", "mean_absolute_error"}), 2),
                    fixed(numberAt(&view, {"baseline", "image", "mean_absolute_error"}), 2), psnrText(view, "apo"),
                    psnrText(view, "baseline"), fixed(numberAt(&view, {"apo", "image", "ssim"}), 3),
                    fixed(numberAt(&view, {"baseline", "image", "ssim"}), 3)});
    html += figuresRow(fmt::format("{:02d}", means[i].index), figures);
  }
  return html + kTableEnd;
}

std::string metricsSection(const Json& manifest) {
  const Json* render = results(manifest, "render");
  if (render == nullptr) return section("metrics", "Metrics", missingStage(manifest, "render"));
  const Json* views = child(render, "views");
  std::string html = "<div class=\"grid2\">\n" + overallTable(child(render, "overall"), views);
  html += bakedFromPointsNote(manifest);
  html += againstScanTable(child(render, "against_scan"));
  if (isFilledArray(views)) html += perViewTable(*views, viewMeans(render, views));
  return section("metrics", "Metrics", html + "</div>\n");
}

// A split run's merge (`apo slurm SCAN --tasks N`): the stages its prepared
// part ran once, whose rows are that part's.
std::string splitParagraph(const Json& manifest) {
  const Json* prepared = child(child(&manifest, "split"), "prepared_stages");
  if (!isFilledArray(prepared)) return "";
  std::string names;
  for (const Json& name : *prepared)
    if (name.is_string()) names += (names.empty() ? "" : ", ") + htmlEscape(name.get<std::string>());
  return "<p>Split across tasks: " + names +
         " ran once, in the prepared part (their rows are its); the bake's passes ran in the array tasks, "
         "and the bake row is the merge's.</p>\n";
}

std::string stagesSection(const Json& manifest) {
  const Json* stages = child(&manifest, "stages");
  if (!isFilledArray(stages))
    return section("stages", "Stages: time and memory", notRunParagraph("no stages recorded (not run)"));
  std::string html = tableStart("stages", {"stage", "status"}, {"wall time", "peak memory"});
  for (const Json& stage : *stages) {
    const std::string status = textAt(&stage, {"status"}).value_or("unknown");
    const bool known = status == "succeeded" || status == "failed" || status == "skipped" || status == "not_run";
    const bool ran = status == "succeeded" || status == "failed";
    html += fmt::format("<tr><td>{}</td><td class=\"status-{}\">{}</td>{}{}</tr>\n", escaped(textAt(&stage, {"name"})),
                        known ? status : "unknown", status == "not_run" ? "not run" : htmlEscape(status),
                        figureCell(ran ? seconds(numberAt(&stage, {"seconds"})) : kNone),
                        figureCell(ran ? bytesText(numberAt(&stage, {"peak_memory_bytes"})) : kNone));
  }
  html += fmt::format("<tr><td><b>total</b></td><td></td><td class=\"n\"><b>{}</b></td><td></td></tr>\n",
                      seconds(totalSeconds(manifest)));
  return section("stages", "Stages: time and memory", html + kTableEnd + splitParagraph(manifest));
}

// The scan positions a multi-scan file gave, and whether the declared
// sensor position oriented the normals, or why not (docs/ingest.md).
std::string sensorRows(const Json* ingest) {
  std::string html;
  if (const Json* stations = at(ingest, {"scan_positions"}); stations != nullptr && stations->is_array() && !stations->empty()) {
    std::uint64_t points = 0;
    for (const Json& station : *stations) points += static_cast<std::uint64_t>(numberAt(&station, {"points"}).value_or(0));
    html += row("scans in the file", count(static_cast<double>(stations->size())) + " scan positions, " +
                                        count(static_cast<double>(points)) + " points in all");
  }
  const Json* sensor = at(ingest, {"sensor"});
  if (sensor == nullptr || !sensor->is_object()) return html;
  const std::string source = escaped(textAt(sensor, {"source"}));
  if (const Json* refused = at(sensor, {"refused"}); refused != nullptr && refused->is_string())
    return html + row("sensor position not used", source + ": " + escaped(text(refused)));
  if (const Json* agreement = at(sensor, {"agreement"}); agreement != nullptr && agreement->is_object()) {
    const double compared = numberAt(agreement, {"compared"}).value_or(0);
    const double disagreeing = numberAt(agreement, {"disagreeing"}).value_or(0);
    const std::string share = compared > 0 ? fmt::format("{:.1f}%", 100.0 * disagreeing / compared) : kNone;
    const bool kept = at(agreement, {"sensor_kept"}) != nullptr && at(agreement, {"sensor_kept"})->is_boolean() &&
                      at(agreement, {"sensor_kept"})->get<bool>();
    const double sampled = numberAt(agreement, {"sight_sampled"}).value_or(0);
    const std::string hidden =
        sampled > 0 ? fmt::format("{:.1f}%", 100.0 * numberAt(agreement, {"sight_hidden"}).value_or(0) / sampled) : kNone;
    html += row(kept ? "normals face the sensor position" : "sensor position not where the points were seen from, not used",
                source + ": " + share + " of the points oriented the other way by propagation, " + hidden +
                    " hidden from it");
  }
  return html;
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
  if (const Json* grid = at(ingest, {"grid_mesh"});
      grid != nullptr && grid->is_object() && textAt(grid, {"sensor_from"}) == "scan_positions")
    html += row("structured scans triangulated on their grids",
                count(numberAt(grid, {"triangles"})) + " triangles facing their scan positions, " +
                    count(numberAt(grid, {"refused_triangles"})) + " refused across depth jumps or grazing");
  else if (grid != nullptr && grid->is_object())
    html += row("organised cloud triangulated on its grid",
                count(numberAt(grid, {"width"})) + " x " + count(numberAt(grid, {"height"})) + " pixels, " +
                    count(numberAt(grid, {"pixels_without_return"})) + " without a return; " +
                    count(numberAt(grid, {"triangles"})) + " triangles facing the sensor (" +
                    escaped(textAt(grid, {"sensor_from"})) + "), " + count(numberAt(grid, {"refused_triangles"})) +
                    " refused across depth jumps (edges over " + fixed(numberAt(grid, {"max_edge_in_spacings"}), 1) +
                    " ray spacings) or grazing");
  const Json* store = at(ingest, {"point_store"});
  const bool stored = store != nullptr && store->is_object() && at(store, {"written"}) != nullptr &&
                      *at(store, {"written"}) == true;
  if (const Json* large = at(ingest, {"large_scan"}); large != nullptr && large->is_object())
    html += row("scan above --max-scan-points, read a run at a time into voxel centroids",
                count(numberAt(large, {"points_in_file"})) + " points in the file, " +
                    count(numberAt(large, {"voxel_centroids"})) + " centroids of voxels of " +
                    fmt::format("{:g}", numberAt(large, {"voxel_size"}).value_or(0)) + " file units kept: " +
                    (stored ? "M is made from them, the points' APO from every point (below)"
                            : "M and the APO are made from them"));
  if (stored) {
    const bool fitted = numberAt(store, {"neighbours"}).value_or(0) > 0;
    const std::string normals =
        fitted ? " points with normals fitted over " + count(numberAt(store, {"neighbours"})) + " neighbours"
               : " points, each with its nearest centroid's normal (--point-normals centroids)";
    const std::string fits = fitted ? count(numberAt(store, {"cut_neighbourhoods"})) + " neighbourhoods cut by a cell's band, " +
                                          count(numberAt(store, {"unfitted_normals"})) + " normals from the nearest centroid (no plane); "
                                    : "";
    html += row("every point in a store (--all-points)",
                count(numberAt(store, {"points"})) + normals + " in " + count(numberAt(store, {"occupied_cells"})) + " cells" +
                    (at(store, {"reused"}) != nullptr && *at(store, {"reused"}) == true ? ", reused from an earlier run" : "") +
                    "; " + fits + bytesText(numberAt(store, {"bytes"})) + " on disk, removed once baked");
  }
  html += sensorRows(ingest);
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

// One titled part of a section.
std::string part(const char* title, const std::string& body) {
  return fmt::format("<div><h3>{}</h3>\n", title) + body + "</div>\n";
}

std::string scanPart(const Json& manifest) {
  const Json* ingest = results(manifest, "ingest");
  if (ingest == nullptr) return part("Scan (ingest)", missingStage(manifest, "ingest"));
  std::string rows = row("kind", escaped(textAt(ingest, {"kind"})));
  rows += row("format", escaped(textAt(ingest, {"input", "format"})));
  rows += row("points read", count(numberAt(ingest, {"counts", "points_in"})));
  rows += row("points after cleaning", count(numberAt(ingest, {"counts", "points_out"})));
  rows += row("triangles read", count(numberAt(ingest, {"counts", "triangles_in"})));
  rows += row("normals", escaped(textAt(ingest, {"normals", "source"})) + ", oriented by " +
                             escaped(textAt(ingest, {"normals", "orientation"})));
  rows += ingestDecisionRows(ingest);
  rows += row("bounding box diagonal", fixed(numberAt(ingest, {"bounding_box", "diagonal"}), 4));
  return part("Scan (ingest)", rowsTable(rows));
}

std::string denseMeshPart(const Json& manifest) {
  const Json* reconstruct = results(manifest, "reconstruct");
  if (reconstruct != nullptr) {
    std::string rows = row("triangles", count(numberAt(reconstruct, {"mesh", "triangles"})));
    rows += row("vertices", count(numberAt(reconstruct, {"mesh", "vertices"})));
    rows += row("method", escaped(textAt(reconstruct, {"method"})));
    rows += row("points used", count(numberAt(reconstruct, {"points", "used"})));
    rows += row("mean point-to-M distance (of bbox diagonal)", fixed(numberAt(reconstruct, {"points_to_mesh", "mean"}), 5));
    return part("Dense mesh M", rowsTable(rows));
  }
  if (stageStatus(manifest, "reconstruct") == "skipped" && denseTriangles(manifest))
    return part("Dense mesh M", "<p>The scan is a mesh: M is the input mesh (reconstruction skipped).</p>\n" +
                                    rowsTable(row("triangles", count(denseTriangles(manifest)))));
  return part("Dense mesh M", missingStage(manifest, "reconstruct"));
}

std::string coarseMeshPart(const Json& manifest) {
  const Json* simplify = results(manifest, "simplify");
  if (simplify == nullptr) return part("Coarse mesh m", missingStage(manifest, "simplify"));
  std::string rows = row("triangles", count(coarseTriangles(manifest)));
  rows += row("target", count(numberAt(simplify, {"faces", "target"})));
  rows += row("vertices", count(numberAt(simplify, {"mesh", "vertices"})));
  rows += row("policy", escaped(textAt(simplify, {"policy"})));
  rows += row("Hausdorff distance to M (of bbox diagonal)", fixed(numberAt(simplify, {"distance_to_input", "hausdorff"}), 5));
  return part("Coarse mesh m", rowsTable(rows));
}

std::string meshesSection(const Json& manifest) {
  return section("meshes", "Scan and meshes",
                 "<div class=\"grid2\">\n" + scanPart(manifest) + denseMeshPart(manifest) + coarseMeshPart(manifest) + "</div>\n");
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
  text += ")";
  if (const std::optional<double> baked = numberAt(choice, {"points_baked"}))
    text += "; the points' APO read " + count(baked) +
            (textAt(choice, {"points_from"}) == "store" ? " points, every point of the scan" : " points, the scan's as ingested");
  return row("baked from", text);
}

// A resumed bake's work read back from its journal; nothing for a bake
// run in one go, or a manifest made before the key.
std::string resumedBricks(const Json* bricks) {
  const std::optional<double> reused = numberAt(bricks, {"journal", "entries_reused"});
  if (!reused || *reused <= 0) return {};
  return "; resumed: " + count(reused) + " cells' and bricks' work read back from the journal of the run killed before";
}

// When the bake went brick by brick (bake.json bricks, docs/bake.md
// "Bricks"), a row saying how; nothing otherwise.
std::string bricksRow(const Json* bake) {
  const Json* bricks = at(bake, {"bricks"});
  if (bricks == nullptr || !bricks->is_object()) return {};
  return row("baked in bricks", count(numberAt(bricks, {"bricks"})) + " bricks of depth " +
                                    count(numberAt(bricks, {"depth"})) + ", " + count(numberAt(bricks, {"refinement_runs"})) +
                                    " brick builds, at most " + count(numberAt(bricks, {"largest_brick_points"})) +
                                    " points held at once; " + count(numberAt(bricks, {"discs_wider_than_reach"})) +
                                    " discs wider than the rays' reach" + resumedBricks(bricks));
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
  const Json* bake = results(manifest, "bake");
  if (bake == nullptr) return section("bake", "Bake", missingStage(manifest, "bake"));
  const std::optional<double> rays = numberAt(bake, {"sampling", "rays"});
  const std::optional<double> hit = numberAt(bake, {"sampling", "samples_hit"});
  const std::optional<double> fallback = numberAt(bake, {"sampling", "samples_fallback"});
  const Json* perDepth = at(bake, {"nodes", "per_depth"});
  std::string rows = row("detail M", escaped(textAt(bake, {"detail", "kind"})) + ", " +
                                         count(numberAt(bake, {"detail", "primitives"})) + " primitives");
  rows += detailChoiceRow(child(bake, "detail_source"));
  rows += bricksRow(bake);
  rows += faceOrderRow(bake);
  rows += row("rays cast", count(rays));
  rows += row("samples hit by a ray", count(hit));
  std::string fallbackText = count(fallback);
  if (hit && fallback && *hit + *fallback > 0.0)
    fallbackText += fmt::format(" ({:.2f}%)", 100.0 * *fallback / (*hit + *fallback));
  rows += row("samples by closest point (ray missed)", fallbackText);
  rows += row("octree depth", isFilledArray(perDepth) ? std::to_string(perDepth->size() - 1) : std::string(kNone));
  rows += row("leaves", count(numberAt(bake, {"nodes", "leaves"})));
  rows += row("texture", count(numberAt(bake, {"texture", "width"})) + " &times; " + count(numberAt(bake, {"texture", "height"})) +
                             " texels, " + bytesText(numberAt(bake, {"texture", "bytes"})));
  std::string steps = tableStart("bake-steps", {"bake step"}, {"seconds"});
  for (const char* step : {"setup", "build", "sample", "encode", "total"})
    steps += row(step, seconds(numberAt(bake, {"seconds", step})));
  steps += row("peak memory", bytesText(numberAt(bake, {"peak_memory_bytes"})));
  return section("bake", "Bake", "<div class=\"grid2\">\n" + rowsTable(rows) + steps + kTableEnd + "</div>\n");
}

std::string renderCostSection(const Json& manifest) {
  const Json* render = results(manifest, "render");
  if (render == nullptr) return section("render-cost", "Render cost", missingStage(manifest, "render"));
  const Json* cost = at(render, {"overall", "cost"});
  const Json* options = child(render, "options");
  const auto flag = [&](const char* key) {
    const Json* v = child(options, key);
    return v != nullptr && v->is_boolean() ? std::string(v->get<bool>() ? "on" : "off") : std::string(kNone);
  };
  std::string rows =
      row("image size", count(numberAt(options, {"size"})) + " px, " + count(numberAt(options, {"views"})) + " views");
  rows += row("mip-mapping / filtering", flag("mipmapping") + " / " + flag("filtering"));
  // What the APO pass walked (docs/render.md): the APO texture, or the same
  // octree as GPU Gems 2's N^3-tree (--layout n3tree).
  const std::optional<std::string> layout = textAt(render, {"layout", "name"});
  if (layout && *layout == "n3tree")
    rows += row("octree drawn as", "GPU Gems 2's N^3-tree, N = " + count(numberAt(render, {"layout", "n"})) + " (scan.n3t)");
  rows += row("frame, reference", fixed(numberAt(cost, {"reference_frame_ms"}), 2) + " ms");
  // M as points goes through the point LOD: what it sent and drew.
  const std::optional<double> sent = numberAt(cost, {"reference_primitives", "sent"});
  if (sent)
    rows += row("reference primitives, sent / drawn per view", count(sent) + " / " +
                                                                 count(numberAt(cost, {"reference_primitives", "drawn"})));
  rows += row("frame, m alone", fixed(numberAt(cost, {"baseline_frame_ms"}), 2) + " ms");
  rows += row("frame, m with APO", fixed(numberAt(cost, {"apo_frame_ms"}), 2) + " ms");
  rows += row("texel reads per fragment, mean / max", fixed(numberAt(cost, {"apo_texel_fetches", "mean"}), 2) + " / " +
                                                          count(numberAt(cost, {"apo_texel_fetches", "max"})));
  rows += row("fragments counted", count(numberAt(cost, {"apo_texel_fetches", "fragments"})));
  return section("render-cost", "Render cost",
                 "<p class=\"meta\">Median wall time of one frame (Mesa llvmpipe, software rendering), mean over the "
                 "views.</p>\n" +
                     rowsTable(rows));
}

std::string optionsSection(const Json& manifest) {
  const Json* options = child(&manifest, "options");
  if (options == nullptr || !options->is_object() || options->empty())
    return section("options", "Options", notRunParagraph("no options recorded"));
  const auto optionRow = [](const std::string& stage, const std::string& key, const Json& value) {
    return "<tr><td>" + htmlEscape(stage) + "</td><td>" + htmlEscape(key) + "</td><td>" + htmlEscape(anyAsText(value)) +
           "</td></tr>\n";
  };
  std::string rows;
  for (const auto& [stage, values] : options->items()) {
    if (values.is_object()) {
      for (const auto& [key, value] : values.items()) rows += optionRow(stage, key, value);
    } else {
      rows += optionRow(stage, "", values);
    }
  }
  return section("options", "Options", "<details><summary>every option of every stage, as run</summary>\n" + rowsTable(rows) +
                                           "</details>\n");
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

// The thumbnail cell: the first view with the APO, opening the scan's
// interactive view when the run made one; empty when nothing was rendered.
std::string thumbnailCell(const Json& manifest, const std::string& dir, const std::string& base) {
  const Json* views = child(results(manifest, "render"), "views");
  if (stageStatus(manifest, "render") != "succeeded" || !isFilledArray(views)) return "<td class=\"thumb\"></td>";
  const std::optional<std::string> viewer = textAt(&manifest, {"files", "viewer"});
  const std::string image = "<img src=\"" + htmlEscape(urlPathEscape(base + rendersFolder(manifest) + "/view00_apo.png")) +
                            "\" alt=\"" + htmlEscape(dir) + ", view 00 with APO\" width=\"96\" height=\"96\">";
  return "<td class=\"thumb\">" +
         (viewer ? "<a href=\"" + htmlEscape(urlPathEscape(base + *viewer)) + "\" title=\"interactive view\">" + image + "</a>"
                 : image) +
         "</td>";
}

// The scan's name, linking to its report, or to its manifest and log when it has none.
std::string nameCell(const Json& manifest, const std::string& status, const std::string& dir, const std::string& base) {
  const bool hasReport = textAt(&manifest, {"files", "report"}).has_value() || status == "succeeded";
  const std::string name = htmlEscape(dir.empty() || dir == "." ? scanName(manifest) : dir);
  if (status == "not_processed") return "<td>" + name + "</td>";  // nothing was written for it
  if (hasReport) return "<td><a href=\"" + htmlEscape(urlPathEscape(base + "report.html")) + "\">" + name + "</a></td>";
  return "<td>" + name + " <a class=\"meta\" href=\"" + htmlEscape(urlPathEscape(base + "manifest.json")) +
         "\">manifest</a> <a class=\"meta\" href=\"" + htmlEscape(urlPathEscape(base + "run.log")) + "\">log</a></td>";
}

// "APO / m alone" mean angular errors, with m's over the APO's, or "m is M"
// when nothing was simplified (m's own normals are then M's).
std::string meanErrorsText(const Json& manifest) {
  const Json* render = results(manifest, "render");
  const std::optional<double> apoMean = numberAt(render, {"overall", "apo", "mean"});
  const std::optional<double> baselineMean = numberAt(render, {"overall", "baseline", "mean"});
  std::string text = degrees(apoMean) + " / " + degrees(baselineMean);
  const Json* simplify = results(manifest, "simplify");
  const std::optional<double> facesIn = numberAt(simplify, {"faces", "in"}), facesOut = numberAt(simplify, {"faces", "out"});
  if (facesIn && facesOut && *facesIn == *facesOut) return text + " (m is M)";
  if (apoMean && baselineMean && *apoMean > 0.0) return text + " (" + ratioText(*baselineMean / *apoMean) + "&times;)";
  return text;
}

std::string indexRow(const BatchRow& scan) {
  const Json& manifest = scan.manifest;
  const std::string status = textAt(&manifest, {"status"}).value_or("");
  std::string dir = scan.relativeDir;
  while (!dir.empty() && dir.back() == '/') dir.pop_back();
  const std::string base = dir.empty() ? std::string() : dir + "/";
  const bool bad = status == "failed" || status == "running" || status == "not_processed" || manifest.empty();
  std::string html = bad ? "<tr class=\"failed\">" : "<tr>";
  html += thumbnailCell(manifest, dir, base) + nameCell(manifest, status, dir, base);
  html += "<td>" + indexStatus(manifest) + "</td>";
  for (const std::string& figure :
       {count(pointsIn(manifest)), count(denseTriangles(manifest)), count(coarseTriangles(manifest)),
        bytesText(numberAt(results(manifest, "bake"), {"texture", "bytes"})), meanErrorsText(manifest),
        seconds(totalSeconds(manifest))})
    html += figureCell(figure);
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
    html += "</header>\n" + tableStart("index", {"", "scan", "status"},
                                        {"points", "M triangles", "m triangles", "APO texture",
                                         "mean angular error<br>APO / m alone", "time"});
    for (const BatchRow& scan : rows) html += indexRow(scan);
    if (rows.empty()) html += "<tr><td colspan=\"9\" class=\"notrun\">no scans</td></tr>\n";
    html += kTableEnd;
    html += "<footer>Each scan's folder holds its report.html, manifest.json and run.log; "
            "summary.json holds the counts above.</footer>\n";
    return html + kPageEnd;
  } catch (const std::exception& e) {
    return fallbackPage(e.what());
  }
}

}  // namespace apo
