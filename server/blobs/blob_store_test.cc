// BlobStore on a real directory: naming, atomic checked writes, corruption
// detection, concurrent writers and leftovers of a crashed process.
#include "server/blobs/blob_store.h"

#include <sys/stat.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "common/file_util.h"
#include "common/hash.h"
#include "gtest/gtest.h"
#include "tests/test_util.h"

namespace pf {
namespace {

namespace fs = std::filesystem;

// Number of entries in `dir` (0 when it does not exist).
int CountEntries(const std::string& dir) {
  std::error_code ec;
  int count = 0;
  for (auto it = fs::directory_iterator(dir, ec); !ec && it != fs::directory_iterator(); ++it) {
    ++count;
  }
  return count;
}

ino_t InodeOf(const std::string& path) {
  struct stat info {};
  EXPECT_EQ(::stat(path.c_str(), &info), 0) << path;
  return info.st_ino;
}

// `size` bytes of a fixed, non-repeating-looking pattern.
std::string Pattern(size_t size) {
  std::string bytes(size, '\0');
  for (size_t i = 0; i < size; ++i) bytes[i] = static_cast<char>(i * 7 + i / 251);
  return bytes;
}

TEST(BlobStore, ValidatesSha256Hex) {
  EXPECT_TRUE(IsValidSha256Hex(std::string(64, 'a')));
  EXPECT_TRUE(IsValidSha256Hex(Sha256Hex("x")));
  EXPECT_FALSE(IsValidSha256Hex(std::string(63, 'a')));
  EXPECT_FALSE(IsValidSha256Hex(std::string(64, 'A')));
  EXPECT_FALSE(IsValidSha256Hex(std::string(63, 'a') + "g"));
  EXPECT_FALSE(IsValidSha256Hex(""));
}

TEST(BlobStore, PutGetRoundTripStoresUnderShardedHashName) {
  const std::string root = testing::MakeTempDir("blob_store");
  BlobStore store(root);
  const std::string content = "hello blobs";
  absl::StatusOr<BlobDigest> digest = store.Put(content);
  ASSERT_TRUE(digest.ok()) << digest.status();
  // SHA-256("hello blobs"), computed independently.
  EXPECT_EQ(digest->sha256, Sha256Hex(content));
  EXPECT_EQ(digest->size_bytes, 11);

  const std::string expected_path = root + "/" + digest->sha256.substr(0, 2) + "/" + digest->sha256;
  EXPECT_TRUE(fs::is_regular_file(expected_path));
  absl::StatusOr<std::string> path = store.PathOf(digest->sha256);
  ASSERT_TRUE(path.ok()) << path.status();
  EXPECT_EQ(fs::path(*path), fs::path(expected_path));
  EXPECT_TRUE(store.Contains(digest->sha256));
  EXPECT_EQ(store.SizeOf(digest->sha256).value(), 11);

  absl::StatusOr<std::string> back = store.Get(digest->sha256);
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(*back, content);
  EXPECT_TRUE(store.Verify(digest->sha256).ok());
  EXPECT_EQ(CountEntries(root + "/tmp"), 0);
}

TEST(BlobStore, EmptyBlobIsStored) {
  BlobStore store(testing::MakeTempDir("blob_store"));
  absl::StatusOr<BlobDigest> digest = store.Put("");
  ASSERT_TRUE(digest.ok()) << digest.status();
  EXPECT_EQ(digest->sha256, "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ(store.Get(digest->sha256).value(), "");
}

TEST(BlobStore, ChunkedWriteMatchesWholeContent) {
  BlobStore store(testing::MakeTempDir("blob_store"));
  const std::string content = Pattern(300000);
  absl::StatusOr<BlobWriter> writer =
      store.StartWrite({Sha256Hex(content), static_cast<int64_t>(content.size())});
  ASSERT_TRUE(writer.ok()) << writer.status();
  for (size_t at = 0; at < content.size(); at += 65536) {
    ASSERT_TRUE(writer->Append(std::string_view(content).substr(at, 65536)).ok());
  }
  absl::StatusOr<BlobDigest> digest = writer->Finish();
  ASSERT_TRUE(digest.ok()) << digest.status();
  EXPECT_EQ(store.Get(digest->sha256).value(), content);
}

TEST(BlobStore, AnnouncedHashMismatchKeepsNothing) {
  const std::string root = testing::MakeTempDir("blob_store");
  BlobStore store(root);
  const std::string announced = Sha256Hex("what the client promised");
  absl::StatusOr<BlobWriter> writer = store.StartWrite({announced, 12});
  ASSERT_TRUE(writer.ok()) << writer.status();
  ASSERT_TRUE(writer->Append("what arrived").ok());
  absl::StatusOr<BlobDigest> digest = writer->Finish();
  ASSERT_FALSE(digest.ok());
  EXPECT_EQ(digest.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(digest.status().message(),
            "digest.sha256: content hashes to " + Sha256Hex("what arrived") + ", not " + announced);
  EXPECT_FALSE(store.Contains(announced));
  EXPECT_FALSE(store.Contains(Sha256Hex("what arrived")));
  EXPECT_EQ(CountEntries(root + "/tmp"), 0);
}

TEST(BlobStore, SizeMismatchIsRefusedBothWays) {
  const std::string root = testing::MakeTempDir("blob_store");
  BlobStore store(root);
  const std::string content = "fifteen bytes!!";
  ASSERT_EQ(content.size(), 15u);

  // More bytes than announced: refused as soon as they arrive.
  absl::StatusOr<BlobWriter> too_many = store.StartWrite({Sha256Hex(content), 12});
  ASSERT_TRUE(too_many.ok());
  absl::Status appended = too_many->Append(content);
  EXPECT_EQ(appended.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(appended.message(), "digest.size_bytes: 12 bytes announced, 15 received");
  EXPECT_EQ(too_many->Finish().status().code(), absl::StatusCode::kFailedPrecondition);

  // Fewer: refused at Finish().
  absl::StatusOr<BlobWriter> too_few = store.StartWrite({Sha256Hex(content), 20});
  ASSERT_TRUE(too_few.ok());
  ASSERT_TRUE(too_few->Append(content).ok());
  absl::StatusOr<BlobDigest> digest = too_few->Finish();
  EXPECT_EQ(digest.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(digest.status().message(), "digest.size_bytes: 20 bytes announced, 15 received");

  EXPECT_FALSE(store.Contains(Sha256Hex(content)));
  EXPECT_EQ(CountEntries(root + "/tmp"), 0);
}

TEST(BlobStore, MalformedDigestsAndUploadLimitNameTheField) {
  BlobStore store(testing::MakeTempDir("blob_store"));
  absl::StatusOr<BlobWriter> bad_hash = store.StartWrite({"ABC", 3});
  EXPECT_EQ(bad_hash.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(bad_hash.status().message(), "digest.sha256: not 64 lowercase hex digits");

  absl::StatusOr<BlobWriter> negative = store.StartWrite({std::string(64, 'a'), -1});
  EXPECT_EQ(negative.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(negative.status().message(), "digest.size_bytes: -1 is negative");

  absl::StatusOr<BlobWriter> too_big = store.StartWrite({std::string(64, 'a'), 5000000}, 1048576);
  EXPECT_EQ(too_big.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(too_big.status().message(),
            "digest.size_bytes: 5000000 bytes exceeds the upload limit of 1048576 bytes "
            "(--max-upload-bytes)");
  EXPECT_TRUE(store.StartWrite({std::string(64, 'a'), 1048576}, 1048576).ok());

  EXPECT_EQ(store.PathOf("nothex").status().code(), absl::StatusCode::kInvalidArgument);
  const std::string absent = Sha256Hex("never stored");
  EXPECT_EQ(store.Get(absent).status().code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(store.Get(absent).status().message(), "blob " + absent + " not found");
  EXPECT_EQ(store.SizeOf(absent).status().code(), absl::StatusCode::kNotFound);
  EXPECT_FALSE(store.Contains(absent));
}

TEST(BlobStore, CorruptedFileGivesDataLossAndIsRemoved) {
  BlobStore store(testing::MakeTempDir("blob_store"));
  const std::string content = Pattern(5000);
  const BlobDigest digest = store.Put(content).value();
  const std::string path = store.PathOf(digest.sha256).value();

  // Flip one byte in place, keeping the size.
  {
    std::fstream file(path, std::ios::in | std::ios::out | std::ios::binary);
    file.seekp(1234);
    file.put(static_cast<char>(content[1234] ^ 0x40));
  }
  absl::StatusOr<std::string> got = store.Get(digest.sha256);
  EXPECT_EQ(got.status().code(), absl::StatusCode::kDataLoss);
  EXPECT_NE(std::string(got.status().message()).find(digest.sha256), std::string::npos);
  EXPECT_FALSE(fs::exists(path));
  EXPECT_FALSE(store.Contains(digest.sha256));

  // Verify() does the same, and a fresh upload restores the blob.
  ASSERT_TRUE(store.Put(content).ok());
  ASSERT_TRUE(WriteFileAtomic(path, "truncated").ok());
  EXPECT_EQ(store.Verify(digest.sha256).code(), absl::StatusCode::kDataLoss);
  EXPECT_FALSE(fs::exists(path));
  ASSERT_TRUE(store.Put(content).ok());
  EXPECT_TRUE(store.Verify(digest.sha256).ok());
}

TEST(BlobStore, ExistingBlobIsNotRewritten) {
  BlobStore store(testing::MakeTempDir("blob_store"));
  const BlobDigest digest = store.Put("stable").value();
  const std::string path = store.PathOf(digest.sha256).value();
  const fs::file_time_type before = fs::last_write_time(path);
  const ino_t inode_before = InodeOf(path);
  fs::last_write_time(path, before - std::chrono::hours(1));
  ASSERT_TRUE(store.Put("stable").ok());
  EXPECT_EQ(fs::last_write_time(path), before - std::chrono::hours(1));
  // Renaming a new copy into place would have changed both.
  EXPECT_EQ(InodeOf(path), inode_before);
}

TEST(BlobStore, ConcurrentWritersOfTheSameBlobAllSucceed) {
  const std::string root = testing::MakeTempDir("blob_store");
  BlobStore store(root);
  const std::string content = Pattern(2 << 20);
  const BlobDigest expected{Sha256Hex(content), static_cast<int64_t>(content.size())};
  constexpr int kWriters = 8;
  std::vector<absl::Status> results(kWriters);
  std::vector<std::thread> threads;
  for (int w = 0; w < kWriters; ++w) {
    threads.emplace_back([&, w]() {
      absl::StatusOr<BlobWriter> writer = store.StartWrite(expected);
      if (!writer.ok()) {
        results[w] = writer.status();
        return;
      }
      for (size_t at = 0; at < content.size(); at += 100000) {
        absl::Status appended = writer->Append(std::string_view(content).substr(at, 100000));
        if (!appended.ok()) {
          results[w] = appended;
          return;
        }
      }
      results[w] = writer->Finish().status();
    });
  }
  for (std::thread& thread : threads) thread.join();
  for (int w = 0; w < kWriters; ++w) EXPECT_TRUE(results[w].ok()) << w << ": " << results[w];
  EXPECT_EQ(store.Get(expected.sha256).value(), content);
  EXPECT_EQ(CountEntries(root + "/tmp"), 0);
  EXPECT_EQ(CountEntries(root + "/" + expected.sha256.substr(0, 2)), 1);
}

TEST(BlobStore, AbandonedWriterLeavesNothing) {
  const std::string root = testing::MakeTempDir("blob_store");
  BlobStore store(root);
  {
    absl::StatusOr<BlobWriter> writer = store.StartWrite({Sha256Hex("abc"), 3});
    ASSERT_TRUE(writer.ok());
    ASSERT_TRUE(writer->Append("ab").ok());
    EXPECT_EQ(CountEntries(root + "/tmp"), 1);
  }
  EXPECT_EQ(CountEntries(root + "/tmp"), 0);
  EXPECT_FALSE(store.Contains(Sha256Hex("abc")));
}

TEST(BlobStore, StaleLeftoversOfACrashedProcessAreRemovedAtStart) {
  const std::string root = testing::MakeTempDir("blob_store");
  const BlobDigest kept = BlobStore(root).Put("kept").value();
  ASSERT_TRUE(WriteFileAtomic(root + "/tmp/12345-0-deadbeef", "half an upload").ok());
  ASSERT_TRUE(MakeDirs(root + "/tmp/odd-directory").ok());
  // An upload another server sharing the directory is writing right now.
  ASSERT_TRUE(WriteFileAtomic(root + "/tmp/777-0-cafe", "in progress").ok());
  const auto two_hours_ago = std::filesystem::file_time_type::clock::now() - std::chrono::hours(2);
  std::filesystem::last_write_time(root + "/tmp/12345-0-deadbeef", two_hours_ago);
  std::filesystem::last_write_time(root + "/tmp/odd-directory", two_hours_ago);
  ASSERT_EQ(CountEntries(root + "/tmp"), 3);

  BlobStore reopened(root);
  EXPECT_EQ(CountEntries(root + "/tmp"), 1);
  EXPECT_TRUE(std::filesystem::exists(root + "/tmp/777-0-cafe"));
  EXPECT_EQ(reopened.Get(kept.sha256).value(), "kept");
}

TEST(BlobStore, PutFileCopiesAndHashes) {
  const std::string dir = testing::MakeTempDir("blob_store");
  BlobStore store(dir + "/blobs");
  const std::string content = Pattern(1500000);
  ASSERT_TRUE(WriteFileAtomic(dir + "/input.bin", content).ok());
  absl::StatusOr<BlobDigest> digest = store.PutFile(dir + "/input.bin");
  ASSERT_TRUE(digest.ok()) << digest.status();
  EXPECT_EQ(digest->sha256, Sha256Hex(content));
  EXPECT_EQ(digest->size_bytes, 1500000);
  EXPECT_EQ(store.Get(digest->sha256).value(), content);

  absl::StatusOr<BlobDigest> missing = store.PutFile(dir + "/absent.bin");
  EXPECT_EQ(missing.status().code(), absl::StatusCode::kNotFound);
  EXPECT_NE(std::string(missing.status().message()).find("absent.bin"), std::string::npos);
}

TEST(BlobStore, TotalBytesCountsBlobsOnlyAndRemoveDeletesOne) {
  const std::string root = testing::MakeTempDir("blob_store");
  BlobStore store(root);
  EXPECT_EQ(store.TotalBytes().value(), 0);
  const BlobDigest a = store.Put(std::string(1000, 'a')).value();
  const BlobDigest b = store.Put(std::string(234, 'b')).value();
  // Neither an unfinished upload nor scratch files count.
  ASSERT_TRUE(WriteFileAtomic(root + "/tmp/upload-in-progress", std::string(50, 'x')).ok());
  ASSERT_TRUE(MakeDirs(root + "/scratch/clip-1").ok());
  ASSERT_TRUE(WriteFileAtomic(root + "/scratch/clip-1/clip.json", "{}").ok());
  EXPECT_EQ(store.TotalBytes().value(), 1234);

  ASSERT_TRUE(store.Remove(a.sha256).ok());
  EXPECT_FALSE(store.Contains(a.sha256));
  EXPECT_EQ(store.TotalBytes().value(), 234);
  EXPECT_EQ(store.Remove(a.sha256).code(), absl::StatusCode::kNotFound);
  EXPECT_EQ(store.Get(b.sha256).value(), std::string(234, 'b'));
}

}  // namespace
}  // namespace pf
