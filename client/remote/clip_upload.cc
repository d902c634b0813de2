// Planning and sending a clip's upload.
#include "client/remote/clip_upload.h"

#include <filesystem>
#include <system_error>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "common/file_util.h"
#include "common/status_macros.h"
#include "engine/clip/clip_io.h"

namespace pf {

namespace v1 = pointforward::v1;

namespace {

constexpr char kFileScheme[] = "file://";

}  // namespace

absl::StatusOr<ClipUploadPlan> PlanClipUpload(const std::string& manifest_path) {
  ASSIGN_OR_RETURN(const LoadedClip loaded, LoadClip(manifest_path));
  ClipUploadPlan plan;
  plan.manifest_path = manifest_path;
  for (const ClipFileRef& ref : ReferencedFiles(loaded.clip)) {
    absl::StatusOr<std::string> local =
        ResolvePath(loaded.dir, ref.path, PathPolicy::kUnderRootOnly);
    if (!local.ok()) {
      return absl::InvalidArgumentError(
          absl::StrCat(ref.field, ": '", ref.path,
                       "' cannot be uploaded: ", std::string(local.status().message()),
                       " (a clip sent to a server names its files relative to the manifest; "
                       "use a file:// URI for clips on a shared volume)"));
    }
    std::error_code ec;
    if (!std::filesystem::is_regular_file(*local, ec)) {
      return absl::NotFoundError(absl::StrCat(ref.field, ": file not found: ", *local));
    }
    plan.files.push_back({ref.path, ref.field, *std::move(local)});
  }
  return plan;
}

absl::StatusOr<v1::UploadedClip> UploadClip(const ClipUploadPlan& plan, BlobClient& blobs) {
  v1::UploadedClip uploaded;
  ASSIGN_OR_RETURN(*uploaded.mutable_manifest(), blobs.UploadFile(plan.manifest_path));
  std::vector<std::string> paths;
  paths.reserve(plan.files.size());
  for (const ClipFileUpload& file : plan.files) paths.push_back(file.local_path);
  ASSIGN_OR_RETURN(const std::vector<v1::Digest> digests, blobs.UploadFiles(paths));
  if (digests.size() != plan.files.size()) {
    return absl::InternalError(
        absl::StrCat("uploaded ", digests.size(), " files of ", plan.files.size()));
  }
  for (size_t i = 0; i < digests.size(); ++i) {
    (*uploaded.mutable_files())[plan.files[i].key] = digests[i];
  }
  return uploaded;
}

absl::StatusOr<ClipInput> PrepareClipInput(const std::string& arg) {
  ClipInput input;
  if (absl::StartsWith(arg, kFileScheme)) {
    const std::string path = arg.substr(sizeof(kFileScheme) - 1);
    if (path.empty() || path[0] != '/') {
      return absl::InvalidArgumentError(absl::StrCat(
          "clip URI '", arg, "' must hold an absolute path: file:///abs/path/clip.json"));
    }
    input.uri = arg;
    return input;
  }
  ASSIGN_OR_RETURN(input.plan, PlanClipUpload(arg));
  return input;
}

absl::StatusOr<v1::ClipSource> SendClipInput(const ClipInput& input, BlobClient& blobs) {
  v1::ClipSource source;
  if (!input.uri.empty()) {
    source.set_uri(input.uri);
    return source;
  }
  ASSIGN_OR_RETURN(*source.mutable_uploaded(), UploadClip(input.plan, blobs));
  return source;
}

}  // namespace pf
