// Format dispatch and file-level errors for the readers in readers.h.
#include "core/file_io.h"
#include "ingest/ingest.h"
#include "ingest/parse_util.h"
#include "ingest/readers.h"

#include <algorithm>
#include <cctype>

namespace apo {
namespace fs = std::filesystem;

std::string formatName(ScanFormat format) {
  switch (format) {
    case ScanFormat::Ply: return "ply";
    case ScanFormat::Pcd: return "pcd";
    case ScanFormat::Xyz: return "xyz";
    case ScanFormat::Off: return "off";
    case ScanFormat::Obj: return "obj";
    case ScanFormat::Stl: return "stl";
  }
  return "unknown";
}

namespace {

// The one list of scan file extensions (lower case) and their formats.
struct ExtensionFormat {
  const char* extension;
  ScanFormat format;
};
constexpr ExtensionFormat kExtensions[] = {
    {".ply", ScanFormat::Ply}, {".pcd", ScanFormat::Pcd}, {".xyz", ScanFormat::Xyz}, {".xyzn", ScanFormat::Xyz},
    {".pts", ScanFormat::Xyz}, {".pwn", ScanFormat::Xyz}, {".off", ScanFormat::Off}, {".obj", ScanFormat::Obj},
    {".stl", ScanFormat::Stl},
};

std::string lowercase(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return text;
}

}  // namespace

std::string scanExtensionList() {
  std::string list;
  for (const ExtensionFormat& entry : kExtensions) list += (list.empty() ? "" : " ") + std::string(entry.extension);
  return list;
}

bool hasScanExtension(const fs::path& path) { return formatFromExtension(path).ok(); }

Result<ScanFormat> formatFromExtension(const fs::path& path) {
  const std::string extension = lowercase(path.extension().string());
  for (const ExtensionFormat& entry : kExtensions)
    if (extension == entry.extension) return entry.format;
  return badInput("{}: unsupported extension '{}' (supported: {})", path.string(), extension, scanExtensionList());
}

Result<Scan> readScan(const fs::path& path) {
  APO_RETURN_IF_ERROR(checkReadableFile(path));
  const auto format = formatFromExtension(path);
  if (!format) return format.error();
  return readScan(path, *format);
}

Result<Scan> readScan(const fs::path& path, ScanFormat format) {
  auto bytes = readFileBytes(path);
  if (!bytes) return bytes.error();
  const std::string_view content = *bytes;
  try {
    switch (format) {
      case ScanFormat::Ply: return readers::readPly(content);
      case ScanFormat::Pcd: return readers::readPcd(content);
      case ScanFormat::Xyz: return readers::readXyz(content);
      case ScanFormat::Off: return readers::readOff(content);
      case ScanFormat::Obj: return readers::readObj(content);
      case ScanFormat::Stl: return readers::readStl(content);
    }
  } catch (const parse::ParseFailure& failure) {
    return badInput("{}: {}", path.string(), failure.what());
  } catch (const std::bad_alloc&) {
    return badInput("{}: not enough memory to hold its contents", path.string());
  }
  return internalError("{}: no reader for format {}", path.string(), static_cast<int>(format));
}

Status writePly(const fs::path& path, const Scan& scan) {
  return writeFileAtomically(path, readers::encodePly(scan, readers::PlyEncoding::BinaryLittleEndian));
}

Status writePlyAscii(const fs::path& path, const Scan& scan) {
  return writeFileAtomically(path, readers::encodePly(scan, readers::PlyEncoding::Ascii));
}

}  // namespace apo
