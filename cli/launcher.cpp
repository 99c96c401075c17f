// `apo`, the command users run: starts the engine (apo-engine) with glibc's
// huge-page tunable set, and nothing else.
//
// The engine's bake spends a fifth of its time in page faults with 4 KiB
// pages; glibc asks the kernel for huge pages only when its tunable
// `glibc.malloc.hugetlb` says so, and reads it at start-up only
// (huge_pages.h). The engine loads 20 shared libraries before main (23 ms
// on the test machine; 60 ms when it linked PCL's six, now in a module
// loaded when needed, and 82 ms when PCL's I/O library was linked), so when
// it restarted itself to set the tunable every command paid that twice.
// This launcher loads only libc and libstdc++.
//
// The engine is looked for beside the launcher (the build tree) and in
// ../lib/apo (installed: /usr/bin/apo, /usr/lib/apo/apo-engine). A tunable
// the caller set is left alone, as the engine itself does.
#include "cli/huge_pages.h"

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>

namespace {

// Exit code of an internal error (cli/commands.h, kExitInternal): the
// launcher links nothing of the engine's.
constexpr int kExitInternal = 3;

std::string directoryOfThisProgram() {
  char path[4096];
  const ssize_t length = readlink("/proc/self/exe", path, sizeof(path) - 1);
  if (length <= 0) return ".";
  const std::string self(path, static_cast<std::size_t>(length));
  const std::size_t slash = self.rfind('/');
  return slash == std::string::npos ? "." : self.substr(0, slash);
}

void askForHugePages() {
  // On failure the engine asks again itself.
  if (const auto wanted = apo::cli::tunablesWithHugePages(std::getenv("GLIBC_TUNABLES")))
    setenv("GLIBC_TUNABLES", wanted->c_str(), 1);
}

}  // namespace

int main(int /*argc*/, char** argv) {
  askForHugePages();
  const std::string directory = directoryOfThisProgram();
  const std::string candidates[] = {directory + "/apo-engine", directory + "/../lib/apo/apo-engine"};
  int firstError = 0;
  for (const std::string& engine : candidates) {
    execv(engine.c_str(), argv);
    if (firstError == 0 || firstError == ENOENT) firstError = errno;
  }
  std::fprintf(stderr, "[E] apo cannot start its engine: tried %s and %s: %s (reinstall apo)\n",
               candidates[0].c_str(), candidates[1].c_str(), std::strerror(firstError));
  return kExitInternal;
}
