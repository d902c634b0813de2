// The engine work of pf-worker's two kinds of task, with no RPC in it: the
// caller passes a function that fetches blobs, callbacks for progress and
// for cancellation, and uploads what comes back. pf-worker wires them to
// BlobService and its heartbeats; the tests to a map of local files.
//
//   ASSIGN_OR_RETURN(ReconstructOutput out,
//                    RunReconstruction(work, fetch, attempt_dir, progress, cancelled));
//   ASSIGN_OR_RETURN(RenderChunkOutput chunk,
//                    RenderChunk(work, *scene, attempt_dir + "/out", on_frame, cancelled));
//
// Errors: INVALID_ARGUMENT naming the field of the task for bad input (a
// clip path that escapes the clip directory, an unknown model, a malformed
// view), the engine's own errors otherwise, CANCELLED when `cancelled()`
// turned true.
#ifndef POINTFORWARD_WORKER_TASK_RUNNER_H_
#define POINTFORWARD_WORKER_TASK_RUNNER_H_

#include <functional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "engine/recon/recon_options.h"
#include "engine/recon/reconstruction.h"
#include "engine/render/scene_source.h"
#include "pointforward/v1/resources.pb.h"
#include "pointforward/v1/worker.pb.h"

namespace pf {

class DeviceRenderer;

// Writes the blob with SHA-256 `sha256` (hex) to `local_path`.
using FetchBlobFn =
    std::function<absl::Status(const std::string& sha256, const std::string& local_path)>;
// Reports that the task reached `stage`, `fraction` (0..1) of the way through.
using StageProgressFn = std::function<void(const std::string& stage, double fraction)>;
// Reports how many views of a render chunk are written.
using FramesDoneFn = std::function<void(int frames_done)>;
// Returns true once the task should stop.
using CancelledFn = std::function<bool()>;

struct ReconstructOutput {
  std::string scene_path;         // The scene file written under work_dir.
  pointforward::v1::Scene scene;  // Statistics; scene_file is left to the caller.
  double seconds = 0;             // Wall time of the whole task.
};

// Fetches the clip of `work` into work_dir/clip (manifest as clip.json, each
// entry of clip.files at its path, which must stay under work_dir/clip),
// reconstructs it on `device` (the worker's --device) and writes
// work_dir/scene.pfs. Progress goes through "download", "load", the
// engine's stages and "save".
absl::StatusOr<ReconstructOutput> RunReconstruction(const pointforward::v1::ReconstructWork& work,
                                                    const FetchBlobFn& fetch,
                                                    const std::string& work_dir,
                                                    const StageProgressFn& progress,
                                                    const CancelledFn& cancelled,
                                                    const ComputeDevice& device = {});

// Fills the statistics of `scene` into a Scene message: counts, instance
// ids, the clip's time range, the bounds of the static Gaussians' means
// without the far layer, channels. `stats` gives the far-layer count;
// `views` the context cameras, whose mean centre the far layer surrounds.
pointforward::v1::Scene SceneStatistics(const GaussianScene& scene, const ReconStats& stats,
                                        const std::vector<ContextView>& views,
                                        const pointforward::v1::Clip& clip);

// One file of a render chunk.
struct RenderedFile {
  std::string name;  // "<view>.exr", "<view>.png", "<lidar>.range.exr" or "<lidar>.lidar.bin".
  std::string path;  // Where it was written.
  std::string view;  // The view's or sweep's name.
};

struct RenderChunkOutput {
  // Per view: its EXR, then its PNG; then per sweep its range EXR and
  // point record.
  std::vector<RenderedFile> files;
  std::string manifest_views_json;   // The chunk's entries of manifest.json's "views".
  std::string manifest_lidars_json;  // Those of its "lidars"; empty without sweeps.
  double seconds = 0;
};

// Renders frames [first_view, first_view + view_count) of `work` (a job's
// views, then its LiDAR sweeps) into `out_dir` exactly as `pf render` does
// (same buffers, writers, scene label), checking `cancelled()` before each
// frame; views with `renderer` (made for scene.scene, e.g. on a GPU) rather
// than the CPU rasterizer when not null, sweeps on the CPU.
// INVALID_ARGUMENT naming `outputs`, `views...` or `first_view`/`view_count`
// for bad input.
absl::StatusOr<RenderChunkOutput> RenderChunk(const pointforward::v1::RenderWork& work,
                                              const OpenedScene& scene, const std::string& out_dir,
                                              const FramesDoneFn& progress,
                                              const CancelledFn& cancelled,
                                              const DeviceRenderer* renderer = nullptr);

}  // namespace pf

#endif  // POINTFORWARD_WORKER_TASK_RUNNER_H_
