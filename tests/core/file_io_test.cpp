#include "core/file_io.h"

#include "tests/test_support.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/stat.h>

namespace apo {
namespace {
namespace fs = std::filesystem;
using ::testing::HasSubstr;

TEST(ReadFileBytes, ReadsExactBytesIncludingNul) {
  const fs::path path = test::freshTempDir() / "a.bin";
  const std::string bytes("ab\0cd\xff", 6);
  test::writeBytes(path, bytes);
  auto read = readFileBytes(path);
  ASSERT_TRUE(read.ok()) << read.error().message;
  EXPECT_EQ(*read, bytes);
}

TEST(ReadFileBytes, MissingFileIsBadInputNamingThePath) {
  const fs::path path = test::freshTempDir() / "nope.ply";
  auto read = readFileBytes(path);
  ASSERT_FALSE(read.ok());
  EXPECT_EQ(read.error().kind, ErrorKind::BadInput);
  EXPECT_THAT(read.error().message, HasSubstr(path.string()));
  EXPECT_THAT(read.error().message, HasSubstr("no such file"));
}

TEST(ReadFileBytes, DirectoryIsBadInput) {
  const fs::path dir = test::freshTempDir();
  auto read = readFileBytes(dir);
  ASSERT_FALSE(read.ok());
  EXPECT_EQ(read.error().kind, ErrorKind::BadInput);
  EXPECT_THAT(read.error().message, HasSubstr("is a directory"));
}

TEST(ReadFileBytes, FifoIsNotARegularFile) {
  const fs::path fifo = test::freshTempDir() / "pipe.ply";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  auto read = readFileBytes(fifo);  // must not block waiting for a writer
  ASSERT_FALSE(read.ok());
  EXPECT_THAT(read.error().message, HasSubstr("not a regular file"));
}

TEST(WriteFileAtomically, WritesAndLeavesNoTemporaryFile) {
  const fs::path dir = test::freshTempDir();
  ASSERT_TRUE(writeFileAtomically(dir / "sub" / "out.txt", "hello").ok());
  EXPECT_EQ(*readFileBytes(dir / "sub" / "out.txt"), "hello");
  EXPECT_EQ(std::distance(fs::directory_iterator(dir / "sub"), fs::directory_iterator()), 1);
}

TEST(WriteFileAtomically, FailedBodyKeepsThePreviousFile) {
  const fs::path dir = test::freshTempDir();
  const fs::path path = dir / "out.txt";
  ASSERT_TRUE(writeFileAtomically(path, "old").ok());
  Status status = writeFileAtomically(path, [](std::ostream& out) -> Status {
    out << "partial new content";
    return internalError("simulated failure half-way");
  });
  EXPECT_FALSE(status.ok());
  EXPECT_EQ(*readFileBytes(path), "old");
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 1);
}

TEST(Sha256, MatchesTheStandardTestVectors) {
  // FIPS 180-2 examples.
  EXPECT_EQ(sha256OfBytes("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(sha256OfBytes(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
}

TEST(Sha256, OfFileEqualsOfBytesAcrossBufferBoundaries) {
  const fs::path path = test::freshTempDir() / "big.bin";
  std::string bytes(3 * (1 << 20) + 17, '\0');
  for (std::size_t i = 0; i < bytes.size(); ++i) bytes[i] = static_cast<char>(i * 31 + 7);
  test::writeBytes(path, bytes);
  EXPECT_EQ(*sha256OfFile(path), sha256OfBytes(bytes));
}

}  // namespace
}  // namespace apo
