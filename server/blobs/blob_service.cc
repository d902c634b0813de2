// BlobService: translates WriteBlob/ReadBlob/FindMissingBlobs into BlobStore
// calls; the store does the checking, this file the streaming.
#include "server/blobs/blob_service.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <string>
#include <utility>

#include "absl/strings/str_cat.h"
#include "common/hash.h"
#include "rpc/grpc_status.h"
#include "spdlog/spdlog.h"

namespace pf {
namespace {

namespace v1 = pointforward::v1;

constexpr int64_t kChunkBytes = 1 << 20;

grpc::Status InvalidArgument(const std::string& message) {
  return grpc::Status(grpc::StatusCode::INVALID_ARGUMENT, message);
}

// Reads up to `size` bytes at the current position of `fd` into `buffer`;
// returns the count (0 at the end) or -1 with errno set.
ssize_t ReadSome(int fd, char* buffer, size_t size) {
  while (true) {
    const ssize_t n = ::read(fd, buffer, size);
    if (n >= 0 || errno != EINTR) return n;
  }
}

// Closes a file descriptor when it goes out of scope.
class FdCloser {
 public:
  explicit FdCloser(int fd) : fd_(fd) {}
  ~FdCloser() {
    if (fd_ >= 0) ::close(fd_);
  }
  FdCloser(const FdCloser&) = delete;
  FdCloser& operator=(const FdCloser&) = delete;

