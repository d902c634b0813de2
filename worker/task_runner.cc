// The engine work of a task: materialising an uploaded clip, reconstructing
// it, rendering a chunk of views the way `pf render` does.
#include "worker/task_runner.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <utility>

#include "absl/strings/str_cat.h"
#include "common/elapsed.h"
#include "common/file_util.h"
#include "common/status_macros.h"
#include "engine/clip/clip_io.h"
#include "engine/recon/recon_options.h"
#include "engine/render/device_renderer.h"
#include "engine/render/render_outputs.h"
#include "engine/render/scene_file.h"
#include "engine/render/views.h"

namespace pf {
namespace {

namespace fs = std::filesystem;
namespace pb = ::pointforward::v1;

// The stages of a reconstruction task in order: the download, the engine's
// stages (recon_stages.h; refine only with the colour fit on, optimize only
// with optimisation steps), the save;
// Begin() reports the stage starting and the share of the work before it.
class ReconProgressReporter {
 public:
  ReconProgressReporter(const StageProgressFn& report, bool refine, bool optimize)
      : report_(report) {
    stages_.push_back({"download", 0.05});
    for (const ReconStageInfo& info : ReconStages()) {
      if (info.stage == ReconStage::kRefine && !refine) continue;
      if (info.stage == ReconStage::kOptimize && !optimize) continue;
      stages_.push_back({info.name, info.weight});
    }
    stages_.push_back({"save", 0.05});
    for (const auto& stage : stages_) total_ += stage.second;
  }

  // Reports that `stage` starts.
  void Begin(const std::string& stage) {
    double before = 0;
    for (const auto& [name, weight] : stages_) {
      if (name == stage) break;
      before += weight;
    }
    if (report_) report_(stage, before / total_);
  }

  // Reports `fraction` (0..1) of the download done.
  void Download(double fraction) {
    if (report_) report_("download", stages_[0].second * fraction / total_);
  }

  // Takes the engine's report: a stage done begins the one after it.
  void Engine(const ReconProgress& progress) {
    if (progress.kind != ReconProgress::Kind::kStageDone || !progress.stage.has_value()) return;
    const std::string finished = ReconStageName(*progress.stage);
    for (size_t i = 0; i + 1 < stages_.size(); ++i) {
      if (stages_[i].first == finished) {
        Begin(stages_[i + 1].first);
        return;
      }
    }
  }

  void Finish() {
    if (report_) report_("done", 1.0);
  }

