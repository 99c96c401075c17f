#include "pipeline/manifest.h"

#include "core/file_io.h"

namespace apo::manifest {
namespace fs = std::filesystem;

namespace {

Json tool() { return {{"name", "apo"}, {"version", APO_VERSION}}; }

Json inputOf(const fs::path& input) { return {{"path", input.string()}, {"name", input.filename().string()}}; }

}  // namespace

Json initial(const RunSettings& settings) {
  Json manifest;
  manifest["format_version"] = kManifestFormatVersion;
  manifest["tool"] = tool();
  manifest["input"] = inputOf(settings.input);
  manifest["options"] = optionsJson(*settings.options);
  manifest["status"] = "running";
  manifest["error"] = nullptr;
  manifest["stages"] = Json::array();
  for (const char* name : kRunStages)
    manifest["stages"].push_back({{"name", name}, {"status", "not_run"}, {"seconds", 0.0}, {"peak_memory_bytes", 0}});
  manifest["results"] = Json::object();
  manifest["files"] = Json::object();
  return manifest;
}

Json placeholder(const fs::path& input) {
  return Json{{"format_version", kManifestFormatVersion}, {"tool", tool()}, {"input", inputOf(input)}, {"stages", Json::array()}};
}

std::optional<Json> read(const fs::path& outDir) {
  auto bytes = readFileBytes(outDir / "manifest.json");
  if (!bytes) return std::nullopt;
  Json manifest = Json::parse(*bytes, nullptr, false);
  if (manifest.is_discarded() || !manifest.is_object()) return std::nullopt;
  return manifest;
}

Status write(const fs::path& outDir, const Json& manifest) {
  return writeFileAtomically(outDir / "manifest.json", manifest.dump(2) + "\n");
}

bool upToDate(const Json& manifest, const std::string& inputSha256, const Json& options) {
  return manifest.value("status", "") == "succeeded" && sameRun(manifest, inputSha256, options);
}

bool sameRun(const Json& manifest, const std::string& inputSha256, const Json& options) {
  return manifest.contains("input") &&
         manifest["input"].value("sha256", "") == inputSha256 && manifest.contains("tool") &&
         manifest["tool"].value("version", "") == APO_VERSION && manifest.contains("options") &&
         manifest["options"] == options;
}

Json markAbnormalEnd(Json manifest, const std::string& reason) {
  if (manifest.value("status", "") == "succeeded" || manifest.value("status", "") == "failed") return manifest;
  std::string stage = "setup";
  if (manifest.contains("stages") && manifest["stages"].is_array())
    for (Json& record : manifest["stages"])
      if (record.value("status", "") == "not_run" || record.value("status", "") == "running") {
        stage = record.value("name", "setup");
        break;
      }
  manifest["status"] = "failed";
  manifest["error"] = {{"stage", stage}, {"message", reason}};
  return manifest;
}

}  // namespace apo::manifest
