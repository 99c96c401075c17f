// The QA report pages of `apo run` and `apo batch`: pure functions from a
// scan's manifest.json (docs/run.md) to HTML, no file I/O. docs/report.md
// describes what each part shows.
//
// The pages are self-contained and work offline: inline CSS and SVG, no
// script, no font or link to the network, images by relative path only.
// Every string taken from the manifest (scan name, paths, error messages,
// options, stage names) is HTML-escaped, in text and in attributes alike; paths
// put in src/href are also percent-encoded. A manifest of unexpected shape
// (a failed run, a missing or mistyped field) never throws: what is missing
// is shown as "not run" or "-".
#pragma once

#include "core/viewer_scene.h"

#include <nlohmann/json.hpp>

#include <string>
#include <string_view>
#include <vector>

namespace apo {

// The heat maps' colour scale in degrees, as render/render.h's
// kHeatMapDegrees (kept apart so these pages need no render/ header).
inline constexpr double kReportHeatMapDegrees = 10.0;

// `text` with & < > " ' replaced by their character references, safe in HTML
// text and in quoted attribute values. Other bytes (UTF-8 included) pass
// unchanged.
std::string htmlEscape(std::string_view text);

// A relative path as a URL path: every byte but the unreserved ones
// (A-Z a-z 0-9 - . _ ~) and '/' percent-encoded (so spaces, #, ?, %, quotes,
// ':' and non-ASCII bytes are), and "./" put before a path starting with '/'
// so it stays relative. The result still needs htmlEscape only in theory: it
// holds no character HTML gives a meaning to.
std::string urlPathEscape(std::string_view path);

// OUTDIR/report.html of one scan, from its manifest (format_version 1): the
// status, a verdict in plain words, per view the reference M, the baseline m,
// m with the APO and the APO's error heat map (paths relative to report.html:
// files.renders + "/viewNN_{reference,baseline,apo,apo_error}.png"), the
// metrics, charts of octree nodes per depth and of each view's mean angular
// error, stage timings and memory, bake sampling, mesh sizes and render cost.
std::string qaReportHtml(const nlohmann::json& manifest);

// One scan of a batch: its output folder relative to the batch's OUTDIR
// (where index.html is), and its manifest (an empty object when it has none).
struct BatchRow {
  std::string relativeDir;
  nlohmann::json manifest;
};

// OUTDIR/index.html of `apo batch`: `summary` ({"scans", "succeeded",
// "failed", "skipped_up_to_date", "not_processed", "seconds"}) at the top,
// then one row per scan in the given order (a file the batch did not process
// has the manifest {"status": "not_processed", "input": {"name"}, "reason"}): thumbnail (first view with the APO), link to its
// report, status (stage and message when it failed), point count, M and m
// triangles, APO texture bytes, mean angular error of the APO and of the
// baseline, total seconds.
std::string batchIndexHtml(const std::vector<BatchRow>& rows, const nlohmann::json& summary);

// OUTDIR/viewer.html of one scan: the interactive WebGL2 view (docs/report.md,
// "The viewer"), self-contained: script, shaders and data inline (base64),
// so it works from file:// and on a machine without the tool. `staticImages`
// (paths relative to the page, one per view) are what a browser without
// WebGL2 shows instead, saying why. Scan names and labels reach the page as
// JSON text only, never as markup.
std::string viewerHtml(const ViewerScene& scene, std::string_view scanName, const std::vector<std::string>& staticImages);

}  // namespace apo
