// Taking a clip in: checking an uploaded clip (manifest and files in the blob
// store) or reading one from a trusted shared volume (a file:// URI), before
// anything is queued, and computing the scene's cache key.
//
// The clip is checked by the same validator as `pf validate`: its files are
// hard-linked (or copied) from the blob store into a staging directory laid
// out as the manifest names them, so every rule (image sizes included)
// applies exactly as on a user's disk.
//
//   ASSIGN_OR_RETURN(AcceptedClip clip, AcceptClip(request.clip(), blobs, roots, staging));
//   std::string key = SceneCacheKey(clip.uploaded, options);
#ifndef POINTFORWARD_SERVER_CLIP_INTAKE_H_
#define POINTFORWARD_SERVER_CLIP_INTAKE_H_

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "pointforward/v1/clip.pb.h"
#include "pointforward/v1/resources.pb.h"
#include "server/blobs/blob_store.h"

namespace pf {

struct AcceptedClip {
  pointforward::v1::UploadedClip uploaded;  // Manifest and files, all in the blob store.
  std::string summary;                      // ClipSummary::ToString().
};

// Limits on what one clip may hold (pf-server flags); 0 means no limit.
struct ClipLimits {
  int64_t max_images_per_clip = 1000;         // --max-images-per-clip: frames.
  int64_t max_pixels_per_image = 50'000'000;  // --max-pixels-per-image: camera width x height.
};

// INVALID_ARGUMENT naming the limit and its flag when `clip` exceeds
// `limits`, e.g. "clip: 400 images exceed the limit of 256 per clip
// (--max-images-per-clip)". Looks at the manifest only.
absl::Status CheckClipLimits(const pointforward::v1::Clip& clip, const ClipLimits& limits);

// Checks `source` and returns the clip as blobs. Errors are INVALID_ARGUMENT
// naming the field: "clip.uploaded.manifest: blob ... not uploaded",
// "clip.uploaded.files[\"../x\"]: ...", "clip.uri: ... not under a trusted
// root", or "clip: 2 problems\nframes[0].image: ..." with the validator's
// findings; FAILED_PRECONDITION for a file:// URI when no root is trusted.
// Every digest's size_bytes must be its blob's size, a path must name a
// file (not the clip directory), and the manifest at most
// JsonLimits::max_bytes. A URI that is absent, not a file, or outside every
// root gets one answer, naming neither what exists nor where links lead.
// `limits` are checked on the manifest before any other file is staged or
// read. `staging_dir` is a scratch directory (created and removed here).
absl::StatusOr<AcceptedClip> AcceptClip(const pointforward::v1::ClipSource& source,
                                        BlobStore& blobs,
                                        const std::vector<std::string>& trusted_roots,
                                        const std::string& staging_dir,
                                        const ClipLimits& limits = {});

// NormalizeReconProto (recon_option_table.h) against the built-in models:
// every field checked, naming it (INVALID_ARGUMENT), defaults filled;
// FAILED_PRECONDITION for a device other than cpu.
absl::StatusOr<pointforward::v1::ReconstructionOptions> NormalizeOptions(
    const pointforward::v1::ReconstructionOptions& options);

// The scene cache key: SHA-256 over the engine version, the manifest's
// digest, every (path, file digest) in path order, and the normalised
// options but `device`.
std::string SceneCacheKey(const pointforward::v1::UploadedClip& clip,
                          const pointforward::v1::ReconstructionOptions& normalized_options);

// The scene id of a cache key: its first 24 hex digits.
std::string SceneIdForKey(const std::string& key);

}  // namespace pf

#endif  // POINTFORWARD_SERVER_CLIP_INTAKE_H_
