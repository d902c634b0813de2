// `pf eval`: reconstruct a clip from its CONTEXT frames, render every TARGET
// frame at its pose and time, and measure the renders against the frames
// (image_metrics.h). Writes DIR/report.json and, per target frame, a contact
// sheet DIR/<camera>_<timestamp_us>.png (truth | render | error heat map).
//
// report.json:
//   {"model": "analytic", "gaussians": N, "reconstructSeconds": s,
//    "renderSeconds": s, "fusion": "softmax", "lifespan": true,
//    "lidarViews": n, "sparseDepthMapViews": n (CONTEXT views whose depth
//    was completed from LiDAR / from a sparse depth map, view_depth.h),
//    "groundFill": true, "groundPixels": n (completed views' pixels set from
//    the ground plane), "facades": true, "facadePixels": n (set from
//    facades above the highest measurements, facade_depth.h),
//    "staticGaussians": n, "dynamicGaussians": n, "farGaussians": n,
//    "instances": n, "contextViews": n, "ns": n, "nd": n,
//    "workingSpace": "srgb"|"linear", "metricsColour": "srgb",
//    "stageSeconds": {"load": s, ...},
//    "mean": {"psnr": x, "ssim": x, "depthRmse": x, "lidarAbsRel": x,
//             "lidarCoverage": x, "dynamicPsnr": x, ...},
//    "baselines": {"nearest": {...}, "warp": {...}}, "baselineSeconds": s,
//    "frames": [{"camera": "...", "timestampUs": t, "psnr": x, "ssim": x,
//                "depthRmse": x, "lidarAbsRel": x, "lidarCoverage": x,
//                "dynamicPsnr": x, "dynamicPixels": n,
//                "holeFraction": x, "renderBlur": px, "contactSheet": "cam_t.png",
//                "baselines": {"nearest": {"psnr": x, ..., "holeFraction": x,
//                                          "frames": [{"camera": "...",
//                                                      "timestampUs": t}]},
//                              "warp": {...}}}, ...]}
// Colour figures compare the sRGB-encoded [0, 1] images whatever the working
// space the colours were blended in. depthRmse is over pixels where the target
// frame has depth (frames without a depth map leave it out); lidarAbsRel is
// the mean |depth - z| / z over the target time's own LiDAR points where the
// render has depth, lidarCoverage the share of those points it has depth at
// (null without LiDAR); dynamicPsnr over pixels whose ray crosses the box
// of an instance that moves (MovingTracks, scene_graph.h) at the frame's
// time (left out where there are none);
// holeFraction is the share of pixels the render leaves (nearly) empty,
// alpha < 0.5, which show black (regions no context view saw); renderBlur
// the blur the frame's render got (render_blur.h RenderBlurAt; the top-level
// "renderBlur" and "renderBlurGrowth" are the scene's). Means
// are over the frames that have the figure; a figure no frame has is null.
// A camera with an ego mask (Camera.ego_mask) has its masked pixels left
// out of every figure of its frames (SSIM: the windows centred on them;
// holeFraction is over the other pixels) and their count as "egoPixels".
//
// Baselines (eval_baselines.h), measured on every TARGET frame as the
// render is (the same figures, the ego mask honoured): "nearest", the
// CONTEXT image of the frame's camera nearest in time, unchanged; "warp", the
// two nearest forward-warped with the clip's depth (depth maps, else LiDAR,
// completed by IP-Basic), nothing of the reconstruction; moving actors are
// warped where the context frame saw them. Each frame's
// "baselines" has their figures and the CONTEXT "frames" they used (the warp's
// nearer first); the top-level "baselines" their means, with the keys of
// "mean". Their depthRmse is over pixels where both the frame and the
// baseline have depth (nearest: the context frame's own depth map, else
// null); holeFraction is the share of pixels neither warp reached (filled from
// the nearest one reached; nearest: 0); filledPsnr equals psnr (they are
// opaque). baselineSeconds: the time spent making and measuring them. The
// summary line of `pf eval` names them beside ours: "mean PSNR x dB
// (nearest y, warp z)", and the same for SSIM.
//
// Extra views (`pf eval --views VIEWS.json --truth DIR`, ExtraViews below):
// after the TARGET frames, every view of a RenderViews file (what
// `pf render --cameras` and `pf synth render --cameras` take; actor edits
// applied) is rendered and compared with DIR/<name>.png (colour, required)
// and DIR/<name>.exr (depth along z, first channel, optional), the files
// `pf synth render` writes, <name> being the view's output name as
// `pf render` spells it. report.json then also has
//    "views": [{"name": "...", "camera": "...", "timestampUs": t, "psnr": x,
//               "ssim": x, "depthRmse": x, "dynamicPsnr": x,
//               "holeFraction": x, "contactSheet": "views/<name>.png"}, ...],
//    "viewsMean": {"psnr": x, "ssim": x, "depthRmse": x, "dynamicPsnr": x,
//                  "holeFraction": x}
// with the contact sheets in DIR/views/ (dynamicPsnr is left out when the
// file has actor edits: the boxes would be the unedited ones). With a lane
// shift (`--lane-shift`, LaneShiftSpec below) each view also has "shiftM",
// and report.json has
//    "laneShift": [{"shiftM": 0, "views": n, "psnr": x, "ssim": x,
//                   "depthRmse": x, "dynamicPsnr": x, "holeFraction": x}, ...],
//    "laneShiftDrop": {"fromM": 0, "toM": d, "psnr": x, "ssim": x},
//    "laneShiftTimeUs": t, "laneShiftLeft": [x, y, z]
// laneShift is sorted by shift; the drop is the first entry's figure minus
// the largest |shift|'s (positive: the shifted views are worse).
//
// Rendered LiDAR (lidar_eval.h): for the sweep nearest each TARGET time,
// unless it is the sweep nearest a CONTEXT frame (which the depth stage
// read), the scene is rendered along the rays of the sweep's points that a
// CONTEXT camera had in its image, from the sweep's sensor at the sweep's
// time (render/lidar_render.h), and report.json has
//    "lidarRender": {"sweeps": n, "points": n, "hitShare": x,
//                    "rangeErrorMedian": m, "rangeErrorP90": m,
//                    "earlyShare": x, "lateShare": x, "chamfer": m,
//                    "seconds": s (loading, rendering, measuring),
//                    "renderSeconds": s (RenderLidarRays alone),
//                    "cells": n, "recordedDropShare": x,
//                    "renderedDropShare": x, "dropAgreement": x,
//                    "perBeam": [{"elevationDeg": d, "points": n,
//                                 "hitShare": x, "rangeErrorMedian": m,
//                                 "rangeErrorP90": m}, ...],
//                    "perSweep": [{"timestampUs": t, "sweepPoints": n,
//                                  "points": n, "hitShare": x, ...,
//                                  "beamsNote": "..."}, ...]}
// (null without such a sweep): the means over the sweeps of the share of the
// recorded returns the render returns too, the median and 90th percentile
// of |rendered - recorded| range over those, the shares of those returned
// early and late (LidarSweepFigures), and the Chamfer distance (the
// mean of both directions' mean nearest-point distances, each capped at
// 5 m). Where a sweep is one spinning head's (SweepBeams) it also has the
// figures per beam and the drops (cells, ...; both left out otherwise, and
// beamsNote says why). The summary lines of `pf eval` give them.
#ifndef POINTFORWARD_ENGINE_RECON_EVALUATION_H_
#define POINTFORWARD_ENGINE_RECON_EVALUATION_H_

