// Normalising the names a user types for jobs and scenes into the resource
// names of the API: "operations/{job_id}" and "scenes/{scene_id}".
//
//   ASSIGN_OR_RETURN(std::string op, OperationNameFor("renderJobs/r42"));  // "operations/r42"
#ifndef POINTFORWARD_CLIENT_REMOTE_RESOURCE_NAMES_H_
#define POINTFORWARD_CLIENT_REMOTE_RESOURCE_NAMES_H_

#include <string>

#include "absl/status/statusor.h"

namespace pf {

// Returns the operation name of job `id`, which may be "operations/X",
// "renderJobs/X" or a bare "X". A scene name, an empty id or one with more
// path segments is INVALID_ARGUMENT saying what was expected.
absl::StatusOr<std::string> OperationNameFor(const std::string& id);

// Returns the scene name of `id` ("scenes/X" or a bare "X"); anything else is
// INVALID_ARGUMENT, and so is a bare X that is a file here (a local scene
// given to a remote command: the message says to run without --server).
absl::StatusOr<std::string> SceneNameFor(const std::string& id);

}  // namespace pf

#endif  // POINTFORWARD_CLIENT_REMOTE_RESOURCE_NAMES_H_
