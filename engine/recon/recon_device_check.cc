// pf_recon_device_check: runs the whole analytic reconstruction of a `pf
// synth` clip with `--device cpu` and with each --devices entry, and prints
// one JSON object: per device the stage times of each run, the Gaussian
// counts, and how many Gaussians differ from the cpu run's.
//
//   pf_recon_device_check [--devices cpu,cuda:0] [--seed 1] [--width 768 --height 576]
//                         [--runs 1]
//
// It reads and writes no file: the clip's CONTEXT frames are rendered in
// memory as `pf synth` renders them (RenderSynthFrame), so it runs where
// OpenImageIO is missing (scripts/cuda-fusion-run.sh). Their
// colours are the renderer's floats, not the 8-bit values of the PNGs `pf
// reconstruct` reads, so the scene is close to, not the same as, that of `pf
// reconstruct` on the written clip. The options are `pf reconstruct`'s
// defaults (ReconOptions).
//
// The reference is a first run on the cpu. A Gaussian differs when one value
// of an array of GaussianScene differs by more than 1e-5 (owners: at all),
// or for its fitted colours (features 0-2 and colour gradients, which a GPU
// solves with sums in another order, colour_refinement.h) by more than 1e-2;
// "differing" gives the count per array, the largest difference, and the
// count over all arrays ("gaussians"). Exit status 0 when every device's last
// run gives the reference's Gaussians, 1 when one does not (after the JSON)
// or a run fails, 2 for a bad flag.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "common/command_line.h"
#include "common/status_macros.h"
#include "common/thread_pool.h"
#include "engine/recon/reconstruction.h"
#include "engine/synth/synth_clip_writer.h"
#include "pointforward/v1/clip.pb.h"

