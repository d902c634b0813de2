// Clip intake: see clip_intake.h.
#include "server/clip_intake.h"

#include <algorithm>
#include <filesystem>
#include <map>
#include <string>
#include <system_error>
#include <vector>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "common/bounded_json.h"
#include "common/file_util.h"
#include "common/hash.h"
#include "common/status_macros.h"
#include "common/version.h"
#include "engine/clip/clip_io.h"
#include "engine/clip/clip_validator.h"
#include "engine/recon/recon_option_table.h"

namespace pf {
namespace {

namespace fs = std::filesystem;
namespace v1 = pointforward::v1;

constexpr char kFileScheme[] = "file://";

// Places blob `sha256` at `path`: a hard link when the blob store is on the
// same file system, a copy otherwise.
absl::Status LinkBlob(BlobStore& blobs, const std::string& sha256, const std::string& path) {
  ASSIGN_OR_RETURN(const std::string blob_path, blobs.PathOf(sha256));
  RETURN_IF_ERROR(MakeDirs(fs::path(path).parent_path().string()));
  std::error_code ec;
  fs::create_hard_link(blob_path, path, ec);
  if (!ec) return absl::OkStatus();
  fs::copy_file(blob_path, path, fs::copy_options::overwrite_existing, ec);
  if (ec) return absl::InternalError(absl::StrCat("staging ", path, ": ", ec.message()));
  return absl::OkStatus();
}

// INVALID_ARGUMENT naming `field` unless `digest` gives its blob's size.
absl::Status CheckSize(BlobStore& blobs, const v1::Digest& digest, const std::string& field) {
  ASSIGN_OR_RETURN(const int64_t size, blobs.SizeOf(digest.sha256()));
  if (size == digest.size_bytes()) return absl::OkStatus();
  return absl::InvalidArgumentError(absl::StrCat(field, ".size_bytes: ", digest.size_bytes(),
                                                 ", but the blob has ", size, " bytes"));
}

// Removes the staging directory however the intake ends.
struct StagingDir {
  explicit StagingDir(std::string dir) : path(std::move(dir)) {}
  ~StagingDir() {
    std::error_code ec;
    fs::remove_all(path, ec);
  }
  std::string path;
};

absl::Status ValidateStaged(const std::string& manifest_path, const std::string& field) {
  const ClipReport report = ValidateClipFile(manifest_path, ValidateOptions{});
  if (report.ok()) return absl::OkStatus();
  std::vector<std::string> lines;
  for (const ClipProblem& problem : report.problems) lines.push_back(problem.ToString());
  return absl::InvalidArgumentError(absl::StrCat(
      field, ": ", report.problems.size(), report.problems.size() == 1 ? " problem" : " problems",
      "\n", absl::StrJoin(lines, "\n")));
}

absl::StatusOr<AcceptedClip> AcceptUploaded(const v1::UploadedClip& uploaded, BlobStore& blobs,
                                            const std::string& staging_root,
                                            const ClipLimits& limits) {
  const std::string& manifest_sha = uploaded.manifest().sha256();
  if (!IsValidSha256Hex(manifest_sha)) {
    return absl::InvalidArgumentError(absl::StrCat("clip.uploaded.manifest.sha256: '", manifest_sha,
                                                   "' is not 64 lowercase hex digits"));
  }
  if (!blobs.Contains(manifest_sha)) {
    return absl::InvalidArgumentError(absl::StrCat("clip.uploaded.manifest: blob ", manifest_sha,
                                                   " was not uploaded (BlobService.WriteBlob)"));
  }
  RETURN_IF_ERROR(CheckSize(blobs, uploaded.manifest(), "clip.uploaded.manifest"));
  // The manifest is read whole: its size is bounded before it is parsed.
  if (uploaded.manifest().size_bytes() > JsonLimits{}.max_bytes) {
    return absl::InvalidArgumentError(absl::StrCat(
        "clip.uploaded.manifest: ", uploaded.manifest().size_bytes(), " bytes exceed the limit of ",
        JsonLimits{}.max_bytes, " bytes for a manifest"));
  }
  StagingDir staging(staging_root);
  RETURN_IF_ERROR(MakeDirs(staging.path));
  const std::string manifest_path = staging.path + "/clip.json";
  RETURN_IF_ERROR(LinkBlob(blobs, manifest_sha, manifest_path));

  // Every file the manifest names must be in the map, and every map entry
  // must be a file the manifest names.
  std::vector<ClipProblem> problems;
  absl::StatusOr<LoadedClip> loaded = LoadClip(manifest_path, &problems);
  if (!loaded.ok()) {
    std::vector<std::string> lines;
    for (const ClipProblem& problem : problems) lines.push_back(problem.ToString());
    return absl::InvalidArgumentError(absl::StrCat(
        "clip.uploaded.manifest: ",
        lines.empty() ? std::string(loaded.status().message()) : absl::StrJoin(lines, "\n")));
  }
  RETURN_IF_ERROR(CheckClipLimits(loaded->clip, limits));
  std::map<std::string, std::string> referenced;  // path -> field
  for (const ClipFileRef& ref : ReferencedFiles(loaded->clip)) referenced[ref.path] = ref.field;
  for (const auto& [path, digest] : uploaded.files()) {
    const std::string field = absl::StrCat("clip.uploaded.files[\"", path, "\"]");
    if (!referenced.count(path)) {
      return absl::InvalidArgumentError(
          absl::StrCat(field, ": the manifest does not reference this file"));
    }
    absl::StatusOr<std::string> target =
        ResolvePath(staging.path, path, PathPolicy::kUnderRootOnly);
    if (!target.ok()) {
      return absl::InvalidArgumentError(absl::StrCat(field, ": ", target.status().message()));
    }
    std::string file = *target;
    while (file.size() > 1 && file.back() == '/') file.pop_back();
    if (file == staging.path || file == manifest_path || absl::EndsWith(path, "/")) {
      return absl::InvalidArgumentError(
          absl::StrCat(field, ": names the clip directory or its manifest, not a file in it"));
    }
    if (!IsValidSha256Hex(digest.sha256())) {
      return absl::InvalidArgumentError(
          absl::StrCat(field, ".sha256: '", digest.sha256(), "' is not 64 lowercase hex digits"));
    }
    if (!blobs.Contains(digest.sha256())) {
      return absl::InvalidArgumentError(absl::StrCat(field, ": blob ", digest.sha256(),
                                                     " was not uploaded (BlobService.WriteBlob)"));
    }
    RETURN_IF_ERROR(CheckSize(blobs, digest, field));
    RETURN_IF_ERROR(LinkBlob(blobs, digest.sha256(), *target));
  }
  for (const auto& [path, field] : referenced) {
    if (!uploaded.files().contains(path)) {
      return absl::InvalidArgumentError(absl::StrCat("clip.uploaded.files: ", field, " names '",
                                                     path,
                                                     "', which was not uploaded with the clip"));
    }
  }
  RETURN_IF_ERROR(ValidateStaged(manifest_path, "clip"));

  AcceptedClip accepted;
  accepted.uploaded = uploaded;  // Sizes checked above.
  accepted.summary = ValidateClipFile(manifest_path, ValidateOptions{}).summary.ToString();
  return accepted;
}

// Resolves a file:// URI to a real path under one of `roots`, symlinks
// resolved first.
absl::StatusOr<std::string> ResolveTrustedUri(const std::string& uri,
                                              const std::vector<std::string>& roots) {
  if (roots.empty()) {
    return absl::FailedPreconditionError(
        "clip.uri: this server trusts no directory for file:// clips (pf-server --trusted-root)");
  }
  if (!absl::StartsWith(uri, kFileScheme)) {
    return absl::InvalidArgumentError(
        absl::StrCat("clip.uri: '", uri, "' is not a file:///absolute/path URI"));
  }
  const std::string path = uri.substr(std::string(kFileScheme).size());
  if (path.empty() || path[0] != '/') {
    return absl::InvalidArgumentError(
        absl::StrCat("clip.uri: '", uri, "' does not name an absolute path (file:///...)"));
  }
  // Absent, unreadable and outside every root answer alike: the answer
  // must not tell what exists on the server, or where a link leads.
  const absl::Status refused = absl::InvalidArgumentError(
      absl::StrCat("clip.uri: ", path, " is not under a trusted root or is not a file there"));
  std::error_code ec;
  const fs::path real = fs::canonical(path, ec);
  if (ec || !fs::is_regular_file(real, ec)) return refused;
  for (const std::string& root : roots) {
    const fs::path real_root = fs::weakly_canonical(root, ec);
    if (ec) continue;
    const fs::path relative = real.lexically_relative(real_root);
    if (!relative.empty() && *relative.begin() != "..") return real.string();
  }
  return refused;
}

absl::StatusOr<AcceptedClip> AcceptUri(const std::string& uri, BlobStore& blobs,
                                       const std::vector<std::string>& roots,
                                       const std::string& staging_dir, const ClipLimits& limits) {
  ASSIGN_OR_RETURN(const std::string manifest_path, ResolveTrustedUri(uri, roots));
  // The limits first, from the manifest alone: no image is read before.
  {
    std::vector<ClipProblem> problems;
    absl::StatusOr<LoadedClip> manifest = LoadClip(manifest_path, &problems);
    if (manifest.ok()) RETURN_IF_ERROR(CheckClipLimits(manifest->clip, limits));
  }
  // The validator refuses paths that leave the clip's directory, and the
  // directory is under a trusted root, so every file read is too.
  RETURN_IF_ERROR(ValidateStaged(manifest_path, "clip"));
  ASSIGN_OR_RETURN(const LoadedClip loaded, LoadClip(manifest_path));
  v1::UploadedClip uploaded;
  ASSIGN_OR_RETURN(const BlobDigest manifest, blobs.PutFile(manifest_path));
  uploaded.mutable_manifest()->set_sha256(manifest.sha256);
  uploaded.mutable_manifest()->set_size_bytes(manifest.size_bytes);
  for (const ClipFileRef& ref : ReferencedFiles(loaded.clip)) {
    ASSIGN_OR_RETURN(const std::string path, ResolveClipPath(loaded, ref.path, false));
    ASSIGN_OR_RETURN(const BlobDigest digest, blobs.PutFile(path));
    v1::Digest& out = (*uploaded.mutable_files())[ref.path];
    out.set_sha256(digest.sha256);
    out.set_size_bytes(digest.size_bytes);
  }
  // Checked once more from the blob store: what was hashed is what is used.
  return AcceptUploaded(uploaded, blobs, staging_dir, limits);
}

}  // namespace

absl::Status CheckClipLimits(const v1::Clip& clip, const ClipLimits& limits) {
  if (limits.max_images_per_clip > 0 && clip.frames_size() > limits.max_images_per_clip) {
    return absl::InvalidArgumentError(
        absl::StrCat("clip: ", clip.frames_size(), " images exceed the limit of ",
                     limits.max_images_per_clip, " per clip (--max-images-per-clip)"));
  }
  if (limits.max_pixels_per_image > 0) {
    for (int i = 0; i < clip.cameras_size(); ++i) {
      const v1::Camera& camera = clip.cameras(i);
      const int64_t pixels = int64_t{camera.width()} * int64_t{camera.height()};
      if (pixels > limits.max_pixels_per_image) {
        return absl::InvalidArgumentError(
            absl::StrCat("clip.cameras[", i, "]: ", camera.width(), "x", camera.height(), " = ",
                         pixels, " pixels per image exceed the limit of ",
                         limits.max_pixels_per_image, " (--max-pixels-per-image)"));
      }
    }
  }
  return absl::OkStatus();
}

absl::StatusOr<AcceptedClip> AcceptClip(const v1::ClipSource& source, BlobStore& blobs,
                                        const std::vector<std::string>& trusted_roots,
                                        const std::string& staging_dir, const ClipLimits& limits) {
  switch (source.source_case()) {
    case v1::ClipSource::kUploaded:
      return AcceptUploaded(source.uploaded(), blobs, staging_dir, limits);
    case v1::ClipSource::kUri:
      return AcceptUri(source.uri(), blobs, trusted_roots, staging_dir, limits);
    default:
      return absl::InvalidArgumentError("clip: missing; set clip.uploaded or clip.uri");
  }
}

absl::StatusOr<v1::ReconstructionOptions> NormalizeOptions(
    const v1::ReconstructionOptions& options) {
  ASSIGN_OR_RETURN(v1::ReconstructionOptions out,
                   NormalizeReconProto(options, BuiltInReconModelNames()));
  if (out.device() != "cpu") {
    return absl::FailedPreconditionError(absl::StrCat(
        "options.device: '", out.device(), "' is not available; this build runs on cpu only"));
  }
  return out;
}

std::string SceneCacheKey(const v1::UploadedClip& clip, const v1::ReconstructionOptions& options) {
  Sha256 hash;
  auto field = [&hash](const std::string& name, const std::string& value) {
    hash.Update(absl::StrCat(name, "=", value.size(), ":", value, "\n"));
  };
  field("engine", SoftwareVersion());
  field("manifest", clip.manifest().sha256());
  std::map<std::string, std::string> files;  // Sorted by path.
  for (const auto& [path, digest] : clip.files()) files[path] = digest.sha256();
  for (const auto& [path, sha] : files) field(absl::StrCat("file ", path), sha);
  for (const auto& [name, value] : SceneCacheKeyFields(options)) field(name, value);
  return hash.FinishHex();
}

std::string SceneIdForKey(const std::string& key) { return key.substr(0, 24); }

}  // namespace pf
