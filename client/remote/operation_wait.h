// Waiting for a long-running operation of the server while showing its
// progress, and reading what a finished one holds.
#ifndef POINTFORWARD_CLIENT_REMOTE_OPERATION_WAIT_H_
#define POINTFORWARD_CLIENT_REMOTE_OPERATION_WAIT_H_

#include <string>

#include "absl/status/statusor.h"
#include "client/remote/remote_context.h"
#include "google/longrunning/operations.pb.h"
#include "pointforward/v1/resources.pb.h"

namespace pf {

// Returns the OperationMetadata packed in `operation` (empty if none).
pointforward::v1::OperationMetadata MetadataOf(const google::longrunning::Operation& operation);

// Returns the name to show for `operation`: the metadata's target
// ("renderJobs/X", "scenes/X") when set, else the operation's name.
std::string DisplayName(const google::longrunning::Operation& operation);

// Waits until operation `name` is done, calling WaitOperation with a 1 s
// timeout (or GetOperation every 500 ms when the server does not implement
// WaitOperation or refuses another long poll), and shows progress on stderr: a bar on a terminal,
// plain lines otherwise. Returns the done operation, whether it succeeded or not; an error only
// when the server could not be asked.
absl::StatusOr<google::longrunning::Operation> WaitForOperation(RemoteContext& ctx,
                                                                const std::string& name);

// For a done operation that failed or was cancelled: prints
// "pf: renderJobs/X FAILED: <message>" to stderr and returns true.
bool ReportOperationFailure(const google::longrunning::Operation& operation);

}  // namespace pf

#endif  // POINTFORWARD_CLIENT_REMOTE_OPERATION_WAIT_H_
