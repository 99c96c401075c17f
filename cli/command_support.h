// What every `apo` subcommand shares: exit codes from errors, error
// reporting, and a guard that turns escaped exceptions into internal errors.
#pragma once

#include "cli/commands.h"
#include "core/error.h"
#include "core/file_io.h"
#include "format/format.h"

#include <spdlog/spdlog.h>
#include <tbb/global_control.h>

#include <filesystem>
#include <new>
#include <optional>
#include <stdexcept>

namespace apo::cli {

inline int exitCodeFor(const Error& error) {
  switch (error.kind) {
    case ErrorKind::Usage: return kExitUsage;
    case ErrorKind::BadInput: return kExitBadInput;
    case ErrorKind::Internal: return kExitInternal;
  }
  return kExitInternal;
}

inline int reportFailure(const Error& error) {
  spdlog::error("{}", error.message);
  return exitCodeFor(error);
}

// Runs a command body, turning escaped exceptions into internal errors so
// that no input ever ends in an uncaught exception.
template <class Body>
int guarded(Body&& body) {
  try {
    return body();
  } catch (const std::bad_alloc&) {
    return reportFailure(internalError("out of memory"));
  } catch (const std::exception& exception) {
    return reportFailure(internalError("unexpected failure: {}", exception.what()));
  }
}

// TBB uses every core unless told otherwise; outputs are the same either way.
inline std::optional<tbb::global_control> limitThreads(int threads) {
  if (threads <= 0) return std::nullopt;
  return std::make_optional<tbb::global_control>(tbb::global_control::max_allowed_parallelism,
                                                 static_cast<std::size_t>(threads));
}

// An octree file as stored: the APO texture (.apo) or, by its extension
// .n3t, the N^3-tree of `apo bake --layout n3tree`.
struct OctreeFile {
  std::optional<ApoTexture> apo;
  std::optional<N3Tree> n3tree;

  const UnitCubeTransform& transform() const { return apo ? apo->transform : n3tree->transform; }
  bool needsCoarseNormals() const { return apo ? apo->needsCoarseNormals() : n3tree->needsCoarseNormals(); }
};

inline Result<OctreeFile> readOctreeFile(const std::filesystem::path& path) {
  OctreeFile file;
  if (path.extension() == ".n3t") {
    auto tree = readN3TreeFile(path);
    if (!tree) return tree.error();
    file.n3tree = std::move(tree).value();
  } else {
    auto texture = readApoFile(path);
    if (!texture) return texture.error();
    file.apo = std::move(texture).value();
  }
  return file;
}

}  // namespace apo::cli
