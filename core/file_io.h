// File input and output that never loses data: inputs are only read, outputs
// are written to a temporary name in the destination folder and renamed over
// the final name once complete, so a killed run leaves either the old file or
// the new one, never a partial one.
#pragma once

#include "core/error.h"

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <iosfwd>
#include <string>
#include <string_view>

namespace apo {

// Reads a whole regular file. Errors (BadInput) name the path and say whether
// it is missing, a directory, unreadable or shorter than its reported size.
Result<std::string> readFileBytes(const std::filesystem::path& path);

// Up to `length` bytes of a file from byte `offset` (fewer where the file
// ends first): a file too large to hold is read a range at a time. Errors
// as readFileBytes's.
Result<std::string> readFileRange(const std::filesystem::path& path, std::uint64_t offset, std::size_t length);

// A regular file mapped read-only: its bytes, paged in from disk as they are
// read, and given back (release) once read, so that a file larger than
// memory can be read through in order. Errors as readFileBytes's.
class MappedFile {
 public:
  static Result<MappedFile> open(const std::filesystem::path& path);
  MappedFile(MappedFile&& other) noexcept;
  MappedFile& operator=(MappedFile&&) = delete;
  MappedFile(const MappedFile&) = delete;
  ~MappedFile();

  std::string_view bytes() const { return {static_cast<const char*>(data_), size_}; }
  // Drops the pages wholly before byte `end` from memory (reading them
  // again pages them in again).
  void release(std::size_t end) const;

 private:
  MappedFile(void* data, std::size_t size) : data_(data), size_(size) {}
  void* data_;
  std::size_t size_;
};

// A file read and written at byte offsets (pread, pwrite), closed when it
// goes. Errors name `what` the file is ("the point store"), its path and the
// byte; a write that fails for a full disk says so (ENOSPC's message).
class RawFile {
 public:
  RawFile(std::string what, const std::filesystem::path& path, int flags);  // open(2) flags; created 0644
  // A file of no name in `folder` (made, then unlinked at once): its space
  // comes back when it is closed, even if the process is killed.
  static Result<RawFile> scratch(std::string what, const std::filesystem::path& folder);
  RawFile(RawFile&& other) noexcept;
  RawFile& operator=(RawFile&&) = delete;
  RawFile(const RawFile&) = delete;
  RawFile& operator=(const RawFile&) = delete;
  ~RawFile();

  Status opened() const;
  Status write(std::uint64_t offset, const void* data, std::size_t bytes) const;
  Status read(std::uint64_t offset, void* data, std::size_t bytes) const;
  // Flushed to disk: a full disk may only show here.
  Status sync() const;

 private:
  RawFile(std::string what, std::filesystem::path path, int fd, int error)
      : what_(std::move(what)), path_(std::move(path)), fd_(fd), openError_(error) {}
  std::string what_;
  std::filesystem::path path_;
  int fd_;
  int openError_;  // errno of a failed open
};

// Checks that `path` names a readable regular file without reading it.
Status checkReadableFile(const std::filesystem::path& path);

// Writes `path` atomically: `writeBody` fills a stream opened on a temporary
// file beside `path`; the file is flushed, synced and renamed only if
// `writeBody` succeeded and the stream reports no error. Parent folders are
// created. Errors are Internal and name the path.
Status writeFileAtomically(const std::filesystem::path& path,
                           const std::function<Status(std::ostream&)>& writeBody);
Status writeFileAtomically(const std::filesystem::path& path, std::string_view bytes);

// A stage's error about an input file, its message prefixed with the path.
inline Error aboutInput(const std::filesystem::path& input, const Error& error) {
  return {error.kind, input.string() + ": " + error.message};
}

// Lower-case hex SHA-256 of a file's bytes, streamed (constant memory).
Result<std::string> sha256OfFile(const std::filesystem::path& path);
// Lower-case hex SHA-256 of a byte string.
std::string sha256OfBytes(std::string_view bytes);

}  // namespace apo
