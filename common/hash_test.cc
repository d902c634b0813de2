// Tests for SHA-256 against the FIPS 180-4 example vectors.
#include "common/hash.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <string>

namespace pf {
namespace {

TEST(Sha256, MatchesStandardVectors) {
  EXPECT_EQ(Sha256Hex(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ(Sha256Hex("abc"), "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(Sha256Hex("abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq"),
            "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
}

TEST(Sha256, IncrementalUpdatesEqualOneShot) {
  std::string data(1000003, '\0');
  for (size_t i = 0; i < data.size(); ++i) data[i] = static_cast<char>(i * 7 + 3);
  Sha256 hasher;
  size_t pos = 0;
  for (size_t step = 1; pos < data.size(); step = step * 3 % 997 + 1) {
    const size_t take = std::min(step, data.size() - pos);
    hasher.Update(data.data() + pos, take);
    pos += take;
  }
  EXPECT_EQ(hasher.FinishHex(), Sha256Hex(data));
  // One million 'a': the FIPS long-message vector.
  EXPECT_EQ(Sha256Hex(std::string(1000000, 'a')),
            "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
}

// Found by scene_file_fuzzer (a scene file with no Gaussians hashes its empty
// arrays): memcpy from a null pointer, undefined even for 0 bytes. UBSan
// builds (make test-sanitizers) abort here without the fix.
TEST(Sha256, EmptyUpdateFromNullPointerChangesNothing) {
  Sha256 hasher;
  hasher.Update("ab", 2);
  hasher.Update(nullptr, 0);
  hasher.Update("c", 1);
  EXPECT_EQ(hasher.FinishHex(), Sha256Hex("abc"));
}

TEST(Sha256, FileHashEqualsBytesHashAndMissingFileIsNotFound) {
  const std::string path = ::testing::TempDir() + "/hash_test.bin";
  std::FILE* f = std::fopen(path.c_str(), "wb");
  ASSERT_NE(f, nullptr);
  std::fputs("abc", f);
  std::fclose(f);
  auto hex = Sha256File(path);
  ASSERT_TRUE(hex.ok()) << hex.status();
  EXPECT_EQ(*hex, Sha256Hex("abc"));
  EXPECT_EQ(Sha256File(path + ".missing").status().code(), absl::StatusCode::kNotFound);
}

}  // namespace
}  // namespace pf
