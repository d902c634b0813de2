// BlobClient: chunked uploads that skip what the server already has, and
// downloads written atomically after their hash checks out.
#include "rpc/blob_transfer.h"

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <system_error>
#include <unordered_set>
#include <utility>

#include "absl/strings/str_cat.h"
#include "common/file_util.h"
#include "common/hash.h"
#include "common/status_macros.h"
#include "rpc/grpc_status.h"

namespace pf {
namespace {

namespace fs = std::filesystem;
namespace v1 = pointforward::v1;

// Returns the SHA-256 and size of the file at `path`; errors name the path.
absl::StatusOr<v1::Digest> DigestOfFile(const std::string& path) {
  ASSIGN_OR_RETURN(std::string sha256, Sha256File(path));
  std::error_code ec;
  const uintmax_t size = fs::file_size(path, ec);
  if (ec) return absl::InternalError(absl::StrCat(path, ": ", ec.message()));
  v1::Digest digest;
  digest.set_sha256(std::move(sha256));
  digest.set_size_bytes(static_cast<int64_t>(size));
  return digest;
}

// Closes a FILE* when it goes out of scope.
struct FileCloser {
  void operator()(std::FILE* file) const { std::fclose(file); }
};
using FilePtr = std::unique_ptr<std::FILE, FileCloser>;

}  // namespace

BlobClient::BlobClient(std::shared_ptr<grpc::Channel> channel, std::string server_address)
    : stub_(v1::BlobService::NewStub(channel)), server_address_(std::move(server_address)) {}

absl::Status BlobClient::FromGrpcStatus(const grpc::Status& status) const {
  return FromGrpc(status, server_address_);
}

absl::StatusOr<std::vector<bool>> BlobClient::FindMissing(const std::vector<v1::Digest>& digests) {
  v1::FindMissingBlobsRequest request;
  for (const v1::Digest& digest : digests) *request.add_digests() = digest;
  v1::FindMissingBlobsResponse response;
  grpc::ClientContext context;
  const grpc::Status status = stub_->FindMissingBlobs(&context, request, &response);
  if (!status.ok()) return FromGrpcStatus(status);
  std::unordered_set<std::string> missing;
  for (const v1::Digest& digest : response.missing()) missing.insert(digest.sha256());
  std::vector<bool> result;
  result.reserve(digests.size());
  for (const v1::Digest& digest : digests) result.push_back(missing.count(digest.sha256()) > 0);
  return result;
}

absl::Status BlobClient::Write(
    const v1::Digest& digest, const std::function<absl::StatusOr<std::string_view>()>& next_chunk) {
  grpc::ClientContext context;
  v1::WriteBlobResponse response;
  std::unique_ptr<grpc::ClientWriter<v1::WriteBlobRequest>> writer =
      stub_->WriteBlob(&context, &response);
  bool first = true;
  while (true) {
    absl::StatusOr<std::string_view> chunk = next_chunk();
    if (!chunk.ok()) {
      // Cancelling makes the server drop what it has received.
      context.TryCancel();
      writer->Finish();
      return chunk.status();
    }
    if (chunk->empty() && !first) break;
    v1::WriteBlobRequest request;
    if (first) *request.mutable_digest() = digest;
    request.set_data(chunk->data(), chunk->size());
    first = false;
    // A refused write means the stream is over; Finish() says why.
    if (!writer->Write(request)) break;
    if (chunk->empty()) break;
  }
  writer->WritesDone();
  const grpc::Status status = writer->Finish();
  if (!status.ok()) return FromGrpcStatus(status);
  return absl::OkStatus();
}

absl::StatusOr<v1::Digest> BlobClient::UploadFile(const std::string& path) {
  ASSIGN_OR_RETURN(std::vector<v1::Digest> digests, UploadFiles({path}));
  return digests.front();
}

absl::StatusOr<v1::Digest> BlobClient::UploadBytes(std::string_view bytes) {
  v1::Digest digest;
  digest.set_sha256(Sha256Hex(bytes));
  digest.set_size_bytes(static_cast<int64_t>(bytes.size()));
  ASSIGN_OR_RETURN(const std::vector<bool> missing, FindMissing({digest}));
  if (!missing.front()) return digest;
  std::string_view rest = bytes;
  RETURN_IF_ERROR(Write(digest, [&rest]() -> absl::StatusOr<std::string_view> {
    const std::string_view chunk = rest.substr(0, kBlobChunkBytes);
    rest.remove_prefix(chunk.size());
    return chunk;
  }));
  return digest;
}

absl::StatusOr<std::vector<v1::Digest>> BlobClient::UploadFiles(
    const std::vector<std::string>& paths) {
  std::vector<v1::Digest> digests;
  digests.reserve(paths.size());
  for (const std::string& path : paths) {
    ASSIGN_OR_RETURN(v1::Digest digest, DigestOfFile(path));
    digests.push_back(std::move(digest));
  }
  absl::StatusOr<std::vector<bool>> missing = FindMissing(digests);
  if (!missing.ok()) {
    return StatusWithContext(missing.status(), paths.size() == 1 ? paths.front() : "upload");
  }

  std::unordered_set<std::string> sent;
  std::string buffer(kBlobChunkBytes, '\0');
  for (size_t i = 0; i < paths.size(); ++i) {
    const std::string& path = paths[i];
    if (!(*missing)[i] || !sent.insert(digests[i].sha256()).second) continue;
    FilePtr file(std::fopen(path.c_str(), "rb"));
    if (file == nullptr) {
      return absl::NotFoundError(absl::StrCat(path, ": cannot open: ", std::strerror(errno)));
    }
    absl::Status written =
        Write(digests[i], [&file, &buffer, &path]() -> absl::StatusOr<std::string_view> {
          const size_t got = std::fread(buffer.data(), 1, buffer.size(), file.get());
          if (got == 0 && std::ferror(file.get())) {
            return absl::InternalError(absl::StrCat(path, ": read error"));
          }
          return std::string_view(buffer.data(), got);
        });
    if (!written.ok()) return StatusWithContext(written, path);
  }
  return digests;
}

absl::Status BlobClient::Read(const std::string& sha256,
                              const std::function<absl::Status(std::string_view)>& sink) {
  grpc::ClientContext context;
  v1::ReadBlobRequest request;
  request.set_sha256(sha256);
  std::unique_ptr<grpc::ClientReader<v1::ReadBlobResponse>> reader =
      stub_->ReadBlob(&context, request);
  Sha256 hasher;
  v1::ReadBlobResponse response;
  absl::Status sink_status;
  while (reader->Read(&response)) {
    hasher.Update(response.data());
    sink_status = sink(response.data());
    if (!sink_status.ok()) {
      context.TryCancel();
      while (reader->Read(&response)) {
      }
      break;
    }
  }
  const grpc::Status status = reader->Finish();
  RETURN_IF_ERROR(sink_status);
  if (!status.ok()) return FromGrpcStatus(status);
  const std::string actual = hasher.FinishHex();
  if (actual != sha256) {
    return absl::DataLossError(
        absl::StrCat("blob ", sha256, ": downloaded content hashes to ", actual));
  }
  return absl::OkStatus();
}

absl::Status BlobClient::DownloadToFile(const std::string& sha256, const std::string& path) {
  RETURN_IF_ERROR(MakeDirs(fs::path(path).parent_path().string()));
  const std::string temp = TempPathFor(path);
  FilePtr file(std::fopen(temp.c_str(), "wb"));
  if (file == nullptr) {
    return absl::InternalError(absl::StrCat(path, ": cannot write: ", std::strerror(errno)));
  }
  absl::Status status = Read(sha256, [&file, &path](std::string_view data) {
    if (std::fwrite(data.data(), 1, data.size(), file.get()) != data.size()) {
      return absl::InternalError(absl::StrCat(path, ": write failed (disk full?)"));
    }
    return absl::OkStatus();
  });
  if (status.ok() && (std::fflush(file.get()) != 0 || ::fsync(::fileno(file.get())) != 0)) {
    status = absl::InternalError(absl::StrCat(path, ": write failed: ", std::strerror(errno)));
  }
  file.reset();
  if (!status.ok()) {
    std::error_code ec;
    fs::remove(temp, ec);
    return StatusWithContext(status, path);
  }
  return CommitTempFile(temp, path);
}

absl::StatusOr<std::string> BlobClient::DownloadBytes(const std::string& sha256) {
  std::string bytes;
  RETURN_IF_ERROR(Read(sha256, [&bytes](std::string_view data) {
    bytes.append(data.data(), data.size());
    return absl::OkStatus();
  }));
  return bytes;
}

}  // namespace pf
