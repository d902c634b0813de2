// Job and scene names as the user types them, turned into resource names.
#include "client/remote/resource_names.h"

#include <filesystem>
#include <system_error>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"

namespace pf {
namespace {

constexpr char kOperations[] = "operations/";
constexpr char kRenderJobs[] = "renderJobs/";
constexpr char kScenes[] = "scenes/";

// Returns `name` without `prefix` when it starts with it.
std::string StripPrefix(const std::string& name, const std::string& prefix) {
  return absl::StartsWith(name, prefix) ? name.substr(prefix.size()) : name;
}

// Checks that `id` (from `original`) is one non-empty segment of printable
// characters; `expected` lists the accepted forms.
absl::Status CheckId(const std::string& original, const std::string& id,
                     const std::string& expected) {
  bool plain = !id.empty();
  for (const char c : id) {
    if (c == '/' || static_cast<unsigned char>(c) <= ' ' || c == 0x7f) plain = false;
  }
  if (plain) return absl::OkStatus();
  return absl::InvalidArgumentError(
      absl::StrCat("'", original, "' is not a valid name: expected ", expected));
}

}  // namespace

absl::StatusOr<std::string> OperationNameFor(const std::string& id) {
  if (absl::StartsWith(id, kScenes)) {
    return absl::InvalidArgumentError(absl::StrCat("'", id,
                                                   "' names a scene, not a job: use `pf scene get ",
                                                   id, "` (its `operation` field names the job)"));
  }
  const std::string bare = absl::StartsWith(id, kRenderJobs) ? StripPrefix(id, kRenderJobs)
                                                             : StripPrefix(id, kOperations);
  if (const absl::Status status = CheckId(id, bare, "operations/ID, renderJobs/ID or ID");
      !status.ok()) {
    return status;
  }
  return absl::StrCat(kOperations, bare);
}

absl::StatusOr<std::string> SceneNameFor(const std::string& id) {
  std::error_code ec;
  if (!absl::StartsWith(id, kScenes) && std::filesystem::is_regular_file(id, ec)) {
    return absl::InvalidArgumentError(absl::StrCat(
        "'", id,
        "' is a file on this machine; with --server (or PF_SERVER), SCENE names a scene on the "
        "server (scenes/ID or ID, as pf scene create and pf scene list print). For a local "
        "scene file, run the command without --server"));
  }
  const std::string bare = StripPrefix(id, kScenes);
  if (const absl::Status status = CheckId(id, bare, "scenes/ID or ID"); !status.ok()) {
    return status;
  }
  return absl::StrCat(kScenes, bare);
}

}  // namespace pf
