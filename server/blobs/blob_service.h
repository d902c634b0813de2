// pointforward.v1.BlobService over a BlobStore: chunked uploads checked
// against their announced digest, chunked downloads checked while streaming.
//
//   BlobStore blobs(dir);
//   BlobServiceImpl service(&blobs, /*max_upload_bytes=*/1 << 30);
//   builder.RegisterService(&service);
#ifndef POINTFORWARD_SERVER_BLOBS_BLOB_SERVICE_H_
#define POINTFORWARD_SERVER_BLOBS_BLOB_SERVICE_H_

#include <cstdint>
#include <functional>

#include "pointforward/v1/blobs.grpc.pb.h"
#include "server/auth.h"
#include "server/blobs/blob_store.h"

namespace pf {

class BlobServiceImpl final : public pointforward::v1::BlobService::Service {
 public:
  // `store` must outlive the service. Uploads larger than
  // `max_upload_bytes` (> 0) are refused; 0 means no limit. With `auth`
  // (pf-server --auth-token-file), every call needs a valid token of any
  // role; blobs are named by their SHA-256, so reading one needs its digest,
  // which only the resources of its owner reveal.
  BlobServiceImpl(BlobStore* store, int64_t max_upload_bytes, Authenticator* auth = nullptr);

  // Keeps the store under its size limit (pf-server --max-blob-bytes): run
  // before an upload is accepted (an error refuses it) and after one is
  // stored. Unset: no limit.
  void set_make_room(std::function<absl::Status()> make_room) { make_room_ = std::move(make_room); }

  // The first message must carry the digest; the content is kept only when
  // its size and hash match it. A cancelled stream keeps nothing.
  grpc::Status WriteBlob(grpc::ServerContext* context,
                         grpc::ServerReader<pointforward::v1::WriteBlobRequest>* reader,
                         pointforward::v1::WriteBlobResponse* response) override;
  // Streams the blob from `offset` in 1 MiB chunks, hashing the whole file on
  // the way; DATA_LOSS (before the last chunk) when it does not match.
  grpc::Status ReadBlob(grpc::ServerContext* context,
                        const pointforward::v1::ReadBlobRequest* request,
                        grpc::ServerWriter<pointforward::v1::ReadBlobResponse>* writer) override;
  grpc::Status FindMissingBlobs(grpc::ServerContext* context,
                                const pointforward::v1::FindMissingBlobsRequest* request,
                                pointforward::v1::FindMissingBlobsResponse* response) override;

 private:
  BlobStore* store_;
  int64_t max_upload_bytes_;
  Authenticator* auth_;  // Null: authentication off.
  std::function<absl::Status()> make_room_;
};

}  // namespace pf

#endif  // POINTFORWARD_SERVER_BLOBS_BLOB_SERVICE_H_
