// PCL's LZF codec, apart from pcl_points.cpp so that the PCD reader (and its
// fuzzer) pull in one light header rather than PCL's feature headers.
#include "adapters/pcl/pcl_points.h"

#include <pcl/io/lzf.h>

namespace apo::pcl_adapter {

bool lzfDecompress(std::string_view compressed, std::vector<char>& out) {
  if (out.empty()) return true;  // nothing to decode, whatever follows
  // pcl::lzfDecompress reads one control byte even from empty input.
  if (compressed.empty()) return false;
  return pcl::lzfDecompress(compressed.data(), static_cast<unsigned>(compressed.size()), out.data(),
                            static_cast<unsigned>(out.size())) == out.size();
}

}  // namespace apo::pcl_adapter
