// Sending a clip to the server: either a "file://" URI the server reads
// itself, or an upload of the manifest and every file it references to the
// blob service.
//
//   ASSIGN_OR_RETURN(ClipInput input, PrepareClipInput("clips/a/clip.json"));  // local checks
//   ... connect ...
//   ASSIGN_OR_RETURN(ClipSource source, SendClipInput(input, blobs));
#ifndef POINTFORWARD_CLIENT_REMOTE_CLIP_UPLOAD_H_
#define POINTFORWARD_CLIENT_REMOTE_CLIP_UPLOAD_H_

#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "pointforward/v1/resources.pb.h"
#include "rpc/blob_transfer.h"

namespace pf {

// One referenced file to upload.
struct ClipFileUpload {
  std::string key;         // The path as the manifest writes it: UploadedClip.files key.
  std::string field;       // Where the manifest names it: "frames[2].image".
  std::string local_path;  // The file on this machine.
};

// Everything an uploaded clip consists of.
struct ClipUploadPlan {
  std::string manifest_path;
  std::vector<ClipFileUpload> files;  // In manifest order, each path once.
};

// Reads the manifest at `manifest_path` and lists the files it references,
// resolved against its directory. Fails when the manifest does not parse,
// a path is absolute or leaves the manifest's directory (the server could
// not lay it out), or a file is missing; errors name the field and the path
// ("frames[2].image: file not found: /data/clip/images/front_1.png").
absl::StatusOr<ClipUploadPlan> PlanClipUpload(const std::string& manifest_path);

// Uploads the manifest and the files of `plan` (the blob service skips those
// it already has) and returns the UploadedClip naming them.
absl::StatusOr<pointforward::v1::UploadedClip> UploadClip(const ClipUploadPlan& plan,
                                                          BlobClient& blobs);

// A clip as the user named it on the command line.
struct ClipInput {
  std::string uri;      // "file:///abs/clip.json": the server reads the files.
  ClipUploadPlan plan;  // Otherwise: the files to upload.
};

// Returns the clip `arg` names, checked locally: a "file://" URI must hold
// an absolute path; anything else is a manifest path given to
// PlanClipUpload.
absl::StatusOr<ClipInput> PrepareClipInput(const std::string& arg);

// Returns the ClipSource for `input`, uploading its files unless it is a URI.
absl::StatusOr<pointforward::v1::ClipSource> SendClipInput(const ClipInput& input,
                                                           BlobClient& blobs);

}  // namespace pf

#endif  // POINTFORWARD_CLIENT_REMOTE_CLIP_UPLOAD_H_
