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

Result<ScanFormat> formatFromExtension(const fs::path& path) {
  std::string extension = path.extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (extension == ".ply") return ScanFormat::Ply;
  if (extension == ".pcd") return ScanFormat::Pcd;
  if (extension == ".xyz" || extension == ".xyzn" || extension == ".pts" || extension == ".pwn") return ScanFormat::Xyz;
  if (extension == ".off") return ScanFormat::Off;
  if (extension == ".obj") return ScanFormat::Obj;
  if (extension == ".stl") return ScanFormat::Stl;
  return badInput("{}: unsupported extension '{}' (supported: .ply .pcd .xyz .xyzn .pts .pwn .off .obj .stl)",
                  path.string(), extension);
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