 private:
  const StageProgressFn& report_;
  std::vector<std::pair<std::string, double>> stages_;
  double total_ = 0;
};

absl::Status CheckCancelled(const CancelledFn& cancelled, const std::string& where) {
  if (cancelled && cancelled()) return absl::CancelledError(absl::StrCat("cancelled ", where));
  return absl::OkStatus();
}

absl::Status CheckDigest(const pb::Digest& digest, const std::string& field) {
  const std::string& sha = digest.sha256();
  const bool hex = std::all_of(sha.begin(), sha.end(), [](char c) {
    return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f');
  });
  if (sha.size() != 64 || !hex) {
    return absl::InvalidArgumentError(
        absl::StrCat(field, ".sha256: not 64 lowercase hex digits: '", sha, "'"));
  }
  return absl::OkStatus();
}

// Downloads the manifest and every file of `clip` under `clip_dir`; returns
// the manifest's path.
absl::StatusOr<std::string> MaterialiseClip(const pb::UploadedClip& clip,
                                            const std::string& clip_dir, const FetchBlobFn& fetch,
                                            ReconProgressReporter& progress,
                                            const CancelledFn& cancelled) {
  RETURN_IF_ERROR(CheckDigest(clip.manifest(), "clip.manifest"));
  // Resolve every path before fetching anything.
  std::map<std::string, std::string> targets;  // Path in the manifest -> local path.
  for (const auto& [path, digest] : clip.files()) {
    const std::string field = absl::StrCat("clip.files[\"", path, "\"]");
    RETURN_IF_ERROR(CheckDigest(digest, field));
    absl::StatusOr<std::string> local = ResolvePath(clip_dir, path, PathPolicy::kUnderRootOnly);
    if (!local.ok()) return StatusWithContext(local.status(), field);
    if (*local == clip_dir || *local == clip_dir + "/clip.json") {
      return absl::InvalidArgumentError(
          absl::StrCat(field, ": names the clip directory or its manifest"));
    }
    targets[path] = *local;
  }
  RETURN_IF_ERROR(MakeDirs(clip_dir));
  const std::string manifest = clip_dir + "/clip.json";
  RETURN_IF_ERROR(StatusWithContext(fetch(clip.manifest().sha256(), manifest), "clip.manifest"));
  size_t fetched = 0;
  for (const auto& [path, local] : targets) {
    RETURN_IF_ERROR(CheckCancelled(cancelled, "while downloading the clip"));
    const std::string field = absl::StrCat("clip.files[\"", path, "\"]");
    RETURN_IF_ERROR(StatusWithContext(MakeDirs(fs::path(local).parent_path().string()), field));
    RETURN_IF_ERROR(StatusWithContext(fetch(clip.files().at(path).sha256(), local), field));
    progress.Download(double(++fetched) / double(targets.size()));
  }
  return manifest;
}

// Returns INVALID_ARGUMENT naming the first file the manifest references
// that `clip.files` lacks.
absl::Status CheckAllFilesUploaded(const pb::Clip& manifest, const pb::UploadedClip& clip) {
  for (const ClipFileRef& ref : ReferencedFiles(manifest)) {
    if (!clip.files().count(ref.path) > 0) {
      return absl::InvalidArgumentError(absl::StrCat("clip.files: the manifest's ", ref.field, " '",
                                                     ref.path, "' was not uploaded"));
    }
  }
  return absl::OkStatus();
}

}  // namespace

pb::Scene SceneStatistics(const GaussianScene& scene, const ReconStats& stats,
                          const std::vector<ContextView>& views, const pb::Clip& clip) {
  pb::Scene out;
  out.set_gaussians(static_cast<int64_t>(scene.size()));
  out.set_static_gaussians(stats.static_gaussians);
  out.set_dynamic_gaussians(stats.dynamic_gaussians);
  out.set_far_gaussians(stats.far_gaussians);
  out.set_num_channels(scene.num_channels);
  for (const InstanceTrack& track : scene.instances) out.add_instances(track.id);
  if (clip.frames_size() > 0) {
    int64_t start = std::numeric_limits<int64_t>::max();
    int64_t end = std::numeric_limits<int64_t>::min();
    for (const pb::Frame& frame : clip.frames()) {
      start = std::min(start, frame.timestamp_us());
      end = std::max(end, frame.timestamp_us());
    }
    out.set_start_time_us(start);
    out.set_end_time_us(end);
  }

  // The far layer is a sphere around the mean context camera centre, at
  // least twice as far out as any measured point (view_depth.h): its
  // Gaussians are the far_gaussians static ones farthest from that centre.
  Vec3 centre;
  for (const ContextView& view : views) centre = centre + view.world_from_camera.translation;
  if (!views.empty()) centre = centre / double(views.size());
  std::vector<std::pair<double, size_t>> by_distance;  // Static Gaussians only.
  for (size_t i = 0; i < scene.size(); ++i) {
    if (scene.owners[i] != 0) continue;
    const Vec3 mean{scene.means[3 * i], scene.means[3 * i + 1], scene.means[3 * i + 2]};
    by_distance.emplace_back(Norm(mean - centre), i);
  }
  const size_t far = std::min(by_distance.size(), static_cast<size_t>(stats.far_gaussians));
  const size_t near = by_distance.size() - far;
  std::nth_element(by_distance.begin(), by_distance.begin() + near, by_distance.end());
  if (near > 0) {
    double lo[3], hi[3];
    std::fill(lo, lo + 3, std::numeric_limits<double>::infinity());
    std::fill(hi, hi + 3, -std::numeric_limits<double>::infinity());
    for (size_t k = 0; k < near; ++k) {
      const size_t i = by_distance[k].second;
      for (int a = 0; a < 3; ++a) {
        lo[a] = std::min(lo[a], double(scene.means[3 * i + a]));
        hi[a] = std::max(hi[a], double(scene.means[3 * i + a]));
      }
    }
    for (int a = 0; a < 3; ++a) {
      out.add_bounds_min(lo[a]);
      out.add_bounds_max(hi[a]);
    }
  }
  return out;
}

absl::StatusOr<ReconstructOutput> RunReconstruction(
    const pb::ReconstructWork& work, const FetchBlobFn& fetch, const std::string& work_dir,
    const StageProgressFn& progress, const CancelledFn& cancelled, const ComputeDevice& device) {
  const auto start = std::chrono::steady_clock::now();
  if (!work.options().device().empty() && work.options().device() != "cpu") {
    return absl::InvalidArgumentError(
        absl::StrCat("options.device: '", work.options().device(),
                     "' is not available: a worker runs on the device it was started with"));
  }
  ASSIGN_OR_RETURN(ReconOptions options, ReconOptionsFromProto(work.options()));
  options.device = device;
  ReconProgressReporter stages(progress, options.refinement.iterations > 0,
                               options.optimize.steps > 0);
  options.progress = [&stages](const ReconProgress& p) { stages.Engine(p); };

  stages.Begin("download");
  const std::string clip_dir = work_dir + "/clip";
  ASSIGN_OR_RETURN(const std::string manifest,
                   MaterialiseClip(work.clip(), clip_dir, fetch, stages, cancelled));
  RETURN_IF_ERROR(CheckCancelled(cancelled, "before loading the clip"));

  stages.Begin("load");
  absl::StatusOr<LoadedClip> loaded = LoadClip(manifest);
  if (!loaded.ok()) return StatusWithContext(loaded.status(), "clip.manifest");
  RETURN_IF_ERROR(CheckAllFilesUploaded(loaded->clip, work.clip()));
  ASSIGN_OR_RETURN(ReconInputs inputs, LoadReconInputs(*loaded, options));
  RETURN_IF_ERROR(CheckCancelled(cancelled, "before reconstructing"));
  stages.Begin("depth");
  ASSIGN_OR_RETURN(const ReconResult result, ReconstructInputs(std::move(inputs), options));
  if (work.max_gaussians() > 0 &&
      static_cast<int64_t>(result.scene.size()) > work.max_gaussians()) {
    return absl::InvalidArgumentError(
        absl::StrCat("scene: ", result.scene.size(), " Gaussians exceed the limit of ",
                     work.max_gaussians(), " per scene (pf-server --max-gaussians)"));
  }
  RETURN_IF_ERROR(CheckCancelled(cancelled, "before saving the scene"));

  stages.Begin("save");
  ReconstructOutput out;
  out.scene_path = work_dir + "/scene.pfs";
  const ReconStats& s = result.stats;
  // As `pf reconstruct` writes it; the clip is named by its manifest's digest.
  const std::map<std::string, std::string> metadata =
      SceneMetadata(options, s, absl::StrCat("sha256:", work.clip().manifest().sha256()));
  RETURN_IF_ERROR(SaveScene(result.scene, out.scene_path, metadata));
  out.scene = SceneStatistics(result.scene, s, inputs.views, loaded->clip);
  out.scene.set_model(options.model);
  *out.scene.mutable_options() = work.options();
  stages.Finish();
  out.seconds = SecondsSince(start);
  return out;
}

absl::StatusOr<RenderChunkOutput> RenderChunk(const pb::RenderWork& work, const OpenedScene& opened,
                                              const std::string& out_dir,
                                              const FramesDoneFn& progress,
                                              const CancelledFn& cancelled,
                                              const DeviceRenderer* renderer) {
  const auto start = std::chrono::steady_clock::now();
  const std::vector<std::string> outputs(work.outputs().begin(), work.outputs().end());
  absl::StatusOr<OutputChannels> parsed_channels = ParseOutputChannels(outputs);
  if (!parsed_channels.ok()) return StatusWithContext(parsed_channels.status(), "outputs");
  const OutputChannels channels = *parsed_channels;
  // The server's limits on a view, before anything is allocated for one.
  RETURN_IF_ERROR(CheckRenderLimits(work.views(), channels, opened.scene.num_channels,
                                    {work.max_pixels_per_view(), work.max_render_bytes()},
                                    "views."));

  // The chunk's own frames, numbered from first_view in the job (older
  // servers sent all of the job's views).
  const pb::RenderViews& views = work.views();
  const int64_t chunk_frames = RenderItemCount(views);
  const bool whole_job = chunk_frames != work.view_count();
  if (work.first_view() < 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("first_view: must be >= 0, got ", work.first_view()));
  }
  if (work.view_count() < 1) {
    return absl::InvalidArgumentError(
        absl::StrCat("view_count: must be >= 1, got ", work.view_count()));
  }
  if (whole_job && int64_t{work.first_view()} + work.view_count() > chunk_frames) {
    return absl::InvalidArgumentError(absl::StrCat(
        "views.views: the task carries ", chunk_frames, " frames, neither the chunk's ",
        work.view_count(), " nor the job's up to frame ", work.first_view() + work.view_count()));
  }
  absl::StatusOr<RenderRequest> parsed = RenderRequestFromProto(views, InstanceIds(opened.scene));
  if (!parsed.ok()) return StatusWithContext(parsed.status(), "views");
  const RenderRequest& request = *parsed;
  const int offset = whole_job ? 0 : work.first_view();  // Job index of the carried frame 0.
  const int carried_views = static_cast<int>(request.views.size());
  RETURN_IF_ERROR(MakeDirs(out_dir));

