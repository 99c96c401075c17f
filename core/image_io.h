// Image output shared by the stages (the APO texture, rendered images).
#pragma once

#include "core/error.h"

#include <cstdint>
#include <filesystem>
#include <vector>

namespace apo {

// Writes an 8-bit RGBA PNG, atomically (core/file_io.h). `rgba` is row-major,
// top row first, width * height * 4 bytes. The bytes depend only on the
// arguments. Errors (Internal) name the path: bad sizes, encoder failure, or
// the file cannot be written.
Status writePngRgba8(const std::filesystem::path& path, std::uint32_t width, std::uint32_t height,
                     const std::vector<std::uint8_t>& rgba);

}  // namespace apo
