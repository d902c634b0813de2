// `pf depth-eval`: how right each CONTEXT view's dense depth is where the
// clip measured depth that the depth stage was not given. A part of every
// LiDAR sweep (and of every sparse depth map) is hidden from the depth
// stage; the rest is completed by each method; the hidden points the camera
// sees (the nearest point in their pixel, in pixels no kept point falls in)
// are the truth.
//
// Methods, each on the same kept measurements:
//   "nearest": CompleteDepth alone (each pixel the nearest measurement's
//              depth within the completion radius; view_depth.h);
//   "ipBasic": IP-Basic with its upward extension (depth_completion.h), the
//              depth of pf eval's warp baseline;
//   "ours":    the reconstruction's depth stage (depth_stage.h) with the
//              given CompletionOptions: completion, the ground plane,
//              facades. Its pixels left to the far layer count as missing.
//
//   ASSIGN_OR_RETURN(ReconInputs inputs, LoadReconInputs(loaded, options));
//   DepthHoldOutReport report = EvaluateDepthHoldOut(std::move(inputs), {}, {});
#ifndef POINTFORWARD_ENGINE_RECON_DEPTH_HOLDOUT_H_
#define POINTFORWARD_ENGINE_RECON_DEPTH_HOLDOUT_H_

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "engine/recon/depth_completion.h"
#include "engine/recon/reconstruction.h"
#include "engine/recon/view_depth.h"

namespace pf {

struct HoldOutOptions {
  // Which measurements are hidden: kHalf, a random half (a fixed seed, so a
  // run is reproducible); kTop, the highest `top_share` of them by elevation
  // (LiDAR: the angle above the sensor's level plane; a sparse depth map: of
  // its pixels' rays above the camera's level plane), the region where
  // facades continue what the top beams measured.
  enum class Mode { kHalf, kTop };
  Mode mode = Mode::kHalf;
  double top_share = 0.25;
};

// Parses --hide: "half" or "top". INVALID_ARGUMENT naming --hide otherwise.
absl::StatusOr<HoldOutOptions::Mode> ParseHoldOutMode(const std::string& name);
const char* HoldOutModeName(HoldOutOptions::Mode mode);

// Splits `sweep`'s points by `options`: `kept` gets the points the depth
// stage sees, `hidden` the rest (each with the sweep's time and pose).
void HoldOutSweep(const LidarSweepData& sweep, const HoldOutOptions& options, LidarSweepData* kept,
                  LidarSweepData* hidden);

// The same for a sparse depth map of `view` (0 unknown): `kept` and
// `hidden` are maps of its size.
void HoldOutDepthMap(const ContextView& view, const ImageF& sparse, const HoldOutOptions& options,
                     ImageF* kept, ImageF* hidden);

// Sums of one method's errors; DepthErrors (depth_completion.h) as means.
struct DepthErrorSums {
  int64_t points = 0, missing = 0;
  double abs_rel = 0, squared = 0, within_5pct = 0;
  void Add(const DepthErrors& e);
  DepthErrors Mean() const;
};

struct DepthHoldOutMethod {
  std::string name;
  DepthErrorSums all;     // Over every hidden point it could have covered.
  DepthErrorSums common;  // Over the hidden points every method has a depth at.
};

struct DepthHoldOutReport {
  HoldOutOptions options;
  int views = 0;                            // Views with a hidden point in sight.
  int64_t hidden_points = 0;                // Hidden points in sight, over all views.
  int64_t kept_measurements = 0;            // Pixels the kept measurements mark, over all views.
  std::vector<DepthHoldOutMethod> methods;  // nearest, ipBasic, ours.
  int64_t facade_pixels = 0;                // Set by "ours"' facades.
  int64_t stereo_pixels = 0;                // Set by "ours"' plane sweep.
  int64_t upward_pixels = 0;                // Set by "ours"' depth below continued up.
  int64_t enclosed_pixels = 0;              // Set by "ours"' fill of enclosed gaps.
  int64_t ground_pixels = 0;                // Set by "ours"' ground fill.
  double seconds = 0;
};

// Hides measurements of `inputs` by `options`, runs every method on the
// rest and measures them at the hidden points in sight; ego pixels are left
// out. FAILED_PRECONDITION when no view has a LiDAR sweep or a sparse depth
// map to hide from.
absl::StatusOr<DepthHoldOutReport> EvaluateDepthHoldOut(ReconInputs inputs,
                                                        const CompletionOptions& completion,
                                                        const HoldOutOptions& options);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RECON_DEPTH_HOLDOUT_H_
