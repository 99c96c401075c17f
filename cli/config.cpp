#include "cli/config.h"

#include "cli/stage_options.h"
#include "core/file_io.h"

#include <sstream>
#include <vector>

namespace apo::cli {

Status applyConfigText(CLI::App& app, std::string_view text, const std::string& sourceName) {
  std::vector<CLI::ConfigItem> items;
  CLI::ConfigTOML format;
  try {
    std::istringstream in{std::string(text)};
    items = format.from_config(in);
  } catch (const std::exception& error) {
    return badInput("{}: not a TOML file of options: {}", sourceName, error.what());
  }
  for (const CLI::ConfigItem& item : items) {
    if (!item.parents.empty())
      return badInput("{}: option '{}' is in a section; options stand at the top level", sourceName, item.fullname());
    CLI::Option* option = app.get_option_no_throw("--" + item.name);
    if (option == nullptr || item.name == "config" || item.name == "out")
      return badInput("{}: '{}' is not an option of apo {} (see --help)", sourceName, item.name, app.get_name());
    if (option->count() > 0) continue;  // given on the command line
    try {
      // As CLI11 does for a main command's config: flags through their flag value (so `no-normals = true` negates).
      if (isFlag(*option))
        option->add_result(option->get_flag_value(item.name, format.to_flag(item)));
      else
        option->add_result(item.inputs);
      option->run_callback();
    } catch (const std::exception& error) {
      return badInput("{}: option '{}': {}", sourceName, item.name, error.what());
    }
  }
  return okStatus();
}

Status applyConfigFile(CLI::App& app, const std::filesystem::path& file) {
  if (file.empty()) return okStatus();
  auto text = readFileBytes(file);
  if (!text) return text.error();
  return applyConfigText(app, *text, file.string());
}

}  // namespace apo::cli
