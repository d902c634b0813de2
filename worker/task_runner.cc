// The engine work of a task: materialising an uploaded clip, reconstructing
// it, rendering a chunk of views the way `pf render` does.
#include "worker/task_runner.h"

#include <google/protobuf/util/json_util.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <utility>

#include "absl/strings/str_cat.h"
#include "common/bounded_json.h"
#include "common/file_util.h"
#include "common/status_macros.h"
#include "nlohmann/json.hpp"
#include "worker/engine/clip/clip_io.h"
#include "worker/engine/recon/recon_flags.h"
#include "worker/engine/recon/tuning_limits.h"
#include "worker/engine/render/device_renderer.h"
#include "worker/engine/render/rasterizer.h"
#include "worker/engine/render/render_outputs.h"
#include "worker/engine/render/scene_file.h"
#include "worker/engine/render/views.h"

namespace pf {
namespace {

namespace fs = std::filesystem;
namespace pb = ::pointforward::v1;

double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// The stages of a reconstruction task in order, with their share of the
// work (roughly their share of the time on the default synth clip, where
// the colour fit takes over half; docs/QUALITY.md); Begin() reports the
// stage starting and the fraction done before it.
class ReconProgress {
 public:
  ReconProgress(const StageProgressFn& report, bool refine) : report_(report) {
    stages_ = {{"download", 0.05},    {"load", 0.05},   {"depth", 0.03}, {"lift", 0.05},
               {"scene_graph", 0.07}, {"sample", 0.07}, {"fuse", 0.05},  {"decode", 0.03}};
    if (refine) stages_.push_back({"refine", 0.55});
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

  // Takes a progress line of the engine: "<stage> done in ..." begins the
  // stage after it.
  void EngineLine(const std::string& line) {
    const size_t done = line.find(" done in ");
    if (done == std::string::npos) return;
    const std::string finished = line.substr(0, done);
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
                                            ReconProgress& progress, const CancelledFn& cancelled) {
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

absl::StatusOr<ReconOptions> ReconOptionsFromProto(const pb::ReconstructionOptions& proto) {
  ReconOptions options;
  if (!proto.model().empty()) {
    if (!ParseReconModel(proto.model()).ok()) {
      return absl::InvalidArgumentError(absl::StrCat("options.model: unknown model '",
                                                     proto.model(),
                                                     "' (expected analytic or pixel-aligned)"));
    }
    options.model = *ParseReconModel(proto.model());
  }
  if (proto.ns() < 0) {
    return absl::InvalidArgumentError(absl::StrCat(
        "options.ns: must be a positive number of queries per view, got ", proto.ns()));
  }
  if (proto.nd() < 0) {
    return absl::InvalidArgumentError(absl::StrCat(
        "options.nd: must be a positive number of queries per instance, got ", proto.nd()));
  }
  options.static_per_view = proto.ns();
  options.dynamic_per_instance = proto.nd();
  const std::string& fusion = proto.fusion();
  if (fusion.empty() || fusion == "softmax") {
    options.fusion.weights = FusionWeights::kDepthSoftmax;
  } else if (fusion == "average") {
    options.fusion.weights = FusionWeights::kPlainAverage;
  } else if (fusion == "no-depth") {
    options.fusion.weights = FusionWeights::kNoDepth;
  } else {
    return absl::InvalidArgumentError(absl::StrCat("options.fusion: unknown weighting '", fusion,
                                                   "' (expected softmax, average or no-depth)"));
  }
  if (proto.lifespan() && proto.no_lifespan()) {
    return absl::InvalidArgumentError(
        "options.lifespan: set together with options.no_lifespan; set one");
  }
  options.fusion.lifespan = proto.lifespan();
  options.completion.ground_fill = !proto.no_ground_fill();
  options.completion.facades = !proto.no_facades();
  RETURN_IF_ERROR(CheckTuningFields(proto));
  if (proto.has_refine()) options.refinement.iterations = proto.refine();
  if (proto.has_splat_sigma()) options.decoder.tangent_sigma = proto.splat_sigma();
  if (proto.has_low_pass()) options.decoder.low_pass = static_cast<float>(proto.low_pass());
  if (proto.has_hidden_band()) options.hidden_band_px = proto.hidden_band();
  if (!proto.colour().empty()) options.colour_gradients = proto.colour() == "gradients";
  if (!proto.device().empty() && proto.device() != "cpu") {
    return absl::InvalidArgumentError(
        absl::StrCat("options.device: '", proto.device(),
                     "' is not available: this build runs the analytic models on the CPU only"));
  }
  return options;
}

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
  ASSIGN_OR_RETURN(ReconOptions options, ReconOptionsFromProto(work.options()));
  options.device = device;
  ReconProgress stages(progress, options.refinement.iterations > 0);
  options.progress = [&stages](const std::string& line) { stages.EngineLine(line); };

  stages.Begin("download");
  const std::string clip_dir = work_dir + "/clip";
  ASSIGN_OR_RETURN(const std::string manifest,
                   MaterialiseClip(work.clip(), clip_dir, fetch, stages, cancelled));
  RETURN_IF_ERROR(CheckCancelled(cancelled, "before loading the clip"));

  stages.Begin("load");
  absl::StatusOr<LoadedClip> loaded = LoadClip(manifest);
  if (!loaded.ok()) return StatusWithContext(loaded.status(), "clip.manifest");
  RETURN_IF_ERROR(CheckAllFilesUploaded(loaded->clip, work.clip()));
  ASSIGN_OR_RETURN(const ReconInputs inputs, LoadReconInputs(*loaded, options));
  RETURN_IF_ERROR(CheckCancelled(cancelled, "before reconstructing"));
  stages.Begin("depth");
  ASSIGN_OR_RETURN(const ReconResult result, ReconstructInputs(inputs, options));
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
  const std::map<std::string, std::string> metadata = {
      {"model", ReconModelName(options.model)},
      {"source_clip", absl::StrCat("sha256:", work.clip().manifest().sha256())},
      {"ns", absl::StrCat(s.static_per_view)},
      {"nd", absl::StrCat(s.dynamic_per_instance)},
      {"fusion", FusionWeightsName(options.fusion.weights)},
      {"lifespan", options.fusion.lifespan ? "true" : "false"}};
  RETURN_IF_ERROR(SaveScene(result.scene, out.scene_path, metadata));
  out.scene = SceneStatistics(result.scene, s, inputs.views, loaded->clip);
  out.scene.set_model(ReconModelName(options.model));
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
                                    "views.cameras"));

