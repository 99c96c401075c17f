// Image output shared by the stages (the APO texture, rendered images).
#pragma once

#include "core/error.h"

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace apo {

// Writes an 8-bit RGBA PNG, atomically (core/file_io.h). `rgba` is row-major,
// top row first, width * height * 4 bytes. The bytes depend only on the
// arguments. Errors (Internal) name the path: bad sizes, encoder failure, or
// the file cannot be written.
// The PNG bytes of an 8-bit image of `channels` (1 to 4) channels per pixel,
// row-major, top row first. Errors (Internal): bad sizes or encoder failure.
Result<std::string> encodePng8(std::uint32_t width, std::uint32_t height, int channels,
                               const std::vector<std::uint8_t>& pixels);

Status writePngRgba8(const std::filesystem::path& path, std::uint32_t width, std::uint32_t height,
                     const std::vector<std::uint8_t>& rgba);

}  // namespace apo
