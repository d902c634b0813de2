// BlobQuota: see blob_quota.h.
#include "server/blob_quota.h"

#include <string>

#include "absl/strings/str_cat.h"
#include "common/bounded_json.h"
#include "common/status_macros.h"
#include "pointforward/v1/resources.pb.h"
#include "spdlog/spdlog.h"

namespace pf {

absl::Status BlobQuota::MakeRoom() {
  if (max_bytes_ <= 0) return absl::OkStatus();
  std::lock_guard<std::mutex> lock(mu_);
  ASSIGN_OR_RETURN(int64_t total, blobs_->TotalBytes());
  while (total > max_bytes_) {
    ASSIGN_OR_RETURN(const std::optional<SceneRecord> evicted,
                     store_->EvictLeastRecentlyUsedScene());
    if (!evicted) {
      return absl::ResourceExhaustedError(absl::StrCat(
          "blobs: the blob store holds ", total, " bytes, over the limit of ", max_bytes_,
          " (--max-blob-bytes), and every cached scene is in use or being built; uploads are "
          "refused until jobs finish or scenes are deleted"));
    }
    pointforward::v1::Scene scene;
    const absl::Status parsed =
        ParseBoundedProtoJson(evicted->description, &scene, kStoredJsonLimits);
    const std::string& sha256 = scene.scene_file().sha256();
    int64_t freed = 0;
    if (parsed.ok() && blobs_->Contains(sha256)) {
      freed = blobs_->SizeOf(sha256).value_or(0);
      if (absl::Status removed = blobs_->Remove(sha256); !removed.ok()) {
        spdlog::error("evicting scenes/{}: {}", evicted->id, std::string(removed.message()));
        freed = 0;
      }
    }
    spdlog::info(
        "evicted scenes/{} (scene file of {} bytes, last used at {} ms) to keep the blob "
        "store under --max-blob-bytes {}",
        evicted->id, freed, evicted->update_time_ms, max_bytes_);
    // Re-count: another replica sharing the directory may have written too.
    ASSIGN_OR_RETURN(total, blobs_->TotalBytes());
  }
  return absl::OkStatus();
}

}  // namespace pf
