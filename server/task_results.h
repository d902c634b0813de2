// What a worker may hand back for a task, checked against the task before
// the server stores it, and read back from the store without trusting it:
// a bad or compromised worker must not be able to name files outside a
// job's views, leave a view without its EXR or PNG, or store a result that
// makes the job unreadable later.
//
//   RETURN_IF_ERROR(CheckRenderResult(result, RenderChunkViewNames(views, 4, 2)));
//   ASSIGN_OR_RETURN(nlohmann::ordered_json views, ParseManifestViews(stored, 2));
//
// Errors are INVALID_ARGUMENT naming the field of CompleteTaskRequest at
// fault ("render.files[2].name: ...").
#ifndef POINTFORWARD_SERVER_TASK_RESULTS_H_
#define POINTFORWARD_SERVER_TASK_RESULTS_H_

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "pointforward/v1/resources.pb.h"
#include "pointforward/v1/views.pb.h"
#include "pointforward/v1/worker.pb.h"

namespace pf {

// Largest manifest_views_json per view of a chunk (an entry is about 1 KB).
inline constexpr int64_t kMaxManifestBytesPerView = 64 << 10;

// The output names (file stems) of views [first_view, first_view +
// view_count) of `views`, as the worker names its files; INVALID_ARGUMENT
// when the range is not inside `views`.
absl::StatusOr<std::vector<std::string>> RenderChunkViewNames(
    const pointforward::v1::RenderViews& views, int first_view, int view_count);

// What a render chunk carries of its job's `views`: views [first_view,
// first_view + view_count), every camera and every edit. INVALID_ARGUMENT
// when the range is not inside `views`.
absl::StatusOr<pointforward::v1::RenderViews> RenderChunkViews(
    const pointforward::v1::RenderViews& views, int first_view, int view_count);

// Parses a chunk's manifest_views_json (bounded: nesting, and
// kMaxManifestBytesPerView per view): a JSON array of `view_count` objects.
// INVALID_ARGUMENT saying what is wrong otherwise.
absl::StatusOr<nlohmann::ordered_json> ParseManifestViews(const std::string& json, int view_count);

// Checks a render chunk's result against the names of its views: exactly
// "<view>.exr" and "<view>.png" for each view (with `view` set to it), each
// with a well-formed digest (64 lowercase hex digits, size not negative),
// nothing else; manifest_views_json one entry per view, in order, whose
// "name", "exr" and "png" are the view's. Whether the blobs were uploaded
// is the caller's to check.
absl::Status CheckRenderResult(const pointforward::v1::RenderResult& result,
                               const std::vector<std::string>& view_names);

// Checks the statistics a reconstruction's result carries: counts not
// negative, instance ids 1 to 1024 characters and at most
// 100000 of them, bounds 3 finite numbers each (or none), a scene_file digest
// well-formed. Names, state and options are the server's and ignored.
absl::Status CheckReconstructResult(const pointforward::v1::ReconstructResult& result);

}  // namespace pf

#endif  // POINTFORWARD_SERVER_TASK_RESULTS_H_
