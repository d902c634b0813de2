// Downloading the files a render job produced into a local directory. The
// names come from the server, so each is checked to be a plain file name
// before anything is written.
#ifndef POINTFORWARD_CLIENT_REMOTE_OUTPUT_FILES_H_
#define POINTFORWARD_CLIENT_REMOTE_OUTPUT_FILES_H_

#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "pointforward/v1/resources.pb.h"
#include "rpc/blob_transfer.h"

namespace pf {

// Checks that `name` is a plain file name that stays inside the output
// directory: not empty, not "." or "..", no '/', '\\' or NUL. Returns
// INVALID_ARGUMENT naming it otherwise.
absl::Status CheckOutputName(const std::string& name);

// Checks every OutputFile of `job` (names as above, no name twice, a digest
// present) before writing anything. INVALID_ARGUMENT naming `files[i]`.
absl::Status CheckOutputFiles(const pointforward::v1::RenderJob& job);

// Downloads every OutputFile of `job` into `dir` (created if missing); each
// file is written atomically and its hash checked by `blobs`. Returns the
// number of files.
absl::StatusOr<int> DownloadOutputs(BlobClient& blobs, const pointforward::v1::RenderJob& job,
                                    const std::string& dir);

}  // namespace pf

#endif  // POINTFORWARD_CLIENT_REMOTE_OUTPUT_FILES_H_
