// libFuzzer target: the TOML config reader of `apo run` and `apo batch`
// (cli/config.cpp, CLI11's TOML parser) over the real stage options. Any
// text must give a Status, never an exception or a crash.
#include "cli/config.h"
#include "cli/stage_options.h"

#include <cstdint>
#include <string_view>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  CLI::App app{"apo run, for the config fuzzer"};
  apo::cli::StageArguments arguments;
  apo::cli::addStageOptionGroups(app, arguments);
  const apo::Status status =
      apo::cli::applyConfigText(app, std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.toml");
  if (status.ok()) (void)apo::cli::runOptionsFrom(arguments);
  return 0;
}
