// Internal to ingest: one pure function per format, from a file's bytes to a
// Scan. They throw parse::ParseFailure with the position in the message;
// readScan() adds the file name and turns it into a BadInput Error.
#pragma once

#include "core/geometry.h"

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace apo::readers {

Scan readPly(std::string_view bytes);
Scan readPcd(std::string_view bytes);
Scan readXyz(std::string_view bytes);  // XYZ, XYZN, PTS and whitespace columns
Scan readOff(std::string_view bytes);
Scan readObj(std::string_view bytes);
Scan readStl(std::string_view bytes);
Scan readLas(std::string_view bytes);  // LAS 1.0-1.4, and LAZ (LASzip-compressed)
// A LAS or LAZ file's point records as an uncompressed LAS file holds them
// (the header's count times its record length), LAZ decompressed; refused
// as readLas refuses. For cross-checks against other LAZ decoders.
std::string lasPointRecords(std::string_view bytes);
// E57 (ASTM E2807) 1.0: every scan of the file, each a ScanStation, its
// points moved by its pose into one frame (docs/ingest.md, "E57").
Scan readE57(std::string_view bytes);
// The records its /data3D declares (valid or not), from its header and XML
// alone; nullopt when those do not read (the whole read then says why).
std::optional<std::uint64_t> e57RecordCount(std::string_view file);
// The same points as readE57, in order, in runs of `runPoints` (the last may
// hold fewer; a run may hold the end of one scan and the start of the next),
// each with the file's frame, stations and read notes and every attribute
// any scan has. The file is read twice through (readE57's two passes);
// `giveBack` is called every so often: the bytes read so far are not needed
// again soon (a mapped file's pages may go). Throws as readE57 does.
void readE57Runs(std::string_view file, std::uint64_t runPoints, const std::function<void(Scan& run)>& take,
                 const std::function<void()>& giveBack);

// Files whose points are fixed-size records (binary PLY of vertices alone,
// uncompressed LAS, binary PCD of one row): a run of their records behind the file's header, its
// count set to theirs, is a file of the same format, which its reader reads
// with every check and attribute it has. A file too large to hold is read so,
// a run at a time (docs/ingest.md, "Large scans").
struct RecordLayout {
  std::uint64_t count = 0;        // points in the file
  std::uint64_t recordsAt = 0;    // byte of the first record: the header is [0, recordsAt)
  std::uint64_t recordBytes = 0;  // bytes of each record
};
// The layout from the file's first bytes (they must hold its header), or
// nullopt when its points cannot be read a run at a time (an ASCII or LAZ
// body; a PLY with faces, list properties or elements before its vertices;
// an organised or compressed PCD; a header longer than `head`, or malformed:
// the whole file's read then says what is wrong).
std::optional<RecordLayout> plyRecordLayout(std::string_view head);
std::optional<RecordLayout> lasRecordLayout(std::string_view head);
std::optional<RecordLayout> pcdRecordLayout(std::string_view head);
// The scan of `records` (whole records of the file) given the file's header
// `head` (bytes [0, layout.recordsAt)).
Scan readPlyRecords(std::string_view head, std::string_view records, const RecordLayout& layout);
Scan readLasRecords(std::string_view head, std::string_view records, const RecordLayout& layout);
Scan readPcdRecords(std::string_view head, std::string_view records, const RecordLayout& layout);
// binary_compressed PCDs of one row, read a run at a time: their body is two
// sizes (compressed, uncompressed) and an LZF stream that decodes to the
// points field by field (every point's x, then every point's y, ...;
// padding fields left out). Runs of points gathered from the decoded fields
// into records are read as readPcdRecords reads the binary twin's.
struct PcdCompressedLayout {
  struct Block {
    std::uint64_t pointBytes = 0;    // one point's bytes of the field (size x count)
    std::uint64_t recordOffset = 0;  // where they sit in a binary record
    bool padding = false;            // not in the decoded body (zeros in records)
  };
  std::uint64_t count = 0;         // points
  std::uint64_t sizesAt = 0;       // byte of the two sizes, right after the header
  std::vector<Block> fields;       // in the header's order, the decoded body's
  RecordLayout binary;             // of the binary twin: its records' size, its header's length
  std::string binaryHead;          // the twin's header: the same but DATA binary
};
// nullopt when the head does not hold such a header (the whole read says why).
std::optional<PcdCompressedLayout> pcdCompressedLayout(std::string_view head);
// The two sizes behind the header (`sizes` starts at layout.sizesAt),
// checked against the header and the file's `fileBytes`. Throws
// parse::ParseFailure as readPcd does.
struct PcdCompressedStream {
  std::uint64_t compressedBytes = 0;  // the LZF stream's, from layout.sizesAt + 8
  std::uint64_t decodedBytes = 0;     // what it decodes to: every field of every point
};
PcdCompressedStream pcdCompressedStream(std::string_view sizes, const PcdCompressedLayout& layout,
                                        std::uint64_t fileBytes);
// LAZ files, whose records are decompressed a run of chunks at a time: the
// header's count from the file's first bytes (nullopt when it is not LAZ or
// the header does not read: the whole file's read then says why), and the
// points of each run of whole chunks holding at least `runPoints` (the last
// may hold fewer), each read as readLasRecords reads uncompressed records
// and handed to `take` with the byte where its chunks end. Returns how the
// file was compressed (a read note).
// Throws parse::ParseFailure as readLas does.
std::optional<std::uint64_t> lazPointCount(std::string_view head);
std::string readLazRuns(std::string_view file, std::uint64_t runPoints,
                        const std::function<void(Scan& run, std::size_t end)>& take);

// Text files whose points are one to a line (XYZ/CSV/PTS; ASCII PLY of
// vertices alone; ASCII PCD of one row): runs of whole lines, each behind the file's head, are
// read with the head's layout, naming the file's lines and points in errors.
// A file too large to hold is read so, a run at a time (docs/ingest.md,
// "Large scans").
struct TextLayout {
  std::uint64_t count = 0;      // points the header declares (PLY); 0 for XYZ, whose lines are counted
  std::size_t headBytes = 0;    // each run is read behind [0, headBytes)
  std::size_t dataBytes = 0;    // the data lines start here (at or before headBytes: XYZ's first
                                // data line may decide its columns)
  std::size_t linesBefore = 0;  // lines before dataBytes
};
// The layout from the file's first bytes, or nullopt when they do not decide
// it (a PLY that is binary or holds more than vertices; a head longer than
// `head`, or malformed: the whole file's read then says what is wrong).
std::optional<TextLayout> xyzTextLayout(std::string_view head);
std::optional<TextLayout> plyTextLayout(std::string_view head);
std::optional<TextLayout> pcdTextLayout(std::string_view head);
// Whether a line holds a point: not blank (PLY, PCD), and not a comment (XYZ).
bool isXyzDataLine(std::string_view line);
bool isNonBlankLine(std::string_view line);
// A run of whole lines: the lines and points of the file before it, and the
// points it holds (its data lines; the last run of a PLY: the rest of the
// header's count, so that lines beyond it are refused as the whole read
// refuses them).
struct TextRun {
  std::uint64_t linesBefore = 0, pointsBefore = 0, points = 0;
};
// The scan of `lines` (the run's whole lines) given the file's head
// (bytes [0, layout.headBytes)). Throws parse::ParseFailure.
Scan readXyzLines(std::string_view head, std::string_view lines, const TextRun& run);
Scan readPlyLines(std::string_view head, std::string_view lines, const TextRun& run);
Scan readPcdLines(std::string_view head, std::string_view lines, const TextRun& run);

enum class PlyEncoding { Ascii, BinaryLittleEndian };
// Local: float positions in the scan's frame, its origin in an apo_origin
// comment. World: double positions origin + position, no comment.
enum class PlyFrame { Local, World };
std::string encodePly(const Scan& scan, PlyEncoding encoding, PlyFrame frame = PlyFrame::Local);

// An E57 1.0 file of the scan: one data3D per station (one for a scan
// without stations) holding its points in the station's own frame (the
// inverse of its pose applied), its pose, grid indices, intensities and
// colours; docs/ingest.md, "E57", has the choices.
std::string encodeE57(const Scan& scan);

// A LAS 1.2 file of the scan's points (Laz: LASzip-compressed, compressor 2
// in 50,000-point chunks, as LASzip writes it): point format 0, or 2 when
// the points have colours (8-bit channels times 257); coordinates on the
// power-of-ten grid finest below half a float's spacing at the largest
// coordinate, offset at the box minimum plus the scan's origin (the file is
// in the scan's file coordinates); intensities as they are when all are
// whole numbers in [0, 65535], else scaled to [0, 65535]; classes 0 to 31
// (above: 1, unclassified); return numbers and counts (1 of 1 without);
// each point's station index as its point source id. The scan must have 1
// to 2^32 - 1 points, all finite (writeLas checks).
enum class LasEncoding { Las, Laz };
std::string encodeLas(const Scan& scan, LasEncoding encoding);

}  // namespace apo::readers
