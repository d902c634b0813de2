// Client side of pointforward.v1.BlobService: uploads files and bytes in
// chunks and downloads blobs to files, checking the SHA-256 on both ends.
// Used by the remote `pf`, pf-worker and the tests.
//
//   BlobClient blobs(channel);
//   ASSIGN_OR_RETURN(pointforward::v1::Digest d, blobs.UploadFile("clip/img.png"));
//   RETURN_IF_ERROR(blobs.DownloadToFile(d.sha256(), "out/img.png"));
#ifndef POINTFORWARD_RPC_BLOB_TRANSFER_H_
#define POINTFORWARD_RPC_BLOB_TRANSFER_H_

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "grpcpp/channel.h"
#include "pointforward/v1/blobs.grpc.pb.h"

namespace pf {

// Bytes per WriteBlob / ReadBlob message.
inline constexpr int64_t kBlobChunkBytes = 1 << 20;

class BlobClient {
 public:
  // `server_address` (optional) names the server in UNAVAILABLE errors.
  explicit BlobClient(std::shared_ptr<grpc::Channel> channel, std::string server_address = "");

  // Hashes the file, asks FindMissingBlobs, and streams it only when the
  // server lacks it. Errors name the path.
  absl::StatusOr<pointforward::v1::Digest> UploadFile(const std::string& path);
  absl::StatusOr<pointforward::v1::Digest> UploadBytes(std::string_view bytes);
  // Uploads several files (skipping those the server has), in order.
  absl::StatusOr<std::vector<pointforward::v1::Digest>> UploadFiles(
      const std::vector<std::string>& paths);

  // Streams the blob into `path` (written atomically) and checks its hash:
  // DATA_LOSS on mismatch, nothing left at `path` then.
  absl::Status DownloadToFile(const std::string& sha256, const std::string& path);
  absl::StatusOr<std::string> DownloadBytes(const std::string& sha256);

 private:
  // Returns, for each digest, whether the server lacks it (FindMissingBlobs).
  absl::StatusOr<std::vector<bool>> FindMissing(
      const std::vector<pointforward::v1::Digest>& digests);
  // Streams the chunks `next_chunk` returns (an empty one ends) to WriteBlob
  // under `digest`.
  absl::Status Write(const pointforward::v1::Digest& digest,
                     const std::function<absl::StatusOr<std::string_view>()>& next_chunk);
  // Streams the blob through `sink` and checks its hash: DATA_LOSS on
  // mismatch (the sink has then seen bad bytes; callers discard them).
  absl::Status Read(const std::string& sha256,
                    const std::function<absl::Status(std::string_view)>& sink);
  absl::Status FromGrpcStatus(const grpc::Status& status) const;

  std::unique_ptr<pointforward::v1::BlobService::Stub> stub_;
  std::string server_address_;
};

}  // namespace pf

#endif  // POINTFORWARD_RPC_BLOB_TRANSFER_H_