 private:
  int fd_;
};

}  // namespace

namespace {

// The caller of the call; Caller{"", admin} when authentication is off.
absl::StatusOr<Caller> CallerOf(Authenticator* auth, const grpc::ServerContext& context) {
  if (auth == nullptr) return Caller{"", Role::kAdmin};
  return auth->Authenticate(context);
}

}  // namespace

BlobServiceImpl::BlobServiceImpl(BlobStore* store, int64_t max_upload_bytes, Authenticator* auth)
    : store_(store), max_upload_bytes_(max_upload_bytes), auth_(auth) {}

grpc::Status BlobServiceImpl::WriteBlob(grpc::ServerContext* context,
                                        grpc::ServerReader<v1::WriteBlobRequest>* reader,
                                        v1::WriteBlobResponse* response) {
  if (absl::StatusOr<Caller> caller = CallerOf(auth_, *context); !caller.ok()) {
    return ToGrpc(caller.status());
  }
  v1::WriteBlobRequest request;
  if (!reader->Read(&request) || !request.has_digest()) {
    return InvalidArgument("digest: missing in the first message");
  }
  const BlobDigest expected{request.digest().sha256(), request.digest().size_bytes()};

  // Already stored (with that size): the rest of the stream is not needed.
  if (store_->Contains(expected.sha256)) {
    absl::StatusOr<int64_t> size = store_->SizeOf(expected.sha256);
    if (size.ok() && *size == expected.size_bytes) {
      while (reader->Read(&request)) {
      }
      response->mutable_digest()->set_sha256(expected.sha256);
      response->mutable_digest()->set_size_bytes(expected.size_bytes);
      response->set_already_present(true);
      return grpc::Status::OK;
    }
  }

  if (make_room_) {
    if (absl::Status room = make_room_(); !room.ok()) return ToGrpc(room);
  }
  absl::StatusOr<BlobWriter> writer = store_->StartWrite(expected, max_upload_bytes_);
  if (!writer.ok()) return ToGrpc(writer.status());
  do {
    if (context->IsCancelled()) {
      return grpc::Status(grpc::StatusCode::CANCELLED, "upload cancelled by the client");
    }
    absl::Status appended = writer->Append(request.data());
    if (!appended.ok()) return ToGrpc(appended);
  } while (reader->Read(&request));
  // A stream that broke off ends like a finished one, but cancelled.
  if (context->IsCancelled()) {
    return grpc::Status(grpc::StatusCode::CANCELLED, "upload cancelled by the client");
  }
  absl::StatusOr<BlobDigest> stored = writer->Finish();
  if (!stored.ok()) return ToGrpc(stored.status());
  if (make_room_) {
    // Over the limit now: the next upload is refused unless scenes go.
    if (absl::Status room = make_room_(); !room.ok()) {
      spdlog::warn("after storing blob {}: {}", stored->sha256, std::string(room.message()));
    }
  }
  response->mutable_digest()->set_sha256(stored->sha256);
  response->mutable_digest()->set_size_bytes(stored->size_bytes);
  response->set_already_present(false);
  return grpc::Status::OK;
}

grpc::Status BlobServiceImpl::ReadBlob(grpc::ServerContext* context,
                                       const v1::ReadBlobRequest* request,
                                       grpc::ServerWriter<v1::ReadBlobResponse>* writer) {
  if (absl::StatusOr<Caller> caller = CallerOf(auth_, *context); !caller.ok()) {
    return ToGrpc(caller.status());
  }
  const std::string& sha256 = request->sha256();
  if (!IsValidSha256Hex(sha256)) return InvalidArgument("sha256: not 64 lowercase hex digits");
  absl::StatusOr<std::string> path = store_->PathOf(sha256);
  if (!path.ok()) return ToGrpc(path.status());
  absl::StatusOr<int64_t> size = store_->SizeOf(sha256);
  if (!size.ok()) return ToGrpc(size.status());
  const int64_t offset = request->offset();
  if (offset < 0 || offset > *size) {
    return InvalidArgument(
        absl::StrCat("offset: ", offset, " is outside the blob's ", *size, " bytes"));
  }

  const int fd = ::open(path->c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    if (errno == ENOENT) {
      return grpc::Status(grpc::StatusCode::NOT_FOUND, absl::StrCat("blob ", sha256, " not found"));
    }
    return grpc::Status(grpc::StatusCode::INTERNAL,
                        absl::StrCat("blob ", sha256, ": cannot open: ", std::strerror(errno)));
  }
  FdCloser closer(fd);
  const auto read_error = [&sha256]() {
    return grpc::Status(grpc::StatusCode::INTERNAL,
                        absl::StrCat("blob ", sha256, ": read failed: ", std::strerror(errno)));
  };

  // The whole file is hashed, also the part before `offset` that is not sent.
  Sha256 hasher;
  std::string buffer(kChunkBytes, '\0');
  for (int64_t skipped = 0; skipped < offset;) {
    const ssize_t n =
        ReadSome(fd, buffer.data(), static_cast<size_t>(std::min(kChunkBytes, offset - skipped)));
    if (n < 0) return read_error();
    if (n == 0) break;  // Shrunk since SizeOf: the hash check below reports it.
    hasher.Update(buffer.data(), static_cast<size_t>(n));
    skipped += n;
  }

  // One chunk is held back until the next is read, so the last one goes out
  // only after the hash has been checked: a client never gets a corrupted
  // blob complete.
  v1::ReadBlobResponse pending;
  bool have_pending = false;
  while (true) {
    if (context->IsCancelled()) {
      return grpc::Status(grpc::StatusCode::CANCELLED, "download cancelled by the client");
    }
    const ssize_t n = ReadSome(fd, buffer.data(), buffer.size());
    if (n < 0) return read_error();
    if (n == 0) break;
    hasher.Update(buffer.data(), static_cast<size_t>(n));
    if (have_pending && !writer->Write(pending)) {
      return grpc::Status(grpc::StatusCode::CANCELLED, "download cancelled by the client");
    }
    pending.set_data(buffer.data(), static_cast<size_t>(n));
    have_pending = true;
  }
  const std::string actual = hasher.FinishHex();
  if (actual != sha256) {
    spdlog::error("blob {} is corrupted on disk (content hashes to {}); removing it", sha256,
                  actual);
    // Verify re-reads the file and removes it when it is still corrupted.
    absl::Status verified = store_->Verify(sha256);
    return grpc::Status(grpc::StatusCode::DATA_LOSS,
                        absl::StrCat("blob ", sha256,
                                     " is corrupted on the server (content "
                                     "hashes to ",
                                     actual, ")", verified.ok() ? "" : "; it was removed"));
  }
  if (have_pending && !writer->Write(pending)) {
    return grpc::Status(grpc::StatusCode::CANCELLED, "download cancelled by the client");
  }
  return grpc::Status::OK;
}

grpc::Status BlobServiceImpl::FindMissingBlobs(grpc::ServerContext* context,
                                               const v1::FindMissingBlobsRequest* request,
                                               v1::FindMissingBlobsResponse* response) {
  if (absl::StatusOr<Caller> caller = CallerOf(auth_, *context); !caller.ok()) {
    return ToGrpc(caller.status());
  }
  for (int i = 0; i < request->digests_size(); ++i) {
    const v1::Digest& digest = request->digests(i);
    if (!IsValidSha256Hex(digest.sha256())) {
      return InvalidArgument(absl::StrCat("digests[", i, "].sha256: not 64 lowercase hex digits"));
    }
    if (!store_->Contains(digest.sha256())) *response->add_missing() = digest;
  }
  return grpc::Status::OK;
}

}  // namespace pf
