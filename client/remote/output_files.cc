// Checked download of a render job's output files.
#include "client/remote/output_files.h"

#include <set>

#include "absl/strings/str_cat.h"
#include "common/file_util.h"
#include "common/status_macros.h"

namespace pf {

namespace v1 = pointforward::v1;

absl::Status CheckOutputName(const std::string& name) {
  if (name.empty()) return absl::InvalidArgumentError("output file name is empty");
  if (name == "." || name == "..") {
    return absl::InvalidArgumentError(absl::StrCat("output file name '", name, "' is not a file"));
  }
  if (name.find_first_of(std::string("/\\\0", 3)) != std::string::npos) {
    return absl::InvalidArgumentError(absl::StrCat(
        "output file name '", name, "' is not a plain file name (it has a path separator)"));
  }
  return absl::OkStatus();
}

absl::Status CheckOutputFiles(const v1::RenderJob& job) {
  std::set<std::string> seen;
  for (int i = 0; i < job.files_size(); ++i) {
    const v1::OutputFile& file = job.files(i);
    const std::string field = absl::StrCat(job.name(), " files[", i, "]");
    RETURN_IF_ERROR(StatusWithContext(CheckOutputName(file.name()), field));
    if (!seen.insert(file.name()).second) {
      return absl::InvalidArgumentError(
          absl::StrCat(field, ": output file name '", file.name(), "' appears twice"));
    }
    if (file.digest().sha256().empty()) {
      return absl::InvalidArgumentError(absl::StrCat(field, ".digest: no sha256"));
    }
  }
  return absl::OkStatus();
}

absl::StatusOr<int> DownloadOutputs(BlobClient& blobs, const v1::RenderJob& job,
                                    const std::string& dir) {
  RETURN_IF_ERROR(CheckOutputFiles(job));
  RETURN_IF_ERROR(MakeDirs(dir));
  for (const v1::OutputFile& file : job.files()) {
    RETURN_IF_ERROR(
        blobs.DownloadToFile(file.digest().sha256(), absl::StrCat(dir, "/", file.name())));
  }
  return job.files_size();
}

}  // namespace pf
