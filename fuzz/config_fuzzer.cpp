// libFuzzer target: the TOML config reader of `apo run` and `apo batch`
// (cli/config.cpp, CLI11's TOML parser) over the real stage options. Any
// text must give a Status, never an exception or a crash.
#include "cli/config.h"
#include "cli/stage_options.h"

#include <cstdint>
#include <string_view>

namespace {

// `apo run`'s options, registered once (that costs a millisecond); each input
// starts from a cleared parse, as if nothing had been given.
struct RunApp {
  CLI::App app{"apo run, for the config fuzzer"};
  apo::cli::StageArguments arguments;
  RunApp() { apo::cli::addStageOptionGroups(app, arguments); }
};

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static RunApp run;
  run.app.clear();
  const apo::Status status =
      apo::cli::applyConfigText(run.app, std::string_view(reinterpret_cast<const char*>(data), size), "fuzz.toml");
  if (status.ok()) (void)apo::cli::runOptionsFrom(run.arguments);
  return 0;
}
