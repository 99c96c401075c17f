// `apo`: parse the command line, run one subcommand, return its exit code.
#include "cli/commands.h"

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <exception>

int main(int argc, char** argv) {
  using namespace apo::cli;
  CLI::App app{"apo: turns dense 3D scans into a light coarse mesh with an Appearance Preserving Octree-texture."};
  app.footer(
      "Exit codes: 0 success, 1 bad usage (command line or option values), "
      "2 bad input (a missing, unreadable or malformed file), 3 internal error.");
  app.require_subcommand(1);
  bool quiet = false;
  bool verbose = false;
  app.add_flag("-q,--quiet", quiet, "Only print warnings and errors");
  app.add_flag("-v,--verbose", verbose, "Print debugging detail");
  app.set_version_flag("--version", std::string(APO_VERSION));

  // Logs go to stderr so that stdout stays free for machine-readable output.
  spdlog::set_default_logger(spdlog::stderr_color_mt("apo"));
  spdlog::set_pattern("%^[%L]%$ %v");
  app.parse_complete_callback([&] { spdlog::set_level(quiet ? spdlog::level::warn : verbose ? spdlog::level::debug : spdlog::level::info); });

  int exitCode = kExitSuccess;
  addIngestCommand(app, exitCode);
  addSimulateScanCommand(app, exitCode);
  addReconstructCommand(app, exitCode);
  addSimplifyCommand(app, exitCode);
  addBakeCommand(app, exitCode);
  addLookupCommand(app, exitCode);
  addRenderCommand(app, exitCode);
  addRunCommand(app, exitCode);
  addBatchCommand(app, exitCode);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& error) {
    return app.exit(error) == 0 ? kExitSuccess : kExitUsage;
  } catch (const std::exception& error) {
    spdlog::error("internal error: {}", error.what());
    return kExitInternal;
  }
  return exitCode;
}