  std::string json;
  const auto to_json = google::protobuf::util::MessageToJsonString(work.views(), &json);
  if (!to_json.ok()) {
    return absl::InvalidArgumentError(
        absl::StrCat("views: cannot convert to JSON: ", std::string(to_json.message())));
  }
  absl::StatusOr<RenderRequest> parsed = ParseRenderViews(json, opened.scene);
  if (!parsed.ok()) return StatusWithContext(parsed.status(), "views");
  const RenderRequest& request = *parsed;
  const int64_t num_views = static_cast<int64_t>(request.views.size());
  if (work.first_view() < 0 || work.first_view() >= num_views) {
    return absl::InvalidArgumentError(absl::StrCat(
        "first_view: ", work.first_view(), " is not a view of the job (it has ", num_views, ")"));
  }
  if (work.view_count() < 1 || work.first_view() + int64_t{work.view_count()} > num_views) {
    return absl::InvalidArgumentError(
        absl::StrCat("view_count: ", work.view_count(), " views from ", work.first_view(),
                     " do not fit in the job's ", num_views, " views"));
  }
  RETURN_IF_ERROR(MakeDirs(out_dir));

  // From here on, the same steps as client/render_command.cc.
  const SceneLabel label{opened.scene_id, opened.model, opened.scene.colour_encoding};
  RenderOptions options;
  options.features = channels.features;
  options.depth = channels.depth;
  options.instance = channels.instance;
  RenderChunkOutput out;
  std::vector<ManifestEntry> entries;
  const int end = work.first_view() + work.view_count();
  for (int i = work.first_view(); i < end; ++i) {
    RETURN_IF_ERROR(CheckCancelled(cancelled, absl::StrCat("before view ", i)));
    const RenderView& view = request.views[i];
    const auto render_start = std::chrono::steady_clock::now();
    absl::StatusOr<RenderBuffers> buffers =
        renderer != nullptr
            ? renderer->Render(view.camera, view.timestamp_us, request.edits, options)
            : Render(opened.scene, view.camera, view.timestamp_us, request.edits, options);
    if (!buffers.ok()) return StatusWithContext(buffers.status(), absl::StrCat("views[", i, "]"));
    ManifestEntry entry;
    entry.exr = view.name + ".exr";
    entry.png = view.name + ".png";
    entry.view = &view;
    entry.channels = ExrChannelNames(channels, opened.scene.num_channels);
    entry.width = buffers->width;
    entry.height = buffers->height;
    entry.render_ms = SecondsSince(render_start) * 1000.0;
    const std::string exr_path = absl::StrCat(out_dir, "/", entry.exr);
    const std::string png_path = absl::StrCat(out_dir, "/", entry.png);
    RETURN_IF_ERROR(WriteRenderExr(exr_path, *buffers, channels, view, label));
    RETURN_IF_ERROR(WritePreviewPng(png_path, *buffers, label.colour_encoding));
    out.files.push_back({entry.exr, exr_path, view.name});
    out.files.push_back({entry.png, png_path, view.name});
    entries.push_back(std::move(entry));
    if (progress) progress(i - work.first_view() + 1);
  }

  const absl::StatusOr<nlohmann::ordered_json> manifest =
      ParseBoundedJson(ManifestJson(label, entries));
  if (!manifest.ok() || !manifest->contains("views")) {
    return absl::InternalError("the render manifest is not the JSON object ManifestJson promises");
  }
  out.manifest_views_json = (*manifest)["views"].dump();
  out.seconds = SecondsSince(start);
  return out;
}

}  // namespace pf
