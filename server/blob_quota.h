// The blob store's size limit (pf-server --max-blob-bytes): the scene cache
// gives way first. When the store holds more than the limit, the least
// recently used READY scenes that no unfinished render job needs are
// evicted (scene row and scene file) until it fits; scenes being built or
// in use, and every job's outputs, are never touched. When nothing more
// can be evicted, uploads are refused.
//
//   BlobQuota quota(store.get(), &blobs, /*max_bytes=*/100 << 30);
//   RETURN_IF_ERROR(quota.MakeRoom());  // Before an upload; again after it.
#ifndef POINTFORWARD_SERVER_BLOB_QUOTA_H_
#define POINTFORWARD_SERVER_BLOB_QUOTA_H_

#include <cstdint>
#include <mutex>

#include "absl/status/status.h"
#include "server/blobs/blob_store.h"
#include "server/store/job_store.h"

namespace pf {

class BlobQuota {
 public:
  // `max_bytes` 0 means no limit. `store` and `blobs` must outlive this.
  BlobQuota(JobStore* store, BlobStore* blobs, int64_t max_bytes)
      : store_(store), blobs_(blobs), max_bytes_(max_bytes) {}

  int64_t max_bytes() const { return max_bytes_; }

  // Evicts least recently used scenes while the blob store holds more than
  // the limit. OK when it is (now) within it; RESOURCE_EXHAUSTED naming
  // --max-blob-bytes when it is still over and no scene can be evicted.
  absl::Status MakeRoom();

 private:
  JobStore* store_;
  BlobStore* blobs_;
  const int64_t max_bytes_;
  std::mutex mu_;  // One eviction pass at a time in this process.
};

}  // namespace pf

#endif  // POINTFORWARD_SERVER_BLOB_QUOTA_H_
