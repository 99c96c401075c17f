// --config: a TOML file of stage options for `apo run` and `apo batch`, by
// their names without dashes (`faces = 5000`, `no-filter = true`); what the
// command line gives wins.
#pragma once

#include "core/error.h"

#include <CLI/CLI.hpp>

#include <filesystem>
#include <string>
#include <string_view>

namespace apo::cli {

// Sets every option of `app` that `text` names and the command line did not
// give. BadInput naming `sourceName` for text that is not TOML, an option in
// a section, a name `app` does not have, or a value the option refuses.
// Never throws, whatever the text.
Status applyConfigText(CLI::App& app, std::string_view text, const std::string& sourceName);

// The same for a file (nothing when `file` is empty); BadInput naming it when
// it cannot be read.
Status applyConfigFile(CLI::App& app, const std::filesystem::path& file);

}  // namespace apo::cli