#include <cstdint>
#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "common/geometry.h"
#include "engine/clip/clip_io.h"
#include "engine/recon/lidar_eval.h"
#include "engine/recon/reconstruction.h"
#include "engine/render/views.h"
#include "pointforward/v1/views.pb.h"

namespace pf {

// The figures of one TARGET frame or one extra view.
struct FrameMetrics {
  std::string name;  // Extra views: the view's output name; empty for TARGET frames.
  std::string camera;
  int64_t timestamp_us = 0;
  double psnr = 0;            // Of the render clamped to [0, 1], as its PNG shows it.
  double psnr_unclamped = 0;  // Of the raw float render.
  double ssim = 0;
  std::optional<double> depth_rmse;
  // Mean |depth - LiDAR| / LiDAR over the target's own LiDAR points
  // (eval_baselines.h SweepDepth) where the image has depth; lidarCoverage:
  // the share of those points where it has. Unset without LiDAR.
  std::optional<double> lidar_abs_rel, lidar_coverage;
  std::optional<double> dynamic_psnr;
  int64_t dynamic_pixels = 0;
  double hole_fraction = 0;  // Pixels the render covers with alpha < 0.5.
  // Pixels on the ego vehicle's body (Camera.ego_mask), left out of every
  // figure; holeFraction is over the others.
  int64_t ego_pixels = 0;
  // PSNR of the render composited over its push-pull fill (render/hole_fill.h,
  // the `filled` EXR layer) instead of over black.
  double filled_psnr = 0;
  std::string contact_sheet;  // File name inside the output directory.
  double render_seconds = 0;
  double render_blur = 0;         // The render's blur, pixels (render_blur.h RenderBlurAt).
  std::optional<double> shift_m;  // Lane-shift views: the sideways shift in metres.
  // Baselines: the CONTEXT frames they were made from.
  struct Source {
    std::string camera;
    int64_t timestamp_us = 0;
  };
  std::vector<Source> sources;
};

struct MeanMetrics {
  std::optional<double> psnr, psnr_unclamped, ssim, depth_rmse, lidar_abs_rel, lidar_coverage,
      dynamic_psnr, hole_fraction, filled_psnr;
};

// The views a lane shift made: each camera's pose at `time_us` moved
// sideways along `left` (unit, world) by each shift.
struct LaneShiftSpec {
  int64_t time_us = 0;
  Vec3 left;
  std::map<std::string, double> shift_of_view;  // View name -> shift in metres.
};

// Extra views to render and measure after the TARGET frames.
struct ExtraViews {
  // The views file, parsed (LoadRenderViews against a scene holding the
  // clip's instance tracks, TracksFromClip).
  RenderRequest request;
  std::string truth_dir;  // <name>.png, optionally <name>.exr, per view.
  std::optional<LaneShiftSpec> lane_shift;
};

// The means of the lane-shift views with one shift.
struct LaneShiftMetrics {
  double shift_m = 0;
  int views = 0;
  MeanMetrics mean;
};

struct EvalReport {
  ReconOptions options;
  int64_t gaussians = 0;
  ReconStats stats;
  double render_seconds = 0;
  std::vector<FrameMetrics> frames;
  MeanMetrics mean;
  // The baselines of each TARGET frame, in the order of `frames`, and their
  // means.
  std::vector<FrameMetrics> nearest, warp;
  MeanMetrics nearest_mean, warp_mean;
  double baseline_seconds = 0;
  std::vector<FrameMetrics> views;  // Extra views; empty without ExtraViews.
  MeanMetrics views_mean;
  std::optional<LaneShiftSpec> lane_shift;
  std::vector<LaneShiftMetrics> lane_shift_means;  // Sorted by shift.
  // The LiDAR the scene renders at the held-out sweeps nearest the TARGET
  // times, in time order (lidar_eval.h), and the time it took.
  std::vector<LidarSweepFigures> lidar_render;
  double lidar_render_seconds = 0;
};

// Returns the means of `frames` as described above.
MeanMetrics MeanOf(const std::vector<FrameMetrics>& frames);

// Returns the means of the lane-shift views of `views` (those with a
// shift_m), one entry per shift, sorted by shift.
std::vector<LaneShiftMetrics> LaneShiftMeans(const std::vector<FrameMetrics>& views);

// A lane shift's RenderViews message and what the report says of it.
struct LaneShift {
  pointforward::v1::RenderViews views;
  LaneShiftSpec spec;
};

// Returns the views of a lane shift of the clip: for each camera of `clip`
// (in order) and each of `shifts_m` (0 added first when missing), a view
// "<camera>_shift<d>m" at `time_us` whose pose is the camera's pose at that
// time (interpolated between its two nearest frames of any role; exact at a
// frame) with `d` metres added along the ego's left. The ego's left is
// up x forward: up is minus the mean of the cameras' image-down (y) axes,
// forward the direction the cameras travel around `time_us` (the mean
// displacement between the frames that bracket it), or the mean viewing
// direction when they do not move. The clip's cameras are copied into the
// message, so `pf render` and `pf synth render` both take it.
// INVALID_ARGUMENT naming the flag (`--lane-shift`, `--lane-shift-time-us`)
// for a non-finite, duplicate or over-100 m shift, or a time outside a
// camera's frames; a camera with no frame is skipped.
absl::StatusOr<LaneShift> MakeLaneShift(const pointforward::v1::Clip& clip,
                                        const std::vector<double>& shifts_m, int64_t time_us);

// Returns report.json's text for `report`.
std::string EvalReportJson(const EvalReport& report);

// Evaluates `loaded` as described above, writing into `out_dir` (created),
// and the extra views when `extra` is given. INVALID_ARGUMENT when the clip
// has no TARGET frame and no extra views (a clip without TARGET frames can
// still be measured on extra views: "frames" is then empty and the figures
// of "mean" null), no CONTEXT frame, or a truth image's size is not its view's;
// NOT_FOUND naming the view and the path looked for when a view has no
// truth image. The truth files are checked before the reconstruction starts.
absl::StatusOr<EvalReport> EvaluateClip(const LoadedClip& loaded, const ReconOptions& options,
                                        const std::string& out_dir,
                                        const std::optional<ExtraViews>& extra = std::nullopt);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RECON_EVALUATION_H_
