// The blob store: a directory of files named by the SHA-256 of their
// content (DIR/ab/abcdef...), written atomically and checked when read.
//
//   BlobStore blobs("/var/pf/blobs");
//   ASSIGN_OR_RETURN(BlobWriter writer, blobs.StartWrite(expected));
//   writer.Append(chunk); ...; ASSIGN_OR_RETURN(Digest d, writer.Finish());
#ifndef POINTFORWARD_SERVER_BLOBS_BLOB_STORE_H_
#define POINTFORWARD_SERVER_BLOBS_BLOB_STORE_H_

#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>
#include <string_view>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "common/hash.h"

namespace pf {

struct BlobDigest {
  std::string sha256;  // 64 lowercase hex digits.
  int64_t size_bytes = 0;
};

// True when `sha256` is 64 lowercase hex digits.
bool IsValidSha256Hex(std::string_view sha256);

class BlobStore;

// An upload in progress: bytes go to a temporary file and are hashed as they
// arrive; Finish() checks size and hash against what was announced and only
// then moves the file into place. Destroying an unfinished writer deletes its
// temporary file.
class BlobWriter {
 public:
  BlobWriter(BlobWriter&&) noexcept;
  BlobWriter& operator=(BlobWriter&&) noexcept;
  ~BlobWriter();

  // INVALID_ARGUMENT when more bytes arrive than announced.
  absl::Status Append(std::string_view data);
  // INVALID_ARGUMENT "digest: ..." when the size or hash differs from the
  // announced digest; nothing is kept then.
  absl::StatusOr<BlobDigest> Finish();

 private:
  friend class BlobStore;
  BlobWriter() = default;
  struct State;
  std::unique_ptr<State> state_;
};

class BlobStore {
 public:
  // `root` is created if absent. Files left in ROOT/tmp by a process that
  // died mid-upload are removed, so only one process should serve a root.
  explicit BlobStore(std::string root);

  const std::string& root() const { return root_; }

  // INVALID_ARGUMENT for a malformed digest (named "digest.sha256" /
  // "digest.size_bytes"), or when size exceeds `max_blob_bytes` (> 0).
  absl::StatusOr<BlobWriter> StartWrite(const BlobDigest& expected, int64_t max_blob_bytes = 0);

  // Stores `data` (its digest computed here) and returns its digest.
  absl::StatusOr<BlobDigest> Put(std::string_view data);
  // Copies the file at `path` in, hashing it on the way.
  absl::StatusOr<BlobDigest> PutFile(const std::string& path);

  bool Contains(const std::string& sha256) const;
  // The file holding the blob; NOT_FOUND when absent. Does not check the hash.
  absl::StatusOr<std::string> PathOf(const std::string& sha256) const;
  // Reads a whole blob and checks its hash: DATA_LOSS when the content does
  // not match its name (the file is then removed).
  absl::StatusOr<std::string> Get(const std::string& sha256) const;
  // Size in bytes; NOT_FOUND when absent.
  absl::StatusOr<int64_t> SizeOf(const std::string& sha256) const;
  // Checks the stored file against its name: DATA_LOSS (and removes the
  // file) on mismatch.
  absl::Status Verify(const std::string& sha256) const;
  // Deletes the blob; NOT_FOUND when absent.
  absl::Status Remove(const std::string& sha256) const;
  // Bytes of every blob stored (unfinished uploads and scratch space not
  // counted). Walks the directory: O(number of blobs).
  absl::StatusOr<int64_t> TotalBytes() const;

 private:
  std::string root_;
};

}  // namespace pf

#endif  // POINTFORWARD_SERVER_BLOBS_BLOB_STORE_H_
