#include "core/file_io.h"

#include <openssl/evp.h>

#include <fcntl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <limits>
#include <memory>
#include <random>
#include <sstream>

namespace apo {
namespace fs = std::filesystem;

namespace {

std::string describeErrno(int err) { return std::strerror(err); }

// A temporary name in the same folder (so rename is atomic) that two
// concurrent writers of the same file never share.
fs::path temporaryNameFor(const fs::path& path) {
  std::random_device device;
  return path.parent_path() /
         fmt::format(".{}.tmp-{}-{:08x}", path.filename().string(), ::getpid(), device());
}

Status syncFile(const fs::path& path) {
  const int fd = ::open(path.c_str(), O_RDONLY);
  if (fd < 0) return internalError("{}: cannot reopen to sync: {}", path.string(), describeErrno(errno));
  const int rc = ::fsync(fd);
  const int err = errno;
  ::close(fd);
  if (rc != 0) return internalError("{}: fsync failed: {}", path.string(), describeErrno(err));
  return okStatus();
}

class Sha256 {
 public:
  Sha256() : context_(EVP_MD_CTX_new(), EVP_MD_CTX_free) {
    APO_CHECK(context_ && EVP_DigestInit_ex(context_.get(), EVP_sha256(), nullptr) == 1);
  }
  void update(const void* data, std::size_t size) {
    APO_CHECK(EVP_DigestUpdate(context_.get(), data, size) == 1);
  }
  std::string hexDigest() {
    std::array<unsigned char, EVP_MAX_MD_SIZE> digest{};
    unsigned int length = 0;
    APO_CHECK(EVP_DigestFinal_ex(context_.get(), digest.data(), &length) == 1);
    std::string hex;
    for (unsigned int i = 0; i < length; ++i) hex += fmt::format("{:02x}", digest[i]);
    return hex;
  }