  std::unique_ptr<DeviceRenderer> cpu;
  if (renderer == nullptr) {
    ASSIGN_OR_RETURN(cpu, DeviceRenderer::Create(&opened.scene, ComputeDevice{}, "device"));
    renderer = cpu.get();
  }
  const SceneLabel label{opened.scene_id, opened.model, opened.scene.colour_encoding};
  RenderChunkOutput out;
  std::vector<ManifestEntry> entries;
  std::vector<LidarManifestEntry> lidars;
  const int end = work.first_view() + work.view_count();
  for (int i = work.first_view(); i < end; ++i) {
    RETURN_IF_ERROR(CheckCancelled(cancelled, absl::StrCat("before frame ", i)));
    const int carried = i - offset;
    if (carried < carried_views) {
      const RenderView& view = request.views[carried];
      absl::StatusOr<ManifestEntry> entry =
          RenderViewToFiles(*renderer, view, request.edits, channels, label, out_dir);
      if (!entry.ok()) return StatusWithContext(entry.status(), absl::StrCat("views[", i, "]"));
      out.files.push_back({entry->exr, absl::StrCat(out_dir, "/", entry->exr), view.name});
      out.files.push_back({entry->png, absl::StrCat(out_dir, "/", entry->png), view.name});
      entries.push_back(*std::move(entry));
    } else {
      const LidarRenderView& lidar = request.lidars[carried - carried_views];
      absl::StatusOr<LidarManifestEntry> entry =
          RenderLidarToFiles(opened.scene, lidar, request.edits, out_dir);
      if (!entry.ok()) {
        return StatusWithContext(entry.status(), absl::StrCat("frame ", i, " (", lidar.name, ")"));
      }
      for (const std::string& file : {entry->range_exr, entry->points}) {
        out.files.push_back({file, absl::StrCat(out_dir, "/", file), lidar.name});
      }
      lidars.push_back(*std::move(entry));
    }
    if (progress) progress(i - work.first_view() + 1);
  }
  out.manifest_views_json = ManifestViewsJson(entries);
  if (!lidars.empty()) out.manifest_lidars_json = ManifestLidarsJson(lidars);
  out.seconds = SecondsSince(start);
  return out;
}

}  // namespace pf
