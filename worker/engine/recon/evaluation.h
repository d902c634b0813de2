// `pf eval`: reconstruct a clip from its CONTEXT frames, render every TARGET
// frame at its pose and time, and measure the renders against the frames
// (image_metrics.h). Writes DIR/report.json and, per target frame, a contact
// sheet DIR/<camera>_<timestamp_us>.png (truth | render | error heat map).
//
// report.json:
//   {"model": "analytic", "gaussians": N, "reconstructSeconds": s,
//    "renderSeconds": s, "fusion": "softmax", "lifespan": true,
//    "staticGaussians": n, "dynamicGaussians": n, "farGaussians": n,
//    "instances": n, "contextViews": n, "ns": n, "nd": n,
//    "stageSeconds": {"load": s, ...},
//    "mean": {"psnr": x, "ssim": x, "depthRmse": x, "dynamicPsnr": x},
//    "frames": [{"camera": "...", "timestampUs": t, "psnr": x, "ssim": x,
//                "depthRmse": x, "dynamicPsnr": x, "dynamicPixels": n,
//                "holeFraction": x, "contactSheet": "cam_t.png"}, ...]}
// depthRmse is over pixels where the target frame has depth (frames without
// a depth map leave it out); dynamicPsnr over pixels whose ray crosses an
// instance box at the frame's time (left out where there are none);
// holeFraction is the share of pixels the render leaves (nearly) empty,
// alpha < 0.5, which show black (regions no context view saw). Means
// are over the frames that have the figure; a figure no frame has is null.
#ifndef POINTFORWARD_WORKER_ENGINE_RECON_EVALUATION_H_
#define POINTFORWARD_WORKER_ENGINE_RECON_EVALUATION_H_

#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "worker/engine/clip/clip_io.h"
#include "worker/engine/recon/reconstruction.h"

namespace pf {

struct FrameMetrics {
  std::string camera;
  int64_t timestamp_us = 0;
  double psnr = 0;
  double ssim = 0;
  std::optional<double> depth_rmse;
  std::optional<double> dynamic_psnr;
  int64_t dynamic_pixels = 0;
  double hole_fraction = 0;   // Pixels the render covers with alpha < 0.5.
  std::string contact_sheet;  // File name inside the output directory.
  double render_seconds = 0;
};

struct MeanMetrics {
  std::optional<double> psnr, ssim, depth_rmse, dynamic_psnr;
};

struct EvalReport {
  ReconOptions options;
  int64_t gaussians = 0;
  ReconStats stats;
  double render_seconds = 0;
  std::vector<FrameMetrics> frames;
  MeanMetrics mean;
};

// Returns the means of `frames` as described above.
MeanMetrics MeanOf(const std::vector<FrameMetrics>& frames);

// Returns report.json's text for `report`.
std::string EvalReportJson(const EvalReport& report);

// Evaluates `loaded` as described above, writing into `out_dir` (created).
// INVALID_ARGUMENT when the clip has no TARGET frame (or no CONTEXT frame).
absl::StatusOr<EvalReport> EvaluateClip(const LoadedClip& loaded, const ReconOptions& options,
                                        const std::string& out_dir);

}  // namespace pf

#endif  // POINTFORWARD_WORKER_ENGINE_RECON_EVALUATION_H_
