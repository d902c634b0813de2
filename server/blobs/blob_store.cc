// The blob store: content-addressed files under ROOT/ab/<sha256>, written
// through ROOT/tmp and checked against their name when read.
#include "server/blobs/blob_store.h"

#include <fcntl.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"
#include "common/file_util.h"
#include "common/status_macros.h"
#include "spdlog/spdlog.h"

namespace pf {
namespace {

namespace fs = std::filesystem;

constexpr size_t kReadBufferBytes = 1 << 20;

// Age after which an unfinished upload in tmp/ is taken for a dead one.
constexpr std::chrono::hours kStaleUploadAge(1);

std::string TmpDir(const std::string& root) { return (fs::path(root) / "tmp").string(); }

std::string BlobPath(const std::string& root, const std::string& sha256) {
  return (fs::path(root) / sha256.substr(0, 2) / sha256).string();
}

// Returns INVALID_ARGUMENT "`field`: not 64 lowercase hex digits" unless
// `sha256` is well formed.
absl::Status CheckSha256(const char* field, const std::string& sha256) {
  if (IsValidSha256Hex(sha256)) return absl::OkStatus();
  return absl::InvalidArgumentError(absl::StrCat(field, ": not 64 lowercase hex digits"));
}

absl::Status ErrnoError(const std::string& what, int err) {
  return absl::InternalError(absl::StrCat(what, ": ", std::strerror(err)));
}

// Writes all of `data` to `fd`, retrying short writes.
absl::Status WriteAll(int fd, std::string_view data, const std::string& path) {
  while (!data.empty()) {
    const ssize_t n = ::write(fd, data.data(), data.size());
    if (n < 0) {
      if (errno == EINTR) continue;
      return ErrnoError(absl::StrCat(path, ": write failed"), errno);
    }
    data.remove_prefix(static_cast<size_t>(n));
  }
  return absl::OkStatus();
}

// Flushes a directory entry change (a rename into `dir`) to disk.
void SyncDirectory(const std::string& dir) {
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY);
  if (fd < 0) return;
  ::fsync(fd);
  ::close(fd);
}

}  // namespace

