// libFuzzer target: the E57 reader (ingest/e57_reader.cpp). Each input is
// read twice: as it is, which exercises the header and the page CRC check
// (a mutated byte nearly always breaks its page's CRC, so that is where most
// inputs stop), and with every page's CRC recomputed first, so that the
// mutations reach the XML section, the compressed vector sections, the
// packets and the bit unpacking behind the CRCs.
#include "fuzz/scan_reader_fuzzer.h"
#include "ingest/e57_pages.h"

#include <string>

namespace {

// Besides the shared checks: every point names a station that exists, and
// grid indices, when present, come one per point.
apo::Scan readE57Checked(std::string_view bytes) {
  apo::Scan scan = apo::readers::readE57(bytes);
  const apo::PointSet& points = scan.points;
  bool consistent = points.stations.size() == points.size() && points.rows.size() == points.columns.size() &&
                    (points.rows.empty() || points.rows.size() == points.size());
  for (const std::uint16_t station : points.stations) consistent &= station < scan.stations.size();
  if (!consistent) {
    std::fprintf(stderr, "E57 reader returned stations or grid indices that do not match its points\n");
    std::abort();
  }
  return scan;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  apo::fuzz::fuzzReader(readE57Checked, data, size);
  std::string sealed(reinterpret_cast<const char*>(data), size);
  apo::e57::sealPages(sealed);
  return apo::fuzz::fuzzReader(readE57Checked, reinterpret_cast<const std::uint8_t*>(sealed.data()), sealed.size());
}
