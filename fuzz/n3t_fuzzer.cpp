// libFuzzer target: the .n3t loader (format/n3tree_file.cpp) and what a
// loaded N^3-tree promises: it validates, and every walk on it, plain or
// filtered, stays inside its textures and ends. A file it refuses is a
// BadInput; anything else (a crash, an exception, undefined behaviour, an
// accepted tree that does not validate) is a bug.
#include "format/format.h"
#include "fuzz/octree_file_fuzzer.h"

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <string_view>
#include <vector>

namespace {

void loadAndWalk(std::string_view bytes, const std::vector<apo::Vec3f>& points) {
  const auto tree = apo::parseN3TreeFile(bytes);
  if (!tree.ok()) {
    if (tree.error().kind != apo::ErrorKind::BadInput) {
      std::fprintf(stderr, "refused with a non-BadInput error: %s\n", tree.error().message.c_str());
      std::abort();
    }
    return;
  }
  if (!apo::validateN3Tree(*tree).ok()) {
    std::fprintf(stderr, "an accepted tree does not validate\n");
    std::abort();
  }
  for (const apo::Vec3f& p : points) {
    (void)apo::lookupN3Tree(*tree, p);
    (void)apo::lookupN3TreeFiltered(*tree, p, apo::Vec3f(0.0f, 0.0f, -1.0f));
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  const std::vector<apo::Vec3f> points = apo::fuzz::lookupPoints(data, size);
  loadAndWalk(bytes, points);
  loadAndWalk(apo::fuzz::withValidChecksum(bytes, 104, 136), points);  // the header's checksum bytes, its size
  return 0;
}