bool IsValidSha256Hex(std::string_view sha256) {
  if (sha256.size() != 64) return false;
  for (const char c : sha256) {
    if (!((c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'))) return false;
  }
  return true;
}

// ---------------------------------------------------------------------------
// BlobWriter

struct BlobWriter::State {
  std::string root;
  std::string temp_path;
  int fd = -1;
  Sha256 hasher;
  // What the content must be; an empty sha256 accepts whatever hash arrives
  // (PutFile, which hashes on the way).
  BlobDigest expected;
  int64_t received = 0;
  bool done = false;  // Finished or failed: the temporary file is gone.

  // Closes and deletes the temporary file.
  void Discard() {
    if (fd >= 0) ::close(fd);
    fd = -1;
    if (!temp_path.empty()) {
      std::error_code ec;
      fs::remove(temp_path, ec);
    }
    done = true;
  }

  ~State() {
    if (!done) Discard();
  }
};

BlobWriter::BlobWriter(BlobWriter&&) noexcept = default;
BlobWriter& BlobWriter::operator=(BlobWriter&&) noexcept = default;
BlobWriter::~BlobWriter() = default;

absl::Status BlobWriter::Append(std::string_view data) {
  if (state_ == nullptr || state_->done) {
    return absl::FailedPreconditionError("blob writer already finished or failed");
  }
  State& s = *state_;
  const int64_t total = s.received + static_cast<int64_t>(data.size());
  if (total > s.expected.size_bytes) {
    s.Discard();
    return absl::InvalidArgumentError(absl::StrCat("digest.size_bytes: ", s.expected.size_bytes,
                                                   " bytes announced, ", total, " received"));
  }
  absl::Status written = WriteAll(s.fd, data, s.temp_path);
  if (!written.ok()) {
    s.Discard();
    return written;
  }
  s.hasher.Update(data);
  s.received = total;
  return absl::OkStatus();
}

absl::StatusOr<BlobDigest> BlobWriter::Finish() {
  if (state_ == nullptr || state_->done) {
    return absl::FailedPreconditionError("blob writer already finished or failed");
  }
  State& s = *state_;
  if (s.received != s.expected.size_bytes) {
    s.Discard();
    return absl::InvalidArgumentError(absl::StrCat("digest.size_bytes: ", s.expected.size_bytes,
                                                   " bytes announced, ", s.received, " received"));
  }
  const std::string actual = s.hasher.FinishHex();
  if (!s.expected.sha256.empty() && actual != s.expected.sha256) {
    s.Discard();
    return absl::InvalidArgumentError(
        absl::StrCat("digest.sha256: content hashes to ", actual, ", not ", s.expected.sha256));
  }
  if (::fsync(s.fd) != 0) {
    const int err = errno;
    s.Discard();
    return ErrnoError(absl::StrCat(s.temp_path, ": fsync failed"), err);
  }
  ::close(s.fd);
  s.fd = -1;

  const BlobDigest digest{actual, s.received};
  const std::string final_path = BlobPath(s.root, actual);
  const std::string shard_dir = fs::path(final_path).parent_path().string();
  std::error_code ec;
  if (fs::exists(final_path, ec)) {
    // Same name, same content: the stored copy stays as it is.
    s.Discard();
    return digest;
  }
  absl::Status made = MakeDirs(shard_dir);
  if (!made.ok()) {
    s.Discard();
    return made;
  }
  fs::rename(s.temp_path, final_path, ec);
  if (ec) {
    s.Discard();
    return absl::InternalError(absl::StrCat(final_path, ": rename failed: ", ec.message()));
  }
  s.done = true;
  SyncDirectory(shard_dir);
  return digest;
}

// ---------------------------------------------------------------------------
// BlobStore

BlobStore::BlobStore(std::string root) : root_(std::move(root)) {
  const std::string tmp = TmpDir(root_);
  absl::Status made = MakeDirs(tmp);
  if (!made.ok()) {
    // Every later write fails with a message naming the directory.
    spdlog::error("blob store: {}", std::string(made.message()));
    return;
  }
  // What has sat in tmp/ untouched for an hour belongs to a process that died
  // mid-upload. Younger files may be uploads in progress in another server
  // sharing this directory (replicas on one volume): they are left alone.
  std::error_code ec;
  int removed = 0;
  const auto stale_before = fs::file_time_type::clock::now() - kStaleUploadAge;
  for (fs::directory_iterator it(tmp, ec); !ec && it != fs::directory_iterator();
       it.increment(ec)) {
    std::error_code time_ec;
    const fs::file_time_type written = fs::last_write_time(it->path(), time_ec);
    if (time_ec || written > stale_before) continue;
    std::error_code remove_ec;
    if (fs::remove_all(it->path(), remove_ec) > 0) ++removed;
  }
  if (removed > 0) {
    spdlog::info("blob store {}: removed {} unfinished upload(s) from {}", root_, removed, tmp);
  }
}

absl::StatusOr<BlobWriter> BlobStore::StartWrite(const BlobDigest& expected,
                                                 int64_t max_blob_bytes) {
  RETURN_IF_ERROR(CheckSha256("digest.sha256", expected.sha256));
  if (expected.size_bytes < 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("digest.size_bytes: ", expected.size_bytes, " is negative"));
  }
  if (max_blob_bytes > 0 && expected.size_bytes > max_blob_bytes) {
    return absl::InvalidArgumentError(absl::StrCat("digest.size_bytes: ", expected.size_bytes,
                                                   " bytes exceeds the upload limit of ",
                                                   max_blob_bytes, " bytes (--max-upload-bytes)"));
  }
  static std::atomic<uint64_t> counter{0};
  const std::string tmp = TmpDir(root_);
  RETURN_IF_ERROR(MakeDirs(tmp));
  const std::string temp_path = (fs::path(tmp) / absl::StrCat(ProcessToken(), "-", counter++, "-",
                                                              expected.sha256.substr(0, 16)))
                                    .string();
  const int fd = ::open(temp_path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
  if (fd < 0) return ErrnoError(absl::StrCat(temp_path, ": cannot create"), errno);

  BlobWriter writer;
  writer.state_ = std::make_unique<BlobWriter::State>();
  writer.state_->root = root_;
  writer.state_->temp_path = temp_path;
  writer.state_->fd = fd;
  writer.state_->expected = expected;
  return writer;
}

absl::StatusOr<BlobDigest> BlobStore::Put(std::string_view data) {
  const BlobDigest digest{Sha256Hex(data), static_cast<int64_t>(data.size())};
  ASSIGN_OR_RETURN(BlobWriter writer, StartWrite(digest));
  RETURN_IF_ERROR(writer.Append(data));
  return writer.Finish();
}

absl::StatusOr<BlobDigest> BlobStore::PutFile(const std::string& path) {
  std::error_code ec;
  const uintmax_t size = fs::file_size(path, ec);
  if (ec) {
    if (ec == std::errc::no_such_file_or_directory) {
      return absl::NotFoundError(absl::StrCat(path, ": no such file"));
    }
    return absl::InternalError(absl::StrCat(path, ": ", ec.message()));
  }
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return ErrnoError(absl::StrCat(path, ": cannot open"), errno);

  // The hash is not known yet: a placeholder name passes validation, and an
  // empty expected hash makes Finish() accept what it computes.
  absl::StatusOr<BlobWriter> writer =
      StartWrite(BlobDigest{std::string(64, '0'), static_cast<int64_t>(size)});
  if (!writer.ok()) {
    ::close(fd);
    return writer.status();
  }
  writer->state_->expected.sha256.clear();
  std::vector<char> buffer(kReadBufferBytes);
  while (true) {
    const ssize_t n = ::read(fd, buffer.data(), buffer.size());
    if (n < 0) {
      if (errno == EINTR) continue;
      const int err = errno;
      ::close(fd);
      return ErrnoError(absl::StrCat(path, ": read failed"), err);
    }
    if (n == 0) break;
    absl::Status appended = writer->Append(std::string_view(buffer.data(), n));
    if (!appended.ok()) {
      ::close(fd);
      return StatusWithContext(appended, absl::StrCat(path, " (changed while copied)"));
    }
  }
  ::close(fd);
  absl::StatusOr<BlobDigest> digest = writer->Finish();
  if (!digest.ok()) return StatusWithContext(digest.status(), path);
  return digest;
}

bool BlobStore::Contains(const std::string& sha256) const {
  if (!IsValidSha256Hex(sha256)) return false;
  std::error_code ec;
  return fs::is_regular_file(BlobPath(root_, sha256), ec);
}

absl::StatusOr<std::string> BlobStore::PathOf(const std::string& sha256) const {
  RETURN_IF_ERROR(CheckSha256("sha256", sha256));
  std::string path = BlobPath(root_, sha256);
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) {
    return absl::NotFoundError(absl::StrCat("blob ", sha256, " not found"));
  }
  return path;
}

absl::StatusOr<std::string> BlobStore::Get(const std::string& sha256) const {
  ASSIGN_OR_RETURN(const std::string path, PathOf(sha256));
  ASSIGN_OR_RETURN(std::string content, ReadFileToString(path));
  const std::string actual = Sha256Hex(content);
  if (actual != sha256) {
    std::error_code ec;
    fs::remove(path, ec);
    return absl::DataLossError(absl::StrCat("blob ", sha256, " is corrupted (content hashes to ",
                                            actual, "); the file was removed"));
  }
  return content;
}

absl::StatusOr<int64_t> BlobStore::SizeOf(const std::string& sha256) const {
  ASSIGN_OR_RETURN(const std::string path, PathOf(sha256));
  std::error_code ec;
  const uintmax_t size = fs::file_size(path, ec);
  if (ec) {
    if (ec == std::errc::no_such_file_or_directory) {
      return absl::NotFoundError(absl::StrCat("blob ", sha256, " not found"));
    }
    return absl::InternalError(absl::StrCat(path, ": ", ec.message()));
  }
  return static_cast<int64_t>(size);
}

absl::Status BlobStore::Verify(const std::string& sha256) const {
  ASSIGN_OR_RETURN(const std::string path, PathOf(sha256));
  ASSIGN_OR_RETURN(const std::string actual, Sha256File(path));
  if (actual != sha256) {
    std::error_code ec;
    fs::remove(path, ec);
    return absl::DataLossError(absl::StrCat("blob ", sha256, " is corrupted (content hashes to ",
                                            actual, "); the file was removed"));
  }
  return absl::OkStatus();
}

absl::Status BlobStore::Remove(const std::string& sha256) const {
  ASSIGN_OR_RETURN(const std::string path, PathOf(sha256));
  std::error_code ec;
  if (!fs::remove(path, ec) && ec)
    return absl::InternalError(absl::StrCat(path, ": ", ec.message()));
  return absl::OkStatus();
}

absl::StatusOr<int64_t> BlobStore::TotalBytes() const {
  int64_t total = 0;
  std::error_code ec;
  for (fs::directory_iterator dir(root_, ec); !ec && dir != fs::directory_iterator();
       dir.increment(ec)) {
    const std::string name = dir->path().filename().string();
    // Blobs live in the two-hex-digit directories; tmp/ and scratch/ are not blobs.
    if (name.size() != 2 || !IsValidSha256Hex(name + std::string(62, '0'))) continue;
    std::error_code inner;
    for (fs::directory_iterator it(dir->path(), inner); !inner && it != fs::directory_iterator();
         it.increment(inner)) {
      std::error_code size_ec;
      const uintmax_t size = it->file_size(size_ec);
      if (!size_ec) total += static_cast<int64_t>(size);
    }
  }
  if (ec) return absl::InternalError(absl::StrCat(root_, ": ", ec.message()));
  return total;
}

}  // namespace pf
