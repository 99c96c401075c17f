// PCD's LZF codec (binary_compressed), apart from pcl_points.cpp so that the
// PCD reader (and its fuzzer) pull in one light header rather than PCL's
// feature headers. liblzf decodes it: PCL's pcl::lzfDecompress is a copy of
// liblzf's, and linking pcl_io for it loaded 57 more shared libraries (VTK's
// among them) into every start of apo, about 40 ms (docs/benchmarks.md, "A
// faster build"). liblzf checks its input (CHECK_INPUT, on in Debian's
// build): a corrupt stream or one longer than `out` returns 0.
#include "adapters/pcl/pcl_points.h"

#include <lzf.h>

namespace apo::pcl_adapter {

bool lzfDecompress(std::string_view compressed, std::vector<char>& out) {
  if (out.empty()) return true;  // nothing to decode, whatever follows
  // lzf_decompress reads one control byte even from empty input.
  if (compressed.empty()) return false;
  return lzf_decompress(compressed.data(), static_cast<unsigned>(compressed.size()), out.data(),
                        static_cast<unsigned>(out.size())) == out.size();
}

}  // namespace apo::pcl_adapter
