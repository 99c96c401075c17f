// The E57 reader and writer. Ground truth comes from outside the code under
// test: published CRC-32C check values; real files from four other writers
// (fuzz/corpus/e57/, from ../shared/data/e57/, whose README gives their scan
// and record counts), whose declared bounds and limits this test reads with
// its own page stripping and pugixml, not through the reader; and, for the
// writer, a page CRC computed here bit by bit and by python3-crc32c.
#include "ingest/e57_pages.h"
#include "ingest/ingest.h"
#include "ingest/parse_util.h"
#include "ingest/readers.h"

#include "tests/ingest/reader_failure.h"
#include "tests/test_support.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <pugixml.hpp>

#include <array>
#include <chrono>
#include <ctime>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <random>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

namespace apo {
namespace {
namespace fs = std::filesystem;

using ::testing::AllOf;
using ::testing::Contains;
using ::testing::HasSubstr;

std::string e57Failure(std::string_view bytes) { return test::readerFailure(readers::readE57, bytes); }

// ---- An independent view of E57 files: pages, header, XML ---------------------------

// CRC-32C bit by bit, straight from the polynomial (no tables): the check on
// the reader's and writer's table-driven one.
std::uint32_t bitwiseCrc32c(std::string_view bytes) {
  std::uint32_t crc = 0xFFFFFFFF;
  for (const char c : bytes) {
    crc ^= static_cast<unsigned char>(c);
    for (int bit = 0; bit < 8; ++bit) crc = (crc >> 1) ^ (0x82F63B78 & (0u - (crc & 1)));
  }
  return ~crc;
}

bool pagesHaveTheirCrcs(std::string_view file) {
  if (file.size() % 1024 != 0) return false;
  for (std::size_t page = 0; page < file.size(); page += 1024) {
    const auto* stored = reinterpret_cast<const unsigned char*>(file.data() + page + 1020);
    const std::uint32_t crc = std::uint32_t{stored[0]} << 24 | stored[1] << 16 | stored[2] << 8 | stored[3];
    if (crc != bitwiseCrc32c(file.substr(page, 1020))) return false;
  }
  return true;
}

void sealWithBitwiseCrcs(std::string& file) {
  for (std::size_t page = 0; page + 1024 <= file.size(); page += 1024) {
    const std::uint32_t crc = bitwiseCrc32c(std::string_view(file).substr(page, 1020));
    for (int i = 0; i < 4; ++i) file[page + 1020 + i] = static_cast<char>(crc >> (24 - 8 * i));
  }
}

std::string logicalOf(std::string_view file) {
  std::string logical;
  for (std::size_t page = 0; page + 1024 <= file.size(); page += 1024) logical.append(file.substr(page, 1020));
  return logical;
}

template <class T>
T fieldAt(std::string_view bytes, std::size_t at) {
  T value;
  std::memcpy(&value, bytes.data() + at, sizeof(T));
  return value;
}

std::uint64_t logicalFromPhysical(std::uint64_t physical) { return physical / 1024 * 1020 + physical % 1024; }

std::string xmlOf(std::string_view file) {
  const std::string logical = logicalOf(file);
  return logical.substr(logicalFromPhysical(fieldAt<std::uint64_t>(file, 24)), fieldAt<std::uint64_t>(file, 32));
}

// The file with its XML section replaced by `xml` (placed where the old one
// started), its header and every page's CRC made to match.
std::string withXml(std::string_view file, const std::string& xml) {
  std::string logical = logicalOf(file);
  const std::uint64_t start = logicalFromPhysical(fieldAt<std::uint64_t>(file, 24));
  logical.resize(start);
  logical += xml;
  logical.resize((logical.size() + 1019) / 1020 * 1020, '\0');
  const std::uint64_t physicalLength = logical.size() / 1020 * 1024, xmlLength = xml.size();
  std::memcpy(logical.data() + 16, &physicalLength, 8);
  std::memcpy(logical.data() + 32, &xmlLength, 8);
  std::string out;
  for (std::size_t at = 0; at < logical.size(); at += 1020) out += logical.substr(at, 1020) + std::string(4, '\0');
  sealWithBitwiseCrcs(out);
  return out;
}

std::string replaced(std::string text, const std::string& from, const std::string& to) {
  const std::size_t at = text.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) text.replace(at, from.size(), to);
  return text;
}

// What a data3D declares, read with pugixml here.
struct Declared {
  std::uint64_t records = 0;
  std::optional<std::array<std::array<double, 2>, 3>> cartesianBounds;
  std::array<std::optional<std::array<double, 2>>, 3> prototypeRanges;  // cartesianX/Y/Z min, max (scaled)
  std::optional<std::array<double, 2>> rangeBounds;                     // sphericalBounds' range
  std::optional<std::array<double, 2>> intensityLimits;
  std::array<double, 4> rotation = {1, 0, 0, 0};
  std::array<double, 3> translation = {0, 0, 0};
};

double numberIn(pugi::xml_node node) {
  const std::string text = node.text().get();
  const double value = text.empty() ? 0.0 : std::stod(text);
  return std::string_view(node.attribute("type").value()) == "ScaledInteger"
             ? value * node.attribute("scale").as_double(1.0) + node.attribute("offset").as_double(0.0)
             : value;
}

std::optional<std::array<double, 2>> pairIn(pugi::xml_node parent, const char* low, const char* high) {
  if (!parent || !parent.child(low) || !parent.child(high)) return std::nullopt;
  return std::array<double, 2>{numberIn(parent.child(low)), numberIn(parent.child(high))};
}

std::vector<Declared> declaredScans(std::string_view file) {
  const std::string xml = xmlOf(file);
  pugi::xml_document document;
  EXPECT_TRUE(document.load_buffer(xml.data(), xml.size()));
  std::vector<Declared> scans;
  for (pugi::xml_node scan : document.child("e57Root").child("data3D").children("vectorChild")) {
    Declared declared;
    const pugi::xml_node points = scan.child("points");
    declared.records = points.attribute("recordCount").as_ullong();
    if (const pugi::xml_node b = scan.child("cartesianBounds")) {
      const auto x = pairIn(b, "xMinimum", "xMaximum"), y = pairIn(b, "yMinimum", "yMaximum"),
                 z = pairIn(b, "zMinimum", "zMaximum");
      declared.cartesianBounds = std::array<std::array<double, 2>, 3>{*x, *y, *z};
    }
    const char* axes[] = {"cartesianX", "cartesianY", "cartesianZ"};
    for (int axis = 0; axis < 3; ++axis) {
      const pugi::xml_node field = points.child("prototype").child(axes[axis]);
      if (!field.attribute("minimum") || !field.attribute("maximum")) continue;
      const double scale = field.attribute("scale").as_double(1.0), offset = field.attribute("offset").as_double(0.0);
      declared.prototypeRanges[axis] = std::array<double, 2>{field.attribute("minimum").as_double() * scale + offset,
                                                             field.attribute("maximum").as_double() * scale + offset};
    }
    declared.rangeBounds = pairIn(scan.child("sphericalBounds"), "rangeMinimum", "rangeMaximum");
    declared.intensityLimits = pairIn(scan.child("intensityLimits"), "intensityMinimum", "intensityMaximum");
    if (const pugi::xml_node pose = scan.child("pose")) {
      if (const pugi::xml_node r = pose.child("rotation")) {
        const char* names[] = {"w", "x", "y", "z"};
        for (int i = 0; i < 4; ++i) declared.rotation[i] = r.child(names[i]) ? numberIn(r.child(names[i])) : 0.0;
      }
      if (const pugi::xml_node t = pose.child("translation")) {
        const char* names[] = {"x", "y", "z"};
        for (int i = 0; i < 3; ++i) declared.translation[i] = t.child(names[i]) ? numberIn(t.child(names[i])) : 0.0;
      }
    }
    scans.push_back(declared);
  }
  return scans;
}

std::string realFile(const std::string& name) {
  std::ifstream in(fs::path(APO_SOURCE_DIR) / "fuzz" / "corpus" / "e57" / name, std::ios::binary);
  EXPECT_TRUE(in) << name;
  std::ostringstream bytes;
  bytes << in.rdbuf();
  return bytes.str();
}

// ---- CRC-32C --------------------------------------------------------------------------

TEST(E57Crc, MatchesPublishedCheckValues) {
  EXPECT_EQ(e57::crc32c("123456789"), 0xE3069283u);  // the CRC catalogue's check value
  // RFC 3720 (iSCSI), appendix B.4.
  EXPECT_EQ(e57::crc32c(std::string(32, '\0')), 0x8A9136AAu);
  EXPECT_EQ(e57::crc32c(std::string(32, '\xFF')), 0x62A8AB43u);
  std::string ascending(32, '\0');
  for (int i = 0; i < 32; ++i) ascending[i] = static_cast<char>(i);
  EXPECT_EQ(e57::crc32c(ascending), 0x46DD794Eu);
}

TEST(E57Crc, TableDrivenEqualsBitwiseAtEveryLengthAndAlignment) {
  std::mt19937 random(57);
  std::string bytes(300, '\0');
  for (char& c : bytes) c = static_cast<char>(random());
  for (std::size_t start = 0; start < 9; ++start)
    for (std::size_t length = 0; start + length <= bytes.size(); length += 7)
      ASSERT_EQ(e57::crc32c(std::string_view(bytes).substr(start, length)),
                bitwiseCrc32c(std::string_view(bytes).substr(start, length)))
          << start << " " << length;
}

TEST(E57Crc, TheRealFilesPagesCarryTheirCrcs) {
  for (const char* name : {"A_B.e57", "bunnyInt32.e57", "read_error.e57"})
    EXPECT_TRUE(pagesHaveTheirCrcs(realFile(name))) << name;
  EXPECT_FALSE(pagesHaveTheirCrcs(realFile("bad-crc.e57")));
}

// ---- Real files --------------------------------------------------------------------

struct RealFile {
  const char* name;
  std::vector<std::uint64_t> records;  // per scan, from the data's README
  // The standard puts cartesianBounds in the scan's own frame; pye57's test
  // file gives them after its pose (x in [4, 5] for points in [0, 1] moved by 4).
  bool boundsAfterPose = false;
};

// ColourRepresentation.e57 has one data3D of 153 records: the README's "3
// scans, 153/2/1" counted the two pointGroupingSchemes groups (compressed
// vectors of 2 and 1 records) inside it as scans.

const std::vector<RealFile> kValidFiles = {
    {"A_B.e57", {2, 4}},
    {"ColourRepresentation.e57", {153}},
    {"translationWithoutRotation.e57", {4}, true},
    {"tiny_pc_and_images.e57", {2}},
    {"read_error.e57", {2651}},
    {"tiny_spherical.e57", {360}},
    {"integer_intensity.e57", {2}},
    {"ColouredCubeFloat.e57", {7680}},
    {"bunnyInt32.e57", {30571}},
};

// Records of `station` the reader skipped as invalid, from its note.
std::uint64_t skippedOf(const Scan& scan, std::size_t station) {
  const std::regex pattern("^/data3D/" + std::to_string(station) + " \\(.*\\): ([0-9]+) of [0-9]+ records skipped");
  for (const std::string& note : scan.readNotes) {
    std::smatch match;
    if (std::regex_search(note, match, pattern)) return std::stoull(match[1]);
  }
  return 0;
}

// A point of `station` back in its scan's own frame: the inverse of the pose
// the file declares (read here), applied to the reader's output.
std::array<double, 3> inScanFrame(const Scan& scan, std::size_t i, const Declared& declared) {
  std::array<double, 3> p;
  for (int axis = 0; axis < 3; ++axis)
    p[axis] = scan.origin[axis] + scan.points.positions[i][axis] - declared.translation[axis];
  Eigen::Quaterniond q(declared.rotation[0], declared.rotation[1], declared.rotation[2], declared.rotation[3]);
  q.normalize();
  const Eigen::Vector3d local = q.conjugate() * Eigen::Vector3d(p[0], p[1], p[2]);
  return {local.x(), local.y(), local.z()};
}

void expectInside(double value, const std::array<double, 2>& range, const char* what) {
  const double slack = 1e-5 * (1.0 + std::abs(range[0]) + std::abs(range[1]));
  EXPECT_GE(value, range[0] - slack) << what;
  EXPECT_LE(value, range[1] + slack) << what;
}

TEST(E57Reader, ReadsEveryRecordOfTheRealFilesInsideTheirDeclaredBounds) {
  for (const RealFile& file : kValidFiles) {
    SCOPED_TRACE(file.name);
    const std::string bytes = realFile(file.name);
    const std::vector<Declared> declared = declaredScans(bytes);
    ASSERT_EQ(declared.size(), file.records.size());
    Scan scan;
    ASSERT_NO_THROW(scan = readers::readE57(bytes));
    ASSERT_EQ(scan.stations.size(), declared.size());
    ASSERT_EQ(scan.points.stations.size(), scan.points.size());
    std::uint64_t total = 0;
    for (std::size_t s = 0; s < declared.size(); ++s) {
      EXPECT_EQ(declared[s].records, file.records[s]) << "scan " << s;
      EXPECT_EQ(scan.stations[s].pointCount + skippedOf(scan, s), declared[s].records) << "scan " << s;
      total += scan.stations[s].pointCount;
    }
    EXPECT_EQ(scan.points.size(), total);
    for (std::size_t i = 0; i < scan.points.size(); ++i) {
      const std::uint16_t s = scan.points.stations[i];
      ASSERT_LT(s, declared.size());
      const auto local = inScanFrame(scan, i, declared[s]);
      for (int axis = 0; axis < 3; ++axis) {
        const double world = scan.origin[axis] + scan.points.positions[i][axis];
        if (declared[s].cartesianBounds)
          expectInside(file.boundsAfterPose ? world : local[axis], (*declared[s].cartesianBounds)[axis],
                       "cartesianBounds");
        if (declared[s].prototypeRanges[axis])
          expectInside(local[axis], *declared[s].prototypeRanges[axis], "prototype range");
      }
      if (declared[s].rangeBounds)
        expectInside(std::hypot(local[0], local[1], local[2]), *declared[s].rangeBounds, "sphericalBounds");
      // Intensities come out mapped by the declared limits: [0, 1] is inside them.
      if (scan.points.hasIntensities() && declared[s].intensityLimits)
        expectInside(scan.points.intensities[i], {0.0, 1.0}, "intensityLimits");
      if (HasFailure()) return;
    }
  }
}

TEST(E57Reader, KeepsEachScansPoseAndStationFacts) {
  // Translation (4, 5, 6), no rotation; indexBounds rows 0..3, one column.
  const Scan translated = readers::readE57(realFile("translationWithoutRotation.e57"));
  ASSERT_EQ(translated.stations.size(), 1u);
  const ScanStation& station = translated.stations[0];
  EXPECT_TRUE(station.hasPose);
  EXPECT_EQ(station.rotationWxyz, (std::array<double, 4>{1, 0, 0, 0}));
  for (int axis = 0; axis < 3; ++axis) EXPECT_DOUBLE_EQ(translated.origin[axis] + station.position[axis], 4.0 + axis);
  EXPECT_EQ(station.rowCount, 4u);
  EXPECT_EQ(station.columnCount, 1u);
  EXPECT_FALSE(translated.points.hasGridIndices());  // the records carry no indices

  // Two named scans, intensity and colour in both.
  const Scan twoScans = readers::readE57(realFile("A_B.e57"));
  ASSERT_EQ(twoScans.stations.size(), 2u);
  EXPECT_EQ(twoScans.stations[0].name, "B2 - Cloud");
  EXPECT_EQ(twoScans.stations[1].name, "A4 - Cloud");
  EXPECT_EQ(twoScans.points.stations, (std::vector<std::uint16_t>{0, 0, 1, 1, 1, 1}));
  EXPECT_TRUE(twoScans.points.hasColors());
  EXPECT_TRUE(twoScans.points.hasIntensities());
  EXPECT_THAT(twoScans.readNotes,
              Contains(HasSubstr("intensities mapped to [0, 1] from their limits [0, 0.873046875]")));

  // A structured spherical scan: a grid per point, its size from the data.
  const Scan grid = readers::readE57(realFile("read_error.e57"));
  ASSERT_TRUE(grid.points.hasGridIndices());
  ASSERT_EQ(grid.stations.size(), 1u);
  EXPECT_GT(grid.stations[0].rowCount, 0u);
  for (std::size_t i = 0; i < grid.points.size(); ++i) {
    ASSERT_LT(grid.points.rows[i], grid.stations[0].rowCount);
    ASSERT_LT(grid.points.columns[i], grid.stations[0].columnCount);
    ASSERT_LE(grid.points.rows[i], 8533u);  // its prototype's declared maximum
    ASSERT_LE(grid.points.columns[i], 5741u);
  }
}

TEST(E57Reader, NamesWhatItDoesNotRead) {
  const Scan images = readers::readE57(realFile("tiny_pc_and_images.e57"));
  EXPECT_THAT(images.readNotes, Contains(AllOf(HasSubstr("4 images2D"), HasSubstr("pinhole"), HasSubstr("spherical"),
                                               HasSubstr("cylindrical"), HasSubstr("not read"))));
  const Scan las = readers::readE57(realFile("ColourRepresentation.e57"));
  EXPECT_THAT(las.readNotes, Contains(AllOf(HasSubstr("/data3D/0"), HasSubstr("las:pointSourceId"))));
  EXPECT_THAT(las.readNotes, Contains(HasSubstr("colours mapped to 0-255 from their limits [0, 65535]")));
  const Scan bunny = readers::readE57(realFile("bunnyInt32.e57"));
  EXPECT_THAT(bunny.readNotes, Contains(AllOf(HasSubstr("elements not read"), HasSubstr("temperature"))));
}

TEST(E57Reader, NotesPointsOutsideTheirDeclaredBounds) {
  // pye57's file gives its bounds after the pose: all 4 points are outside
  // them in the scan's own frame.
  EXPECT_THAT(readers::readE57(realFile("translationWithoutRotation.e57")).readNotes,
              Contains(HasSubstr("/data3D/0 (Scan 0): 4 points lie outside its declared cartesianBounds")));
  // A spherical scan of ranges up to 1, declared up to 0.5.
  const std::string bytes = realFile("tiny_spherical.e57");
  const std::string bounds =
      "<sphericalBounds type=\"Structure\"><rangeMinimum type=\"Float\"/><rangeMaximum "
      "type=\"Float\">0.5</rangeMaximum></sphericalBounds><points ";
  const Scan scan = readers::readE57(withXml(bytes, replaced(xmlOf(bytes), "<points ", bounds)));
  EXPECT_THAT(scan.readNotes,
              Contains(AllOf(HasSubstr("points lie outside its declared"), HasSubstr("sphericalBounds"))));
  for (const Vec3f& p : scan.points.positions) EXPECT_GT(p.norm(), 0.5f);
}

TEST(E57Reader, RefusesTheBrokenRealFilesSayingWhy) {
  EXPECT_THAT(e57Failure(realFile("bad-crc.e57")),
              AllOf(HasSubstr("byte 0: page 0's CRC-32C"), HasSubstr("does not match")));
  EXPECT_THAT(e57Failure(realFile("InvalidCVHeader.e57")),
              AllOf(HasSubstr("byte 48"), HasSubstr("/data3D/0/points' compressed vector section"),
                    HasSubstr("section id 182")));
  // A scan of zero records and no section: nothing to read, refused like
  // every reader refuses an empty scan.
  EXPECT_THAT(e57Failure(realFile("ZeroPointsInvalid.e57")), HasSubstr("no points"));
}

TEST(E57Reader, ReadScanNamesTheFileOfAnEmptyScan) {
  const fs::path path = test::freshTempDir() / "ZeroPointsInvalid.e57";
  test::writeBytes(path, realFile("ZeroPointsInvalid.e57"));
  const auto scan = readScan(path);
  ASSERT_FALSE(scan.ok());
  EXPECT_EQ(scan.error().kind, ErrorKind::BadInput);
  EXPECT_THAT(scan.error().message, AllOf(HasSubstr(path.string()), HasSubstr("no points")));
}

TEST(E57Reader, RefusesEveryTruncation) {
  for (const char* name : {"A_B.e57", "ColourRepresentation.e57", "tiny_spherical.e57"}) {
    const std::string bytes = realFile(name);
    for (std::size_t size = 0; size < bytes.size(); size += size < 64 ? 1 : 97) {
      SCOPED_TRACE(std::string(name) + " cut at " + std::to_string(size));
      EXPECT_THAT(e57Failure(bytes.substr(0, size)), testing::Not(testing::IsEmpty()));
    }
    // Whole pages cut off, their CRCs fine and the header's length mended: the
    // sections the XML names are gone.
    for (std::size_t pages = 1; pages * 1024 < bytes.size(); ++pages) {
      std::string cut = bytes.substr(0, pages * 1024);
      const std::uint64_t length = cut.size();
      std::memcpy(cut.data() + 16, &length, 8);
      sealWithBitwiseCrcs(cut);
      EXPECT_THAT(e57Failure(cut), testing::Not(testing::IsEmpty())) << name << " " << pages << " pages";
    }
  }
}

TEST(E57Reader, RefusesHugeRecordCountsBeforeAllocating) {
  const std::string bytes = realFile("bunnyInt32.e57");
  const std::string xml = replaced(xmlOf(bytes), "recordCount=\"30571\"", "recordCount=\"100000000000\"");
  EXPECT_THAT(e57Failure(withXml(bytes, xml)),
              AllOf(HasSubstr("byte 48"), HasSubstr("/data3D/0/points claims 100000000000 records")));
}

TEST(E57Reader, RefusesScansThatShareASectionBeyondTheFilesSize) {
  const std::string bytes = realFile("bunnyInt32.e57");
  const std::string xml = xmlOf(bytes);
  const std::size_t start = xml.find("<vectorChild"), end = xml.find("</vectorChild>") + 14;
  std::string copies;
  for (int i = 0; i < 30; ++i) copies += xml.substr(start, end - start);
  EXPECT_THAT(e57Failure(withXml(bytes, xml.substr(0, start) + copies + xml.substr(end))),
              HasSubstr("XML element /data3D: the scans' records up to /data3D/1 claim more bytes than the file's"));
}

TEST(E57Reader, ErrorsNameTheXmlElement) {
  const std::string bytes = realFile("A_B.e57");
  const std::string xml = xmlOf(bytes);
  EXPECT_THAT(e57Failure(withXml(bytes, replaced(xml, "precision=\"single\" minimum=\"-4.26422997e+001\"",
                                                 "precision=\"half\" minimum=\"-4.26422997e+001\""))),
              HasSubstr("XML element /data3D/0/points/prototype/cartesianX: precision 'half'"));
  EXPECT_THAT(e57Failure(withXml(bytes, replaced(xml, "<colorRed type=\"Integer\" minimum=\"0\" maximum=\"255\"/>",
                                                 "<colorRed type=\"String\"/>"))),
              HasSubstr("XML element /data3D/0/points/prototype/colorRed: a 'String' field"));
  EXPECT_THAT(e57Failure(withXml(bytes, replaced(xml, "recordCount=\"2\"", "recordCount=\"two\""))),
              HasSubstr("XML element /data3D/0/points (attribute recordCount): expected an integer, got 'two'"));
  EXPECT_THAT(e57Failure(withXml(bytes, replaced(xml, "</e57Root>", "</e57Roo>"))),
              HasSubstr("the XML section is not well-formed"));
}

// Packs values least significant bit first, `bits` each: written here
// apart from the writer's packer.
std::string packBits(const std::vector<std::uint64_t>& values, int bits) {
  std::string bytes((values.size() * bits + 7) / 8, '\0');
  std::size_t bit = 0;
  for (const std::uint64_t value : values)
    for (int b = 0; b < bits; ++b, ++bit)
      if ((value >> b) & 1) bytes[bit / 8] = static_cast<char>(bytes[bit / 8] | (1 << (bit % 8)));
  return bytes;
}

template <class T>
void append(std::string& bytes, T value) {
  bytes.append(reinterpret_cast<const char*>(&value), sizeof(T));
}

// An E57 file made by hand: one scan of `records` records whose prototype
// is `prototype` (XML), its streams cut into data packets at the byte
// offsets `cuts` (the same for every stream), wherever records fall.
std::string handMadeE57(const std::string& prototype, std::uint64_t records, const std::vector<std::string>& streams,
                        const std::vector<std::size_t>& cuts) {
  std::string logical(48, '\0');
  const std::uint64_t section = logical.size();
  logical += std::string(32, '\0');
  std::size_t from = 0;
  for (std::size_t p = 0; p <= cuts.size(); ++p) {
    std::string packet = {1, 0, 0, 0};
    append<std::uint16_t>(packet, static_cast<std::uint16_t>(streams.size()));
    std::string body;
    for (const std::string& stream : streams) {
      const std::size_t to = p < cuts.size() ? std::min(cuts[p], stream.size()) : stream.size();
      const std::string slice = stream.substr(std::min(from, stream.size()), to - std::min(from, to));
      append<std::uint16_t>(packet, static_cast<std::uint16_t>(slice.size()));
      body += slice;
    }
    packet += body;
    packet.resize((packet.size() + 3) / 4 * 4, '\0');
    const auto lengthMinusOne = static_cast<std::uint16_t>(packet.size() - 1);
    std::memcpy(packet.data() + 2, &lengthMinusOne, 2);
    logical += packet;
    if (p < cuts.size()) from = cuts[p];
  }
  logical[section] = 1;
  const std::uint64_t sectionLength = logical.size() - section, dataOffset = section + 32;
  std::memcpy(logical.data() + section + 8, &sectionLength, 8);
  std::memcpy(logical.data() + section + 16, &dataOffset, 8);  // within page 0: physical = logical
  const std::string xml = "<?xml version=\"1.0\"?><e57Root type=\"Structure\"><data3D type=\"Vector\">"
                          "<vectorChild type=\"Structure\"><points type=\"CompressedVector\" fileOffset=\"48\" "
                          "recordCount=\"" + std::to_string(records) + "\"><prototype type=\"Structure\">" +
                          prototype + "</prototype></points></vectorChild></data3D></e57Root>";
  std::memcpy(logical.data(), "ASTM-E57", 8);
  const std::uint32_t major = 1;
  std::memcpy(logical.data() + 8, &major, 4);
  const std::uint64_t pageSize = 1024;
  std::memcpy(logical.data() + 40, &pageSize, 8);
  std::string file;
  for (std::size_t at = 0; at < logical.size(); at += 1020)
    file += logical.substr(at, 1020) + std::string(1020 - std::min<std::size_t>(1020, logical.size() - at), '\0') +
            std::string(4, '\0');
  const std::uint64_t xmlOffset = file.size();  // the start of a page after the last
  std::memcpy(file.data() + 24, &xmlOffset, 8);
  return withXml(file, xml);
}

TEST(E57Reader, UnpacksWideIntegersAcrossPacketsWhereverRecordsFall) {
  // 61-bit and 64-bit fields (two word loads per value), a constant 0-bit
  // field, and packets cut through the middle of values.
  const std::vector<std::uint64_t> x = {0, 1, std::uint64_t{1} << 40, (std::uint64_t{1} << 60) + 12345, 77, 3};
  const std::vector<std::int64_t> y = {-5, 0, 1 << 20, std::numeric_limits<std::int64_t>::min(),
                                       std::numeric_limits<std::int64_t>::max(), -(1 << 22)};
  std::vector<std::uint64_t> yRaw;
  for (const std::int64_t v : y) yRaw.push_back(static_cast<std::uint64_t>(v) - static_cast<std::uint64_t>(INT64_MIN));
  const std::string prototype =
      "<cartesianX type=\"Integer\" minimum=\"0\" maximum=\"2305843009213693951\"/>"
      "<cartesianY type=\"ScaledInteger\" minimum=\"-9223372036854775808\" maximum=\"9223372036854775807\" "
      "scale=\"1e-6\"/><cartesianZ type=\"Integer\" minimum=\"5\" maximum=\"5\"/>";
  for (const std::vector<std::size_t>& cuts : {std::vector<std::size_t>{}, {3}, {7, 8, 29}, {1, 2, 3, 4, 5, 6, 7}}) {
    SCOPED_TRACE(testing::PrintToString(cuts));
    const std::string bytes = handMadeE57(prototype, x.size(), {packBits(x, 61), packBits(yRaw, 64), ""}, cuts);
    Scan scan;
    ASSERT_NO_THROW(scan = readers::readE57(bytes)) << e57Failure(bytes);
    ASSERT_EQ(scan.points.size(), x.size());
    for (std::size_t i = 0; i < x.size(); ++i) {
      EXPECT_EQ(scan.origin[0] + scan.points.positions[i].x(), static_cast<float>(static_cast<double>(x[i])));
      EXPECT_FLOAT_EQ(static_cast<float>(scan.origin[1] + scan.points.positions[i].y()),
                      static_cast<float>(static_cast<double>(y[i]) * 1e-6));
      EXPECT_EQ(scan.origin[2] + scan.points.positions[i].z(), 5.0);
    }
  }
}

// Random byte changes with the CRCs mended (what the fuzz target does, a
// few thousand times): each either reads or is refused with a message.
TEST(E57Reader, SurvivesCorruptionsBehindValidCrcs) {
  std::mt19937 random(2807);
  for (const char* name : {"A_B.e57", "ColourRepresentation.e57", "read_error.e57", "tiny_pc_and_images.e57"}) {
    const std::string good = realFile(name);
    for (int round = 0; round < 500; ++round) {
      std::string bytes = good;
      const int changes = 1 + static_cast<int>(random() % 4);
      for (int c = 0; c < changes; ++c) bytes[random() % bytes.size()] = static_cast<char>(random());
      e57::sealPages(bytes);
      try {
        const Scan scan = readers::readE57(bytes);
        EXPECT_EQ(scan.points.stations.size(), scan.points.size());
      } catch (const parse::ParseFailure&) {
      }
    }
  }
}

// ---- Writer ------------------------------------------------------------------------

// Three stations, posed and gridded, with intensities in [0, 1], colours and
// normals, far from zero like a georeferenced survey.
Scan surveyOfThreeStations() {
  Scan scan;
  scan.origin = {512000.0, 5400000.0, 300.0};
  const std::array<std::array<double, 4>, 3> rotations = {
      {{1, 0, 0, 0}, {0.9238795325112867, 0, 0, 0.3826834323650898}, {0.5, 0.5, -0.5, 0.5}}};
  const std::array<Vec3f, 3> positions = {Vec3f(0, 0, 1.5f), Vec3f(20, -5, 1.4f), Vec3f(-12, 30, 2.0f)};
  std::mt19937 random(44);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  for (int s = 0; s < 3; ++s) {
    ScanStation station;
    station.name = "station " + std::to_string(s);
    station.position = positions[s];
    station.rotationWxyz = rotations[s];
    station.hasPose = true;
    station.rowCount = 40;
    station.columnCount = 30 + s;
    const Eigen::Quaterniond q(rotations[s][0], rotations[s][1], rotations[s][2], rotations[s][3]);
    for (std::uint32_t row = 0; row < station.rowCount; ++row)
      for (std::uint32_t column = 0; column < station.columnCount; column += 1 + (row % 2)) {
        const double azimuth = 0.2 * column, elevation = 0.03 * row - 0.5, range = 3.0 + 10.0 * unit(random);
        const Eigen::Vector3d local(range * std::cos(elevation) * std::cos(azimuth),
                                    range * std::cos(elevation) * std::sin(azimuth), range * std::sin(elevation));
        const Eigen::Vector3d world = q * local + positions[s].cast<double>();
        scan.points.positions.push_back(world.cast<float>());
        scan.points.normals.push_back((q * -local.normalized()).cast<float>());
        scan.points.intensities.push_back(unit(random));
        scan.points.colors.push_back({static_cast<std::uint8_t>(random()), static_cast<std::uint8_t>(random()),
                                      static_cast<std::uint8_t>(random())});
        scan.points.stations.push_back(static_cast<std::uint16_t>(s));
        scan.points.rows.push_back(row);
        scan.points.columns.push_back(column);
        ++station.pointCount;
      }
    scan.stations.push_back(station);
  }
  return scan;
}

TEST(E57Writer, RoundTripKeepsPointsStationsPosesGridsAndAttributes) {
  const Scan scan = surveyOfThreeStations();
  const std::string bytes = readers::encodeE57(scan);
  ASSERT_TRUE(pagesHaveTheirCrcs(bytes));
  EXPECT_EQ(readers::encodeE57(scan), bytes);  // deterministic
  const Scan read = readers::readE57(bytes);

  ASSERT_EQ(read.points.size(), scan.points.size());
  ASSERT_EQ(read.stations.size(), 3u);
  for (std::size_t s = 0; s < 3; ++s) {
    const ScanStation &want = scan.stations[s], &got = read.stations[s];
    EXPECT_EQ(got.name, want.name);
    EXPECT_TRUE(got.hasPose);
    EXPECT_EQ(got.pointCount, want.pointCount);
    EXPECT_EQ(got.rowCount, want.rowCount);
    EXPECT_EQ(got.columnCount, want.columnCount);
    for (int i = 0; i < 4; ++i) EXPECT_NEAR(got.rotationWxyz[i], want.rotationWxyz[i], 1e-15);
    for (int axis = 0; axis < 3; ++axis)
      EXPECT_NEAR(read.origin[axis] + got.position[axis], scan.origin[axis] + want.position[axis], 1e-6);
  }
  // Points come back per station in their order: this scan's already are.
  EXPECT_EQ(read.points.stations, scan.points.stations);
  EXPECT_EQ(read.points.rows, scan.points.rows);
  EXPECT_EQ(read.points.columns, scan.points.columns);
  EXPECT_EQ(read.points.colors, scan.points.colors);
  EXPECT_EQ(read.points.intensities, scan.points.intensities);
  double worst = 0.0, worstNormal = 0.0;
  for (std::size_t i = 0; i < scan.points.size(); ++i)
    for (int axis = 0; axis < 3; ++axis) {
      worst = std::max(worst, std::abs((read.origin[axis] + read.points.positions[i][axis]) -
                                       (scan.origin[axis] + scan.points.positions[i][axis])));
      worstNormal =
          std::max(worstNormal, double(std::abs(read.points.normals[i][axis] - scan.points.normals[i][axis])));
    }
  // Coordinates within 15 m of their station: a scale of 1e-7 m, plus the
  // floats' own spacing at those coordinates (about 1e-6).
  EXPECT_LT(worst, 4e-6);
  EXPECT_LT(worstNormal, 1e-6);
}

TEST(E57Writer, PagesPassAnIndependentCrc32cImplementation) {
  if (std::system("/usr/bin/python3 -c 'import crc32c' 2>/dev/null") != 0)
    GTEST_SKIP() << "python3-crc32c is not installed";
  const fs::path path = test::freshTempDir() / "survey.e57";
  ASSERT_TRUE(writeE57(path, surveyOfThreeStations()).ok());
  const std::string check =
      "/usr/bin/python3 -c \"import crc32c, sys; b = open(sys.argv[1], 'rb').read(); "
      "sys.exit(0 if len(b) % 1024 == 0 and all(crc32c.crc32c(b[i:i + 1020]) == int.from_bytes(b[i + 1020:i + 1024], "
      "'big') for i in range(0, len(b), 1024)) else 1)\" " +
      path.string();
  EXPECT_EQ(std::system(check.c_str()), 0);
}

TEST(E57Writer, WritesThroughReadScanAndAScanWithoutStations) {
  Scan plain;
  plain.origin = {0.0, 0.0, 0.0};
  for (const Vec3f& p : test::fibonacciSpherePoints(500)) plain.points.positions.push_back(p);
  plain.points.positions.push_back(Vec3f(std::nanf(""), 0, 0));  // written as invalid
  const fs::path path = test::freshTempDir() / "plain.e57";
  ASSERT_TRUE(writeE57(path, plain).ok());
  const auto read = readScan(path);
  ASSERT_TRUE(read.ok()) << read.error().message;
  ASSERT_EQ(read->points.size(), 500u);
  ASSERT_EQ(read->stations.size(), 1u);
  EXPECT_FALSE(read->stations[0].hasPose);
  EXPECT_THAT(read->readNotes,
              Contains(HasSubstr("1 of 501 records skipped as invalid (0 with a direction only, 1 invalid)")));
  for (std::size_t i = 0; i < 500; ++i)
    EXPECT_LT((read->points.positions[i] - plain.points.positions[i]).norm(), 1e-6f);
}

// Not a test: the decoding speed on 20 million points, for docs/ingest.md.
//   build/ingest_tests --gtest_filter='E57Speed.*' --gtest_also_run_disabled_tests
TEST(E57Speed, DISABLED_TwentyMillionPoints) {
  Scan scan;
  const std::size_t count = 20'000'000;
  scan.points.positions.resize(count);
  std::mt19937 random(20);
  std::uniform_real_distribution<float> coordinate(-50.0f, 50.0f);
  for (Vec3f& p : scan.points.positions) p = Vec3f(coordinate(random), coordinate(random), coordinate(random) * 0.1f);
  auto start = std::chrono::steady_clock::now();
  const std::string bytes = readers::encodeE57(scan);
  const double encodeSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("E57 of %zu scaled-integer points, %.1f MB: encode %.2f s\n", count, bytes.size() / 1e6, encodeSeconds);
  // Three reads: on a shared machine the best is the one least disturbed.
  for (int round = 0; round < 3; ++round) {
    start = std::chrono::steady_clock::now();
    const std::clock_t cpuStart = std::clock();
    const Scan read = readers::readE57(bytes);
    const double cpuSeconds = double(std::clock() - cpuStart) / CLOCKS_PER_SEC;
    const double readSeconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    ASSERT_EQ(read.points.size(), count);
    std::printf("read %.2f s wall (%.2f s CPU) = %.1f million points/s\n", readSeconds, cpuSeconds,
                count / readSeconds / 1e6);
  }
}

}  // namespace
}  // namespace apo
