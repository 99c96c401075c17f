// Format dispatch and file-level errors for the readers in readers.h.
#include "core/file_io.h"
#include "ingest/ingest.h"
#include "ingest/parse_util.h"
#include "ingest/readers.h"

#include <algorithm>
#include <cctype>
#include <limits>

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
    case ScanFormat::Las: return "las";
    case ScanFormat::E57: return "e57";
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
    {".stl", ScanFormat::Stl}, {".las", ScanFormat::Las}, {".laz", ScanFormat::Las}, {".csv", ScanFormat::Xyz},
    {".asc", ScanFormat::Xyz}, {".e57", ScanFormat::E57},
};

// Scan formats labs meet that apo has no reader for, so that the refusal can
// say what the file is and what to do.
struct KnownFormat {
  const char* extension;
  const char* name;
};
constexpr KnownFormat kUnreadFormats[] = {
    {".ptx", "Leica PTX"},                 {".ptg", "Leica PTG"},
    {".fls", "FARO scan"},                 {".fws", "FARO workspace"},     {".rcp", "Autodesk ReCap project"},
    {".rcs", "Autodesk ReCap scan"},       {".zfs", "Z+F scan"},           {".x3a", "RIEGL scan"},
    {".rdbx", "RIEGL RDB"},                {".3mf", "3MF mesh"},           {".gltf", "glTF"},
    {".glb", "glTF binary"},               {".fbx", "FBX"},                {".dae", "COLLADA"},
};

std::string lowercase(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return text;
}

}  // namespace

std::string scanExtensionList() {
  std::string list;
  for (const ExtensionFormat& entry : kExtensions) {
    if (!list.empty()) list += ' ';
    list += entry.extension;
  }
  return list;
}

bool hasScanExtension(const fs::path& path) { return formatFromExtension(path).ok(); }

Result<ScanFormat> formatFromExtension(const fs::path& path) {
  const std::string extension = lowercase(path.extension().string());
  for (const ExtensionFormat& entry : kExtensions)
    if (extension == entry.extension) return entry.format;
  for (const KnownFormat& known : kUnreadFormats)
    if (extension == known.extension)
      return badInput("{}: {} files have no reader in apo: export the scan as PLY, LAS or XYZ (apo reads: {})",
                      path.string(), known.name, scanExtensionList());
  return badInput("{}: unsupported extension '{}' (apo reads: {})", path.string(), extension, scanExtensionList());
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
      case ScanFormat::Las: return readers::readLas(content);
      case ScanFormat::E57: return readers::readE57(content);
    }
  } catch (const parse::ParseFailure& failure) {
    return badInput("{}: {}", path.string(), failure.what());
  } catch (const std::bad_alloc&) {
    return badInput("{}: not enough memory to hold its contents", path.string());
  }
  return internalError("{}: no reader for format {}", path.string(), static_cast<int>(format));
}

Status writePly(const fs::path& path, const Scan& scan, bool worldCoordinates) {
  return writeFileAtomically(path, readers::encodePly(scan, readers::PlyEncoding::BinaryLittleEndian,
                                                      worldCoordinates ? readers::PlyFrame::World : readers::PlyFrame::Local));
}

Status writePlyAscii(const fs::path& path, const Scan& scan) {
  return writeFileAtomically(path, readers::encodePly(scan, readers::PlyEncoding::Ascii));
}

Status writeE57(const fs::path& path, const Scan& scan) { return writeFileAtomically(path, readers::encodeE57(scan)); }

Status writeLas(const fs::path& path, const Scan& scan, bool compressed) {
  const std::vector<Vec3f>& positions = scan.points.positions;
  if (positions.empty() || positions.size() > std::numeric_limits<std::uint32_t>::max())
    return badInput("{}: LAS 1.2 holds 1 to {} points, the scan has {}", path.string(),
                    std::numeric_limits<std::uint32_t>::max(), positions.size());
  const auto nonFinite = std::find_if(positions.begin(), positions.end(), [](const Vec3f& p) { return !p.allFinite(); });
  if (nonFinite != positions.end())
    return badInput("{}: LAS cannot hold point {}'s non-finite coordinates", path.string(), nonFinite - positions.begin());
  return writeFileAtomically(path, readers::encodeLas(scan, compressed ? readers::LasEncoding::Laz : readers::LasEncoding::Las));
}

}  // namespace apo
