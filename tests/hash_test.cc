#include "core/hash.h"

#include <cstring>
#include <fstream>
#include <random>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "core/error.h"
#include "test_util.h"

namespace g6d {
namespace {

using ::testing::HasSubstr;

uint64_t HashText(const std::string& text) { return Fnv1a64(text.data(), text.size()); }

void WriteFile(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

TEST(Fnv1a64, KnownVectors) {
  // Reference values of the FNV-1a 64-bit test suite (Fowler, Noll, Vo).
  EXPECT_EQ(HashText(""), 0xcbf29ce484222325ULL);
  EXPECT_EQ(HashText("a"), 0xaf63dc4c8601ec8cULL);
  EXPECT_EQ(HashText("foobar"), 0x85944171f73967e8ULL);
  EXPECT_EQ(kFnvOffsetBasis, 0xcbf29ce484222325ULL);
}

TEST(Fnv1a64, ContinuesAcrossChunks) {
  const std::string text = "g6d template cache";
  for (size_t split = 0; split <= text.size(); ++split) {
    const uint64_t first = Fnv1a64(text.data(), split);
    EXPECT_EQ(Fnv1a64(text.data() + split, text.size() - split, first), HashText(text));
  }
}

TEST(Fnv1a64, SeesEveryByte) {
  std::string text(64, 'x');
  const uint64_t original = HashText(text);
  for (size_t i = 0; i < text.size(); ++i) {
    std::string changed = text;
    changed[i] = 'y';
    EXPECT_NE(HashText(changed), original) << "byte " << i;
  }
}

TEST(HexString, SixteenLowercaseDigits) {
  EXPECT_EQ(HexString(0), "0000000000000000");
  EXPECT_EQ(HexString(0xcbf29ce484222325ULL), "cbf29ce484222325");
  EXPECT_EQ(HexString(0xffffffffffffffffULL), "ffffffffffffffff");
  EXPECT_EQ(HexString(0x1aULL), "000000000000001a");
}

TEST(HashFile, EqualsHashOfBytes) {
  const std::string dir = test::TempDir("hash_file");
  // Larger than the read buffer (64 KiB), with every byte value, including zeros.
  std::string bytes(200000, '\0');
  std::mt19937_64 engine(1);
  for (char& byte : bytes) byte = static_cast<char>(engine() & 0xff);
  const std::string path = dir + "/random.bin";
  WriteFile(path, bytes);
  EXPECT_EQ(HashFile(path), Fnv1a64(bytes.data(), bytes.size()));

  const std::string small_path = dir + "/a.txt";
  WriteFile(small_path, "a");
  EXPECT_EQ(HashFile(small_path), 0xaf63dc4c8601ec8cULL);
}

TEST(HashFile, EmptyFileIsOffsetBasis) {
  const std::string path = test::TempDir("hash_empty") + "/empty.bin";
  WriteFile(path, "");
  EXPECT_EQ(HashFile(path), kFnvOffsetBasis);
}

TEST(HashFile, MissingFileThrowsNamingIt) {
  const std::string path = test::TempDir("hash_missing") + "/does_not_exist.ply";
  try {
    HashFile(path);
    FAIL() << "no error for a missing file";
  } catch (const Error& error) {
    EXPECT_THAT(error.what(), HasSubstr(path));
  }
}

TEST(HashFile, DirectoryThrowsNamingIt) {
  const std::string dir = test::TempDir("hash_directory");
  try {
    HashFile(dir);
    FAIL() << "no error for a directory";
  } catch (const Error& error) {
    EXPECT_THAT(error.what(), HasSubstr(dir));
  }
}

}  // namespace
}  // namespace g6d
