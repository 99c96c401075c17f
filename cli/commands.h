// The `apo` subcommands: each registers its options (filled into the stage's
// options struct) and a callback that runs the stage and sets the exit code.
#pragma once

#include <CLI/CLI.hpp>

namespace apo::cli {

// Documented exit codes (also printed by `apo --help`).
inline constexpr int kExitSuccess = 0;
inline constexpr int kExitUsage = 1;
inline constexpr int kExitBadInput = 2;
inline constexpr int kExitInternal = 3;

void addIngestCommand(CLI::App& app, int& exitCode);
void addSimulateScanCommand(CLI::App& app, int& exitCode);
void addReconstructCommand(CLI::App& app, int& exitCode);
void addSimplifyCommand(CLI::App& app, int& exitCode);
void addBakeCommand(CLI::App& app, int& exitCode);
void addLookupCommand(CLI::App& app, int& exitCode);
void addRenderCommand(CLI::App& app, int& exitCode);
void addRunCommand(CLI::App& app, int& exitCode);
void addBatchCommand(CLI::App& app, int& exitCode);
void addSlurmCommand(CLI::App& app, int& exitCode);
void addExportCommand(CLI::App& app, int& exitCode);

}  // namespace apo::cli
