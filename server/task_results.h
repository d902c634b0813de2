// What a worker may hand back for a task, checked against the task before
// the server stores it, and read back from the store without trusting it:
// a bad or compromised worker must not be able to name files outside a
// job's views and sweeps, leave one without its files, or store a result
// that makes the job unreadable later.
//
// A render job's frames are its views, then its LiDAR sweeps
// (RenderItemCount); a chunk is a range of them.
//
//   ASSIGN_OR_RETURN(RenderChunkNames names, ChunkOutputNames(views, 4, 2));
//   RETURN_IF_ERROR(CheckRenderResult(result, names));
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

// The output names (file stems) of a chunk's views and sweeps, as the
// worker names its files.
struct RenderChunkNames {
  std::vector<std::string> views;   // <view>.exr, <view>.png
  std::vector<std::string> lidars;  // <lidar>.range.exr, <lidar>.lidar.bin
};

// The names of frames [first, first + count) of `views`; INVALID_ARGUMENT
// when the range is not inside the job's frames.
absl::StatusOr<RenderChunkNames> ChunkOutputNames(const pointforward::v1::RenderViews& views,
                                                  int first, int count);

// What a render chunk carries of its job's `views`: the views and sweeps of
// frames [first, first + count), every camera and every edit.
// INVALID_ARGUMENT when the range is not inside the job's frames.
absl::StatusOr<pointforward::v1::RenderViews> RenderChunkViews(
    const pointforward::v1::RenderViews& views, int first, int count);

// Parses a chunk's manifest_views_json or manifest_lidars_json (bounded:
// nesting, and kMaxManifestBytesPerView per entry): a JSON array of `count`
// objects. INVALID_ARGUMENT saying what is wrong otherwise.
absl::StatusOr<nlohmann::ordered_json> ParseManifestViews(const std::string& json, int count);

// Checks a render chunk's result against the names of its views and sweeps:
// exactly "<view>.exr" and "<view>.png" for each view, "<lidar>.range.exr"
// and "<lidar>.lidar.bin" for each sweep (with `view` set to its name),
// each with a well-formed digest (64 lowercase hex digits, size not
// negative), nothing else; manifest_views_json one entry per view, in
// order, whose "name", "exr" and "png" are the view's; manifest_lidars_json
// (empty when there are no sweeps) one entry per sweep whose "name",
// "rangeExr" and "points" are the sweep's. Whether the blobs were uploaded
// is the caller's to check.
absl::Status CheckRenderResult(const pointforward::v1::RenderResult& result,
                               const RenderChunkNames& names);

// Checks the statistics a reconstruction's result carries: counts not
// negative, instance ids 1 to 1024 characters and at most
// 100000 of them, bounds 3 finite numbers each (or none), a scene_file digest
// well-formed. Names, state and options are the server's and ignored.
absl::Status CheckReconstructResult(const pointforward::v1::ReconstructResult& result);

}  // namespace pf

#endif  // POINTFORWARD_SERVER_TASK_RESULTS_H_