 private:
  std::unique_ptr<EVP_MD_CTX, decltype(&EVP_MD_CTX_free)> context_;
};

}  // namespace

Status checkReadableFile(const fs::path& path) {
  std::error_code ec;
  const fs::file_status status = fs::status(path, ec);
  if (ec || !fs::exists(status)) return badInput("{}: no such file", path.string());
  if (fs::is_directory(status)) return badInput("{}: is a directory, expected a file", path.string());
  if (!fs::is_regular_file(status)) return badInput("{}: not a regular file", path.string());
  if (::access(path.c_str(), R_OK) != 0)
    return badInput("{}: cannot be read: {}", path.string(), describeErrno(errno));
  return okStatus();
}

Result<std::string> readFileBytes(const fs::path& path) {
  return readFileRange(path, 0, std::numeric_limits<std::size_t>::max());
}

Result<std::string> readFileRange(const fs::path& path, std::uint64_t offset, std::size_t length) {
  APO_RETURN_IF_ERROR(checkReadableFile(path));
  std::ifstream in(path, std::ios::binary);
  if (!in) return badInput("{}: cannot be opened: {}", path.string(), describeErrno(errno));
  std::error_code ec;
  const auto size = fs::file_size(path, ec);
  if (ec) return badInput("{}: cannot read its size: {}", path.string(), ec.message());
  if (offset >= size) return std::string();
  const auto wanted = static_cast<std::size_t>(std::min<std::uintmax_t>(length, size - offset));
  std::string bytes(wanted, '\0');
  in.seekg(static_cast<std::streamoff>(offset));
  in.read(bytes.data(), static_cast<std::streamsize>(wanted));
  if (static_cast<std::size_t>(in.gcount()) != wanted)
    return badInput("{}: read {} of the {} bytes from byte {}", path.string(), in.gcount(), wanted, offset);
  return bytes;
}

Result<MappedFile> MappedFile::open(const fs::path& path) {
  APO_RETURN_IF_ERROR(checkReadableFile(path));
  const int descriptor = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (descriptor < 0) return badInput("{}: cannot be opened: {}", path.string(), describeErrno(errno));
  std::error_code ec;
  const auto size = static_cast<std::size_t>(fs::file_size(path, ec));
  if (ec) {
    ::close(descriptor);
    return badInput("{}: cannot read its size: {}", path.string(), ec.message());
  }
  // An empty file maps nothing: no bytes to read.
  void* data = size == 0 ? nullptr : mmap(nullptr, size, PROT_READ, MAP_PRIVATE, descriptor, 0);
  const int mapError = errno;
  ::close(descriptor);  // the mapping keeps the file
  if (data == MAP_FAILED) return badInput("{}: cannot be mapped: {}", path.string(), describeErrno(mapError));
  if (data != nullptr) madvise(data, size, MADV_SEQUENTIAL);
  return MappedFile(data, size);
}

MappedFile::MappedFile(MappedFile&& other) noexcept : data_(other.data_), size_(other.size_) {
  other.data_ = nullptr;
  other.size_ = 0;
}

MappedFile::~MappedFile() {
  if (data_ != nullptr) munmap(data_, size_);
}

void MappedFile::release(std::size_t end) const {
  const auto page = static_cast<std::size_t>(sysconf(_SC_PAGESIZE));
  const std::size_t whole = std::min(end, size_) / page * page;
  if (data_ != nullptr && whole > 0) madvise(data_, whole, MADV_DONTNEED);
}

RawFile::RawFile(std::string what, const fs::path& path, int flags)
    : what_(std::move(what)), path_(path), fd_(::open(path.c_str(), flags | O_CLOEXEC, 0644)), openError_(errno) {}

Result<RawFile> RawFile::scratch(std::string what, const fs::path& folder) {
  std::string name = (folder / "apo-scratch-XXXXXX").string();
  const int fd = ::mkostemp(name.data(), O_CLOEXEC);
  if (fd < 0) return internalError("cannot make {} in {}: {}", what, folder.string(), std::strerror(errno));
  ::unlink(name.c_str());
  return RawFile(std::move(what), name, fd, 0);
}

RawFile::RawFile(RawFile&& other) noexcept
    : what_(std::move(other.what_)), path_(std::move(other.path_)), fd_(other.fd_), openError_(other.openError_) {
  other.fd_ = -1;
}

RawFile::~RawFile() {
  if (fd_ >= 0) ::close(fd_);
}

Status RawFile::opened() const {
  if (fd_ < 0) return internalError("{} {}: cannot open: {}", what_, path_.string(), std::strerror(openError_));
  return okStatus();
}

Status RawFile::write(std::uint64_t offset, const void* data, std::size_t bytes) const {
  const char* from = static_cast<const char*>(data);
  while (bytes > 0) {
    const ssize_t written = ::pwrite(fd_, from, bytes, static_cast<off_t>(offset));
    if (written < 0 && errno == EINTR) continue;
    if (written <= 0)
      return internalError("writing {} {} at byte {}: {}", what_, path_.string(), offset,
                           written < 0 ? std::strerror(errno) : "nothing written");
    from += written;
    offset += static_cast<std::uint64_t>(written);
    bytes -= static_cast<std::size_t>(written);
  }
  return okStatus();
}

Status RawFile::read(std::uint64_t offset, void* data, std::size_t bytes) const {
  char* to = static_cast<char*>(data);
  while (bytes > 0) {
    const ssize_t got = ::pread(fd_, to, bytes, static_cast<off_t>(offset));
    if (got < 0 && errno == EINTR) continue;
    if (got <= 0)
      return badInput("{} {}: cannot read {} bytes at byte {}: {}", what_, path_.string(), bytes, offset,
                      got < 0 ? std::strerror(errno) : "the file ends there");
    to += got;
    offset += static_cast<std::uint64_t>(got);
    bytes -= static_cast<std::size_t>(got);
  }
  return okStatus();
}

Status RawFile::sync() const {
  if (::fsync(fd_) != 0) return internalError("writing {} {}: {}", what_, path_.string(), std::strerror(errno));
  return okStatus();
}

Status writeFileAtomically(const fs::path& path,
                           const std::function<Status(std::ostream&)>& writeBody) {
  std::error_code ec;
  if (path.has_parent_path()) {
    fs::create_directories(path.parent_path(), ec);
    if (ec) return internalError("{}: cannot create folder: {}", path.parent_path().string(), ec.message());
  }
  const fs::path temporary = temporaryNameFor(path);
  auto discard = [&] { fs::remove(temporary, ec); };
  {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    if (!out) return internalError("{}: cannot create: {}", temporary.string(), describeErrno(errno));
    Status body = writeBody(out);
    if (!body.ok()) {
      out.close();
      discard();
      return body;
    }
    out.flush();
    if (!out) {
      discard();
      return internalError("{}: write failed: {}", path.string(), describeErrno(errno));
    }
  }
  if (Status synced = syncFile(temporary); !synced.ok()) {
    discard();
    return synced;
  }
  fs::rename(temporary, path, ec);
  if (ec) {
    discard();
    return internalError("{}: cannot rename temporary file into place: {}", path.string(), ec.message());
  }
  return okStatus();
}

Status writeFileAtomically(const fs::path& path, std::string_view bytes) {
  return writeFileAtomically(path, [&](std::ostream& out) {
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    return okStatus();
  });
}

Result<std::string> sha256OfFile(const fs::path& path) {
  APO_RETURN_IF_ERROR(checkReadableFile(path));
  std::ifstream in(path, std::ios::binary);
  if (!in) return badInput("{}: cannot be opened: {}", path.string(), describeErrno(errno));
  Sha256 hash;
  std::vector<char> buffer(1 << 20);
  while (in) {
    in.read(buffer.data(), static_cast<std::streamsize>(buffer.size()));
    hash.update(buffer.data(), static_cast<std::size_t>(in.gcount()));
  }
  if (in.bad()) return badInput("{}: read error while hashing", path.string());
  return hash.hexDigest();
}

std::string sha256OfBytes(std::string_view bytes) {
  Sha256 hash;
  hash.update(bytes.data(), bytes.size());
  return hash.hexDigest();
}

}  // namespace apo
