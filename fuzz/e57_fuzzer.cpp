// libFuzzer target: the E57 reader (ingest/e57_reader.cpp). Each input is
// read twice: as it is, which exercises the header and the page CRC check
// (a mutated byte nearly always breaks its page's CRC, so that is where most
// inputs stop), and with every page's CRC recomputed first, so that the
// mutations reach the XML section, the compressed vector sections, the
// packets and the bit unpacking behind the CRCs. The sealed input is also
// read in runs of 61 points (readE57Runs, as a file above
// --max-scan-points is read): every run as consistent, as many points in all.
#include "fuzz/scan_reader_fuzzer.h"
#include "ingest/e57_pages.h"

#include <string>

namespace {

// Besides the shared checks: every point names a station that exists, and
// grid indices, when present, come one per point.
void checkStations(const apo::Scan& scan) {
  apo::fuzz::checkConsistent(scan);
  const apo::PointSet& points = scan.points;
  bool consistent = points.stations.size() == points.size() && points.rows.size() == points.columns.size() &&
                    (points.rows.empty() || points.rows.size() == points.size());
  for (const std::uint16_t station : points.stations) consistent &= station < scan.stations.size();
  if (!consistent) {
    std::fprintf(stderr, "E57 reader returned stations or grid indices that do not match its points\n");
    std::abort();
  }
}

apo::Scan readE57Checked(std::string_view bytes) {
  apo::Scan scan = apo::readers::readE57(bytes);
  checkStations(scan);
  return scan;
}

void readInRuns(std::string_view bytes) {
  std::size_t inRuns = 0, whole = 0;
  try {
    apo::readers::readE57Runs(
        bytes, 61,
        [&](apo::Scan& run) {
          checkStations(run);
          inRuns += run.points.size();
        },
        [] {});
    whole = apo::readers::readE57(bytes).points.size();
  } catch (const apo::parse::ParseFailure&) {
    return;
  }
  if (inRuns != whole) {
    std::fprintf(stderr, "E57 runs held %zu points, the whole read %zu\n", inRuns, whole);
    std::abort();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  apo::fuzz::fuzzReader(readE57Checked, data, size);
  std::string sealed(reinterpret_cast<const char*>(data), size);
  apo::e57::sealPages(sealed);
  readInRuns(sealed);
  return apo::fuzz::fuzzReader(readE57Checked, reinterpret_cast<const std::uint8_t*>(sealed.data()), sealed.size());
}
