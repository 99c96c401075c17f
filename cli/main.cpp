// apo's engine (apo-engine, started by the `apo` launcher): parse the
// command line, run one subcommand, return its exit code.
#include "cli/commands.h"
#include "cli/huge_pages.h"

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

#include <malloc.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace {

using namespace apo::cli;

// Edit distance (insertions, deletions, substitutions, transpositions of
// neighbours), for the nearest subcommand to a mistyped one.
std::size_t editDistance(std::string_view a, std::string_view b) {
  std::vector<std::vector<std::size_t>> d(a.size() + 1, std::vector<std::size_t>(b.size() + 1));
  for (std::size_t i = 0; i <= a.size(); ++i) d[i][0] = i;
  for (std::size_t j = 0; j <= b.size(); ++j) d[0][j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i)
    for (std::size_t j = 1; j <= b.size(); ++j) {
      d[i][j] = std::min({d[i - 1][j] + 1, d[i][j - 1] + 1, d[i - 1][j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1)});
      if (i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1]) d[i][j] = std::min(d[i][j], d[i - 2][j - 2] + 1);
    }
  return d[a.size()][b.size()];
}

std::vector<std::string> subcommandNames(const CLI::App& app) {
  std::vector<std::string> names;
  for (const CLI::App* sub : app.get_subcommands([](const CLI::App*) { return true; })) names.push_back(sub->get_name());
  return names;
}

// The first argument that is not an option of `apo` itself (whose options
// take no value): the subcommand, if any.
std::optional<std::string> subcommandArgument(int argc, char** argv) {
  for (int i = 1; i < argc; ++i)
    if (argv[i][0] != '-') return std::string(argv[i]);
  return std::nullopt;
}

// Usage error for a missing or unknown subcommand, with the nearest name and
// the list; nothing when the subcommand is known.
std::optional<std::string> subcommandProblem(const CLI::App& app, int argc, char** argv) {
  const std::vector<std::string> names = subcommandNames(app);
  std::string list;
  for (const std::string& name : names) list += (list.empty() ? "" : ", ") + name;
  const std::optional<std::string> given = subcommandArgument(argc, argv);
  if (!given) return "a subcommand is required: " + list + " (apo --help describes them)";
  if (std::find(names.begin(), names.end(), *given) != names.end()) return std::nullopt;
  const auto nearest = std::min_element(names.begin(), names.end(), [&](const std::string& a, const std::string& b) {
    return editDistance(*given, a) < editDistance(*given, b);
  });
  std::string message = "'" + *given + "' is not an apo subcommand";
  if (nearest != names.end() && editDistance(*given, *nearest) <= std::max<std::size_t>(2, given->size() / 3))
    message += "; did you mean '" + *nearest + "'?";
  return message + " Subcommands: " + list + ".";
}

bool asksForHelpOrVersion(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    const std::string_view argument = argv[i];
    if (argument == "-h" || argument == "--help" || argument == "--version") return true;
  }
  return false;
}

// glibc hands freed memory back to the kernel above 128 KiB (its default
// trim threshold) and serves large blocks by mmap, so the bake's refinement,
// which frees and allocates millions of primitive lists, spent a tenth of
// its time in page faults (1.2M triangles at 3 MiB: octree build 6.2 s,
// 5.4 s with these; docs/bake.md "A faster build"). Memory freed stays
// in the heap for the next list; the peak is unchanged.
void keepFreedMemoryInTheHeap() {
  mallopt(M_MMAP_THRESHOLD, 32 << 20);  // the largest the allocator accepts
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
  mallopt(M_TOP_PAD, 64 << 20);
}

// Huge pages (huge_pages.h): the `apo` launcher sets the tunable before it
// starts this engine; run directly (a Slurm script names the engine's path),
// the engine starts itself again once with the tunable set. A failed exec
// only costs the speed.
void restartWithHugePagesUnlessAsked(char** argv) {
  const char* tunables = std::getenv("GLIBC_TUNABLES");
  const std::optional<std::string> wanted = tunablesWithHugePages(tunables);
  if (!wanted || setenv("GLIBC_TUNABLES", wanted->c_str(), 1) != 0) return;
  execv("/proc/self/exe", argv);
  if (tunables) setenv("GLIBC_TUNABLES", tunables, 1);  // the exec failed: run as we are
  else unsetenv("GLIBC_TUNABLES");
}

}  // namespace

int main(int argc, char** argv) {
  restartWithHugePagesUnlessAsked(argv);
  keepFreedMemoryInTheHeap();
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
  addSlurmCommand(app, exitCode);
  addExportCommand(app, exitCode);

  if (!asksForHelpOrVersion(argc, argv))
    if (const std::optional<std::string> problem = subcommandProblem(app, argc, argv)) {
      std::fprintf(stderr, "apo: %s\n", problem->c_str());
      return kExitUsage;
    }
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
