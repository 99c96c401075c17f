// glibc's huge-page tunable, asked for by both the `apo` launcher
// (launcher.cpp) and the engine run directly (main.cpp): header-only, as the
// launcher links nothing of the engine's.
//
// The kernel here backs memory with huge pages only where a program asks
// (transparent_hugepage "madvise"), and glibc asks only when its
// `glibc.malloc.hugetlb` tunable says so, which it reads from the
// environment at start-up. With 4 KiB pages a fifth of the bake went to page
// faults: 1.2M triangles at 3 MiB 5.7 s, 4.4 s with the tunable; the 7.2M
// torus 15.1 s, 10.7 s (docs/bake.md, "A faster build").
#pragma once

#include <optional>
#include <string>

namespace apo::cli {

// GLIBC_TUNABLES asking for huge pages, given its current value (null when
// unset): the caller's tunables plus ours; none when the caller already
// chose (a `glibc.malloc.hugetlb` the user set is left alone).
inline std::optional<std::string> tunablesWithHugePages(const char* given) {
  const std::string tunables = given ? given : "";
  if (tunables.find("glibc.malloc.hugetlb") != std::string::npos) return std::nullopt;
  return (tunables.empty() ? "" : tunables + ":") + "glibc.malloc.hugetlb=1";
}

}  // namespace apo::cli
