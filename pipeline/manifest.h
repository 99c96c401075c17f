// Internal to pipeline/: manifest.json (docs/run.md) as the run writes it and
// as the batch reads it back to resume.
#pragma once

#include "pipeline/pipeline.h"

#include <nlohmann/json.hpp>

#include <filesystem>
#include <optional>
#include <string>

namespace apo::manifest {

using Json = nlohmann::ordered_json;

// A run that has not started a stage yet: every stage "not_run".
Json initial(const RunSettings& settings);

// A worker's manifest that it never wrote (it crashed before its first save).
Json placeholder(const std::filesystem::path& input);

// OUTDIR/manifest.json, when it exists and is a JSON object.
std::optional<Json> read(const std::filesystem::path& outDir);
Status write(const std::filesystem::path& outDir, const Json& manifest);

// Whether a finished run can stand for a new one: it succeeded, with the same
// input digest, options and tool version.
bool upToDate(const Json& manifest, const std::string& inputSha256, const Json& options);
// Whether a manifest is of a run of this input digest, these options and
// this tool version, whatever its status.
bool sameRun(const Json& manifest, const std::string& inputSha256, const Json& options);

// A manifest whose run ended without recording its end (a crash, a kill)
// marked failed at the first stage that did not finish, with `reason`.
// Manifests that recorded their end are returned as they are.
Json markAbnormalEnd(Json manifest, const std::string& reason);

}  // namespace apo::manifest
