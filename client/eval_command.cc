// pf eval CLIP.json --out DIR [reconstruction flags]
//         [--views VIEWS.json --truth TRUTH_DIR]
//         [--lane-shift D1,D2,... --lane-shift-time-us T]
// Reconstructs from the clip's CONTEXT frames, renders every TARGET frame
// and any extra views, and writes DIR/report.json and a contact sheet per
// frame and view (engine/recon/evaluation.h). A lane shift builds its
// views itself and, for a `pf synth` clip, ray-casts their truth in-process
// (DIR/lane_shift/views.json, DIR/lane_shift/truth/). Progress to stderr;
// the mean figures to stdout.
#include <google/protobuf/util/json_util.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "client/commands.h"
#include "common/command_line.h"
#include "common/file_util.h"
#include "common/status_macros.h"
#include "engine/clip/clip_io.h"
#include "engine/clip/clip_validator.h"
#include "engine/recon/context_views.h"
#include "engine/recon/evaluation.h"
#include "engine/recon/recon_option_table.h"
#include "engine/recon/recon_options.h"
#include "engine/render/views.h"
#include "engine/synth/synth_view_renderer.h"

namespace pf {
namespace {

constexpr char kEvalUsage[] =
    "usage: pf eval CLIP.json --out DIR [--model analytic|pixel-aligned] [--ns N --nd N] "
    "[--fusion softmax|average|no-depth] [--lifespan] [--refine N] [--splat-sigma S] "
    "[--low-pass PX2] [--order-band B] [--fade-frames F] [--hidden-band PX] "
    "[--colour-fit-memory GB] [--no-ground-fill] [--no-facades] [--no-stereo] [--no-ego-layer] "
    "[--render-blur PX] [--render-blur-growth G] [--still-rig-density F] "
    "[--device cpu|cuda[:N]] [--optimize-steps N [--optimize-seconds S] [--optimize-poses] "
    "[--optimize-densify]] "
    "[--allow-outside-paths] [--views VIEWS.json --truth TRUTH_DIR] "
    "[--lane-shift D1,D2,... --lane-shift-time-us T] (pf eval --help for more)";

constexpr char kHelp[] = R"(usage: pf eval CLIP.json --out DIR [reconstruction flags]
               [--views VIEWS.json --truth TRUTH_DIR]
               [--lane-shift D1,D2,... --lane-shift-time-us T]

Reconstructs the clip from its CONTEXT frames, renders every TARGET frame at its
pose and time, compares it with the frame, and writes DIR/report.json ("mean",
"frames") and a contact sheet DIR/<camera>_<timestamp_us>.png per frame
(truth | render | error heat map). "psnr" measures the render composited over
black, as the rgb layer of pf render is, clamped to [0, 1] as its PNG preview
shows it (the truth is a PNG or JPEG); "psnrUnclamped" the raw float render;
"filledPsnr" the render composited over a push-pull fill of itself, as the
"filled" layer is (pixels the scene does not cover take the colour around
them); "holeFraction" is the share of pixels with alpha < 0.5. SSIM and
dynamicPsnr are of the clamped render too. Every colour figure compares
sRGB-encoded images ("metricsColour": "srgb"), whatever the working space.
Where the clip has LiDAR, "lidarAbsRel" is the mean |depth - LiDAR| / LiDAR
over the target time's own LiDAR points that the image has depth at, and
"lidarCoverage" the share of those points it has depth at.

Every TARGET frame is also measured against two baselines made from the clip
alone, reported beside ours ("baselines" in report.json and in each frame):
"nearest", the same camera's CONTEXT image nearest in time, unchanged; "warp",
the two nearest forward-warped into the target with the clip's depth maps or
LiDAR (completed by IP-Basic), holes filled from the other frame, then from
the nearest pixel. Moving actors are warped as if they stood still.

The ego vehicle's body, where the reconstruction finds one in a camera's
CONTEXT frames (the scene's ego layer; --no-ego-layer: none), is drawn over
every render of that camera, as the frames show it; "egoBody" in report.json
gives each such camera's share of pixels on the body. Pixels of a camera's
own ego mask (Camera.egoMask) are left out of every figure.

reconstruction flags (as pf reconstruct):
  --model analytic|pixel-aligned  --ns N --nd N  --fusion softmax|average|no-depth
  --lifespan  --refine N  --splat-sigma S  --low-pass PX2  --order-band B  --fade-frames F  --hidden-band PX
  --colour-fit-memory GB (the colour fit's memory bound, fixed; default 2 GB raised to half
                       of the memory free when the fit starts; report.json "colourFitBoundGB")
  --no-ground-fill  --no-facades  --no-stereo  --no-ego-layer  --render-blur PX  --render-blur-growth G  --still-rig-density F  --colour gradients|flat  --working-space srgb|linear
  --completion nearest|ip-basic
  --optimize-steps N  --optimize-seconds S  --optimize-poses  --optimize-densify
                       (per-scene optimisation; report.json's "optimize": loss, context
                       PSNR per step, with --optimize-poses each context view's pose
                       correction, with --optimize-densify the Gaussians split and pruned)
  --device cpu|cuda[:N]  --allow-outside-paths

extra views (views not in the clip, e.g. extrapolated poses):
  --views VIEWS.json   a RenderViews file, as pf render --cameras and
                       pf synth render --cameras take; every view is rendered
                       after the TARGET frames (actor edits applied)
  --truth TRUTH_DIR    the truth of each view: TRUTH_DIR/<name>.png (colour,
                       required; the view's size) and TRUTH_DIR/<name>.exr (depth,
                       optional), as `pf synth render --clip CLIP_DIR --cameras
                       VIEWS.json --out TRUTH_DIR` writes them
  report.json gains "views" ([{"name", "camera", "timestampUs", "psnr", "psnrUnclamped", "ssim",
  "depthRmse", "dynamicPsnr", "filledPsnr", "holeFraction", "contactSheet"}]) and
  "viewsMean";
  the contact sheets go to DIR/views/<name>.png. A clip without TARGET frames is
  measured on its extra views alone.

lane shift (extrapolation sideways, one command):
  --lane-shift D1,D2,...    shifts in metres along the ego's left (negative: to
                            the right); 0 is always added. Each camera's pose at
                            T (interpolated between its nearest frames), moved by
                            each shift, is a view <camera>_shift<D>m. The left is
                            up x the rig's direction of travel at T, up being
                            minus the mean of the cameras' image-down axes
  --lane-shift-time-us T    the time of the shifted views (required with
                            --lane-shift; within every camera's frames)
  The views are written to DIR/lane_shift/views.json. Their truth is ray-cast
  from the clip's synthetic scene (CLIP_DIR/synth.json, a pf synth clip) into
  DIR/lane_shift/truth/; for other clips render the truth yourself and pass
  --views/--truth. report.json gains the views (each with "shiftM"), "laneShift"
  ([{"shiftM", "views", "psnr", "ssim", "depthRmse", "dynamicPsnr",
  "holeFraction", "filledPsnr"}], sorted by shift), "laneShiftDrop" ({"fromM": 0, "toM": the
  largest |shift|, "psnr", "ssim": figure at 0 minus figure there}),
  "laneShiftTimeUs" and "laneShiftLeft" (the unit shift direction, world).

example:
  pf synth --out /tmp/s1
  pf eval /tmp/s1/clip.json --out /tmp/e1 --lane-shift 1,2,3 --lane-shift-time-us 800000
)";

// Returns the views file at `path`, its edits checked against the clip's
// instances.
absl::StatusOr<RenderRequest> LoadViewsForClip(const std::string& path, const LoadedClip& loaded) {
  GaussianScene instances_only;
  ASSIGN_OR_RETURN(instances_only.instances, TracksFromClip(loaded.clip));
  return LoadRenderViews(path, instances_only);
}

std::string Figure(const std::optional<double>& value, const char* unit) {
  return value.has_value() ? absl::StrCat(absl::SixDigits(*value), unit) : "n/a";
}

// Returns the shifts of --lane-shift.
absl::StatusOr<std::vector<double>> ParseShifts(const CommandLine& cl) {
  std::vector<double> shifts;
  for (const std::string& item : cl.GetList("lane-shift")) {
    double shift = 0;
    if (!absl::SimpleAtod(item, &shift)) {
      return absl::InvalidArgumentError(
          absl::StrCat("--lane-shift: '", item, "' is not a number of metres"));
    }
    shifts.push_back(shift);
  }
  if (shifts.empty()) {
    return absl::InvalidArgumentError("--lane-shift: expected shifts in metres, e.g. 1,2,3");
  }
  return shifts;
}

// Builds the lane-shift views of `loaded` into `out_dir`/lane_shift/ and,
// for a synth clip, their truth; returns them as extra views.
absl::StatusOr<ExtraViews> PrepareLaneShift(const CommandLine& cl, const LoadedClip& loaded,
                                            const std::string& out_dir) {
  ASSIGN_OR_RETURN(const std::vector<double> shifts, ParseShifts(cl));
  if (!cl.Has("lane-shift-time-us")) {
    return absl::InvalidArgumentError(
        "--lane-shift-time-us: required with --lane-shift (the time of the shifted views)");
  }
  ASSIGN_OR_RETURN(const int64_t time_us, cl.GetInt("lane-shift-time-us", 0));
  ASSIGN_OR_RETURN(const LaneShift lane_shift, MakeLaneShift(loaded.clip, shifts, time_us));

  ExtraViews extra;
  const std::string dir = absl::StrCat(out_dir, "/lane_shift");
  const std::string views_path = absl::StrCat(dir, "/views.json");
  extra.truth_dir = absl::StrCat(dir, "/truth");
  extra.lane_shift = lane_shift.spec;
  std::string json;
  google::protobuf::util::JsonPrintOptions print;
  print.add_whitespace = true;
  const auto printed = google::protobuf::util::MessageToJsonString(lane_shift.views, &json, print);
  if (!printed.ok()) return absl::InternalError(absl::StrCat("views.json: ", printed.ToString()));
  RETURN_IF_ERROR(MakeDirs(dir));
  RETURN_IF_ERROR(WriteFileAtomic(views_path, json));
  ASSIGN_OR_RETURN(extra.request, LoadViewsForClip(views_path, loaded));

  const std::string params = absl::StrCat(loaded.dir, "/synth.json");
  if (!std::filesystem::exists(params)) {
    return absl::FailedPreconditionError(absl::StrCat(
        "--lane-shift: ", loaded.dir, " is not a pf synth clip (no ", params,
        "), so there is no truth for the shifted views; render their truth yourself and pass "
        "--views VIEWS.json --truth TRUTH_DIR (the shifted views are in ",
        views_path, ")"));
  }
  std::fprintf(stderr, "pf eval: ray-casting the truth of %d lane-shift views into %s\n",
               lane_shift.views.views_size(), extra.truth_dir.c_str());
  RETURN_IF_ERROR(RenderSynthViews(loaded.dir, views_path, extra.truth_dir).status());
  return extra;
}

absl::Status EvalCommand(const CommandLine& cl) {
  if (cl.positional().size() != 1) return absl::InvalidArgumentError(kEvalUsage);
  RETURN_IF_ERROR(cl.Require({"out"}, kEvalUsage));
  if (cl.Has("views") != cl.Has("truth")) {
    return absl::InvalidArgumentError(cl.Has("views")
                                          ? "--truth: required with --views (the truth images)"
                                          : "--views: required with --truth (the views file)");
  }
  if (cl.Has("lane-shift") && cl.Has("views")) {
    return absl::InvalidArgumentError(
        "--lane-shift: cannot be combined with --views (run them as two evals)");
  }
  if (cl.Has("lane-shift-time-us") && !cl.Has("lane-shift")) {
    return absl::InvalidArgumentError("--lane-shift-time-us: only with --lane-shift");
  }
  ASSIGN_OR_RETURN(ReconOptions options, ReconOptionsFromFlags(cl));
  options.progress = [](const ReconProgress& progress) {
    std::fprintf(stderr, "pf eval: %s\n", ProgressLine(progress).c_str());
  };
  const std::string out_dir = cl.Get("out");
  RETURN_IF_ERROR(CheckOutputDirPath("--out", out_dir));
  ValidateOptions validate;
  validate.allow_outside_paths = options.allow_outside_paths;
  ASSIGN_OR_RETURN(const LoadedClip loaded, LoadValidClip(cl.positional()[0], validate));
  std::optional<ExtraViews> extra;
  if (cl.Has("views")) {
    ASSIGN_OR_RETURN(RenderRequest request, LoadViewsForClip(cl.Get("views"), loaded));
    extra = ExtraViews{std::move(request), cl.Get("truth"), std::nullopt};
  } else if (cl.Has("lane-shift")) {
    ASSIGN_OR_RETURN(extra, PrepareLaneShift(cl, loaded, out_dir));
  }
  ASSIGN_OR_RETURN(const EvalReport report, EvaluateClip(loaded, options, out_dir, extra));
  // "x (nearest a, warp b)": ours beside the baselines.
  auto beside = [&](const std::optional<double>& ours, const std::optional<double>& nearest,
                    const std::optional<double>& warp, const char* unit) {
    if (report.nearest.empty()) return Figure(ours, unit);
    return absl::StrCat(Figure(ours, unit), " (nearest ", Figure(nearest, ""), ", warp ",
                        Figure(warp, ""), ")");
  };
  std::printf(
      "%s: %lld gaussians, reconstruct %.2f s, %zu target frames and %zu views rendered in "
      "%.2f s, baselines %.2f s\n"
      "  mean PSNR %s (unclamped %s), SSIM %s, depth RMSE %s, dynamic PSNR %s, filled PSNR %s\n",
      options.model.c_str(), static_cast<long long>(report.gaussians), report.stats.total_seconds,
      report.frames.size(), report.views.size(), report.render_seconds, report.baseline_seconds,
      beside(report.mean.psnr, report.nearest_mean.psnr, report.warp_mean.psnr, " dB").c_str(),
      Figure(report.mean.psnr_unclamped, " dB").c_str(),
      beside(report.mean.ssim, report.nearest_mean.ssim, report.warp_mean.ssim, "").c_str(),
      Figure(report.mean.depth_rmse, " m").c_str(), Figure(report.mean.dynamic_psnr, " dB").c_str(),
      Figure(report.mean.filled_psnr, " dB").c_str());
  if (!report.views.empty()) {
    std::printf("  views: mean PSNR %s, SSIM %s, depth RMSE %s\n",
                Figure(report.views_mean.psnr, " dB").c_str(),
                Figure(report.views_mean.ssim, "").c_str(),
                Figure(report.views_mean.depth_rmse, " m").c_str());
  }
  for (const LaneShiftMetrics& shift : report.lane_shift_means) {
    std::printf("  lane shift %s m (%d views): PSNR %s, SSIM %s\n",
                absl::StrCat(shift.shift_m).c_str(), shift.views,
                Figure(shift.mean.psnr, " dB").c_str(), Figure(shift.mean.ssim, "").c_str());
  }
  if (!report.lidar_render.empty()) {
    const LidarSweepFigures mean = MeanLidarFigures(report.lidar_render);
    std::printf(
        "  LiDAR rendered at %zu TARGET times: Chamfer %.3f m, range error median %.3f m "
        "(90th percentile %.3f m; %.1f %% early, %.1f %% late by over max(0.5 m, 5 %%)), "
        "%.1f %% of the recorded returns returned\n",
        report.lidar_render.size(), mean.chamfer, mean.range_error_median, mean.range_error_p90,
        100 * mean.early_share, 100 * mean.late_share, 100 * mean.hit_share);
    if (mean.intensity_rays > 0) {
      std::printf(
          "    intensity: median error %.3g over %lld returns on the recorded surface (the best "
          "constant's %.3g)\n",
          mean.intensity_error_median, static_cast<long long>(mean.intensity_rays),
          mean.intensity_constant_error_median);
    }
    if (mean.cells > 0) {
      std::printf(
          "    drops: the render agrees with the LiDAR on %.1f %% of %lld seen (beam, azimuth) "
          "cells (recorded %.1f %% drops, rendered %.1f %%)\n",
          100 * mean.drop_agreement, static_cast<long long>(mean.cells),
          100 * mean.recorded_drop_share, 100 * mean.rendered_drop_share);
    }
    if (!mean.beams.empty()) {
      const auto [best, worst] = std::minmax_element(
          mean.beams.begin(), mean.beams.end(),
          [](const auto& a, const auto& b) { return a.range_error_median < b.range_error_median; });
      std::printf(
          "    per beam (%zu, report.json perBeam): range error median from %.3f m (%.2f deg) "
          "to %.3f m (%.2f deg; 90th percentile %.3f m)\n",
          mean.beams.size(), best->range_error_median, best->elevation_deg,
          worst->range_error_median, worst->elevation_deg, worst->range_error_p90);
    }
  }
  std::printf("  report: %s/report.json\n", out_dir.c_str());
  return absl::OkStatus();
}

}  // namespace

int RunEval(const std::vector<std::string>& args) {
  std::set<std::string> value_flags = ReconValueFlags();
  value_flags.insert({"out", "views", "truth", "lane-shift", "lane-shift-time-us"});
  std::set<std::string> bool_flags = ReconSwitchFlags();
  bool_flags.insert({"help", "allow-outside-paths"});
  absl::StatusOr<CommandLine> cl = CommandLine::Parse(args, value_flags, bool_flags);
  if (!cl.ok()) return ReportError("eval", cl.status());
  if (cl->Has("help")) {
    std::fputs(kHelp, stdout);
    return kExitOk;
  }
  const absl::Status status = EvalCommand(*cl);
  return status.ok() ? kExitOk : ReportError("eval", status);
}

}  // namespace pf