namespace pf {
namespace {

using Json = nlohmann::ordered_json;

constexpr double kTolerance = 1e-5;
constexpr double kColourTolerance = 1e-2;
constexpr int kColourColumns = 3;  // Of features.

// Renders the CONTEXT frames of the synth clip of `options` and decodes its
// tracks, as LoadReconInputs does for the written clip.
absl::StatusOr<ReconInputs> SynthInputs(const SynthOptions& options) {
  ASSIGN_OR_RETURN(const SynthScene scene, GenerateSynthScene(options));
  const pointforward::v1::Clip clip = BuildSynthClip(scene);
  ReconInputs inputs;
  SceneSnapshot snapshot;
  for (int f = 0; f < clip.frames_size(); ++f) {
    const pointforward::v1::Frame& frame = clip.frames(f);
    if (frame.role() != pointforward::v1::Frame::CONTEXT) continue;
    const double time_s = frame.timestamp_us() * 1e-6;
    if (snapshot.scene == nullptr || snapshot.time_s != time_s) {
      snapshot = SnapshotAt(scene, time_s);
    }
    const int camera = scene.FindCamera(frame.camera());
    RenderedView rendered = RenderSynthFrame(snapshot, camera);
    ContextView& view = inputs.views.emplace_back();
    view.frame_index = f;
    view.camera_id = frame.camera();
    view.camera = scene.cameras[camera].model;
    view.world_from_camera = scene.WorldFromCamera(camera, time_s);
    view.timestamp_us = frame.timestamp_us();
    view.rgb = std::move(rendered.rgb);
    view.depth = std::move(rendered.depth);
  }
  RETURN_IF_ERROR(SetTracksFromClip(clip, &inputs));
  return inputs;
}

// Returns how far apart two values are: 0 when equal (infinities included),
// infinity when one is not finite.
double Difference(double a, double b) {
  if (a == b) return 0;
  const double d = std::fabs(a - b);
  return std::isfinite(d) ? d : INFINITY;
}

// Compares array `a` with `b` (the same size, `n` Gaussians of equal width),
// marks the Gaussians that differ in `differs`, and returns their count and
// the largest difference.
// Its first `colour_columns` values per Gaussian are colours, compared with
// kColourTolerance; "over_1e-4" counts the values more than 1e-4 apart.
template <typename T>
Json CompareArray(const std::vector<T>& a, const std::vector<T>& b, size_t n,
                  std::vector<bool>* differs, size_t colour_columns = 0) {
  const size_t width = n == 0 ? 0 : a.size() / n;
  int64_t count = 0, over = 0;
  double max_abs = 0;
  for (size_t i = 0; i < n; ++i) {
    bool differ = false;
    for (size_t k = i * width; k < (i + 1) * width; ++k) {
      const double d = Difference(a[k], b[k]);
      max_abs = std::max(max_abs, d);
      differ |= d > (k - i * width < colour_columns ? kColourTolerance : kTolerance);
      over += d > 1e-4;
    }
    count += differ;
    if (differ) (*differs)[i] = true;
  }
  return {{"gaussians", count}, {"max_abs", max_abs}, {"over_1e-4", over}};
}

// Returns how scene `b` differs from the reference `a`.
Json CompareScenes(const GaussianScene& a, const GaussianScene& b) {
  const bool same_shape = a.size() == b.size() && a.num_channels == b.num_channels &&
                          a.colour_gradients.size() == b.colour_gradients.size();
  if (!same_shape) {
    return {{"gaussians", std::max(a.size(), b.size())},
            {"sizes", {a.size(), b.size()}},
            {"colour_gradients", {a.has_colour_gradients(), b.has_colour_gradients()}}};
  }
  const size_t n = a.size();
  std::vector<bool> differs(n, false);
  Json result = {{"gaussians", 0}};  // Over all arrays, set below.
  result["means"] = CompareArray(a.means, b.means, n, &differs);
  result["log_scales"] = CompareArray(a.log_scales, b.log_scales, n, &differs);
  result["rotations"] = CompareArray(a.rotations, b.rotations, n, &differs);
  result["opacity_logits"] = CompareArray(a.opacity_logits, b.opacity_logits, n, &differs);
  result["features"] = CompareArray(a.features, b.features, n, &differs, kColourColumns);
  result["colour_gradients"] = CompareArray(a.colour_gradients, b.colour_gradients, n, &differs, 6);
  result["times"] = CompareArray(a.times, b.times, n, &differs);
  result["lifespans"] = CompareArray(a.lifespans, b.lifespans, n, &differs);
  result["owners"] = CompareArray(a.owners, b.owners, n, &differs);
  result["gaussians"] = std::count(differs.begin(), differs.end(), true);
  return result;
}

Json StageSeconds(const ReconStats& stats) {
  Json stages;
  for (const auto& [name, seconds] : stats.stage_seconds) stages[name] = seconds;
  stages["total"] = stats.total_seconds;
  stages["colour_fit"] = {{"device", stats.colour_fit_device},
                          {"record", stats.colour_fit_record_seconds},
                          {"solve", stats.colour_fit_solve_seconds},
                          {"upload", stats.colour_fit_upload_seconds}};
  return stages;
}

Json GaussianCounts(const ReconResult& result) {
  return {{"total", result.scene.size()},
          {"static", result.stats.static_gaussians},
          {"far", result.stats.far_gaussians},
          {"dynamic", result.stats.dynamic_gaussians}};
}

// Reconstructs `inputs` on `device` `runs` times; returns the last result and
// adds each run's stage times to `entry`.
absl::StatusOr<ReconResult> ReconstructOn(const ReconInputs& inputs, const ComputeDevice& device,
                                          int runs, Json* entry) {
  ReconOptions options;
  options.device = device;
  ReconResult result;
  for (int r = 0; r < runs; ++r) {
    absl::StatusOr<ReconResult> run = ReconstructInputs(inputs, options);
    if (!run.ok()) return StatusWithContext(run.status(), device.ToString());
    result = *std::move(run);
    (*entry)["seconds"].push_back(StageSeconds(result.stats));
  }
  (*entry)["gaussians"] = GaussianCounts(result);
  return result;
}

// Runs the check; sets `*all_same` to whether every device matched the cpu.
absl::Status Run(const std::vector<std::string>& args, bool* all_same) {
  ASSIGN_OR_RETURN(CommandLine cl,
                   CommandLine::Parse(args, {"devices", "seed", "width", "height", "runs"}));
  if (!cl.positional().empty()) {
    return absl::InvalidArgumentError(
        absl::StrCat("unexpected argument '", cl.positional().front(), "'"));
  }
  SynthOptions synth;
  ASSIGN_OR_RETURN(const int64_t seed, cl.GetInt("seed", 1));
  ASSIGN_OR_RETURN(const int64_t width, cl.GetInt("width", synth.width));
  ASSIGN_OR_RETURN(const int64_t height, cl.GetInt("height", synth.height));
  ASSIGN_OR_RETURN(const int64_t runs, cl.GetInt("runs", 1));
  RETURN_IF_ERROR(cl.RequireBoth("width", "height"));
  if (seed < 0 || width < 16 || width > 8192 || height < 16 || height > 8192) {
    return absl::InvalidArgumentError(absl::StrCat(
        "--seed >= 0, --width and --height 16 to 8192; got ", seed, ", ", width, " x ", height));
  }
  if (runs < 1 || runs > 100) {
    return absl::InvalidArgumentError(absl::StrCat("--runs: 1 to 100, got ", runs));
  }
  synth.seed = static_cast<uint64_t>(seed);
  synth.width = static_cast<int>(width);
  synth.height = static_cast<int>(height);
  std::vector<ComputeDevice> devices;
  for (const std::string& name : cl.GetList("devices")) {
    ASSIGN_OR_RETURN(ComputeDevice device, ParseComputeDevice(name, "--devices"));
    RETURN_IF_ERROR(CheckComputeDevice(device, "--devices"));
    devices.push_back(device);
  }
  if (!cl.Has("devices")) devices.push_back(ComputeDevice{});

  ASSIGN_OR_RETURN(const ReconInputs inputs, SynthInputs(synth));
  Json report = {{"clip",
                  {{"seed", seed},
                   {"width", width},
                   {"height", height},
                   {"context_views", inputs.views.size()},
                   {"instances", inputs.tracks.size()}}},
                 {"backend", TensorBackendDescription()},
                 {"pool_workers", DefaultThreadPool().num_threads()},
                 {"tolerance", kTolerance},
                 {"colour_tolerance", kColourTolerance}};
  ASSIGN_OR_RETURN(const ReconResult reference,
                   ReconstructOn(inputs, ComputeDevice{}, 1, &report["reference_cpu"]));
  *all_same = true;
  for (const ComputeDevice& device : devices) {
    Json& entry = report["devices"][device.ToString()];
    ASSIGN_OR_RETURN(const ReconResult result,
                     ReconstructOn(inputs, device, static_cast<int>(runs), &entry));
    entry["differing"] = CompareScenes(reference.scene, result.scene);
    if (entry["differing"]["gaussians"] != 0) {
      *all_same = false;
      std::fprintf(stderr, "pf_recon_device_check: %s differs from the cpu\n",
                   device.ToString().c_str());
    }
  }
  std::printf("%s\n", report.dump(2).c_str());
  return absl::OkStatus();
}

}  // namespace
}  // namespace pf

int main(int argc, char** argv) {
  bool all_same = false;
  const absl::Status status = pf::Run(std::vector<std::string>(argv + 1, argv + argc), &all_same);
  if (!status.ok()) return pf::ExitStatusFor("pf_recon_device_check", status);
  return all_same ? 0 : 1;
}
