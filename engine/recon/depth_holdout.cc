// Dense depth measured at hidden LiDAR points / depth-map pixels.
#include "engine/recon/depth_holdout.h"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "common/elapsed.h"
#include "engine/recon/depth_stage.h"

namespace pf {
namespace {

// A fixed hash of a measurement's index: which half it falls in.
bool InHiddenHalf(uint64_t index) {
  uint64_t z = index + 0x9e3779b97f4a7c15ULL;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return ((z ^ (z >> 31)) & 1) != 0;
}

// The elevation above which the top `share` of `elevations` lie.
double TopThreshold(std::vector<double> elevations, double share) {
  if (elevations.empty()) return 0;
  const size_t k = std::min(
      elevations.size() - 1,
      static_cast<size_t>(std::floor((1.0 - std::clamp(share, 0.0, 1.0)) * elevations.size())));
  std::nth_element(elevations.begin(), elevations.begin() + k, elevations.end());
  return elevations[k];
}

}  // namespace

absl::StatusOr<HoldOutOptions::Mode> ParseHoldOutMode(const std::string& name) {
  if (name == "half") return HoldOutOptions::Mode::kHalf;
  if (name == "top") return HoldOutOptions::Mode::kTop;
  return absl::InvalidArgumentError(
      absl::StrCat("--hide: unknown '", name, "' (expected half or top)"));
}

const char* HoldOutModeName(HoldOutOptions::Mode mode) {
  return mode == HoldOutOptions::Mode::kHalf ? "half" : "top";
}

void HoldOutSweep(const LidarSweepData& sweep, const HoldOutOptions& options, LidarSweepData* kept,
                  LidarSweepData* hidden) {
  *kept = sweep;
  *hidden = sweep;
  kept->points.clear();
  hidden->points.clear();
  kept->intensities.clear();
  hidden->intensities.clear();
  const size_t n = sweep.points.size() / 3;
  const bool with_intensity = sweep.intensities.size() == n;
  std::vector<double> elevations;
  double threshold = 0;
  if (options.mode == HoldOutOptions::Mode::kTop) {
    elevations.resize(n);
    for (size_t i = 0; i < n; ++i) {
      const Vec3 d = Vec3{sweep.points[3 * i], sweep.points[3 * i + 1], sweep.points[3 * i + 2]} -
                     sweep.sensor_origin;
      const double r = Norm(d);
      elevations[i] = r > 0 ? Dot(d, sweep.sensor_up) / r : 0.0;
    }
    threshold = TopThreshold(elevations, options.top_share);
  }
  for (size_t i = 0; i < n; ++i) {
    const bool hide =
        options.mode == HoldOutOptions::Mode::kHalf ? InHiddenHalf(i) : elevations[i] > threshold;
    LidarSweepData& to = hide ? *hidden : *kept;
    to.points.insert(to.points.end(), sweep.points.begin() + 3 * i,
                     sweep.points.begin() + 3 * i + 3);
    if (with_intensity) to.intensities.push_back(sweep.intensities[i]);
  }
}

void HoldOutDepthMap(const ContextView& view, const ImageF& sparse, const HoldOutOptions& options,
                     ImageF* kept, ImageF* hidden) {
  *kept = KnownDepthOnly(sparse);
  *hidden = ImageF(sparse.width, sparse.height, 1);
  // The known pixels, and with kTop the elevation of each one's ray above
  // the camera's level plane (image up is camera -y).
  std::vector<size_t> known;
  for (size_t i = 0; i < kept->pixels.size(); ++i)
    if (kept->pixels[i] > 0.f) known.push_back(i);
  std::vector<double> elevations;
  double threshold = 0;
  if (options.mode == HoldOutOptions::Mode::kTop) {
    elevations.resize(known.size(), 0.0);
    for (size_t k = 0; k < known.size(); ++k) {
      Vec3 ray;
      const size_t x = known[k] % sparse.width, y = known[k] / sparse.width;
      if (view.camera.Unproject(x + 0.5, y + 0.5, &ray)) elevations[k] = -ray.y / Norm(ray);
    }
    threshold = TopThreshold(elevations, options.top_share);
  }
  for (size_t k = 0; k < known.size(); ++k) {
    const size_t i = known[k];
    const bool hide =
        options.mode == HoldOutOptions::Mode::kHalf ? InHiddenHalf(i) : elevations[k] > threshold;
    if (!hide) continue;
    hidden->pixels[i] = kept->pixels[i];
    kept->pixels[i] = 0.f;
  }
}

void DepthErrorSums::Add(const DepthErrors& e) {
  points += e.points;
  missing += e.missing;
  abs_rel += e.abs_rel * e.points;
  squared += e.rmse * e.rmse * e.points;
  within_5pct += e.within_5pct * e.points;
}

DepthErrors DepthErrorSums::Mean() const {
  DepthErrors e;
  e.points = points;
  e.missing = missing;
  if (points > 0) {
    e.abs_rel = abs_rel / points;
    e.rmse = std::sqrt(squared / points);
    e.within_5pct = within_5pct / points;
  }
  return e;
}

absl::StatusOr<DepthHoldOutReport> EvaluateDepthHoldOut(ReconInputs inputs,
                                                        const CompletionOptions& completion,
                                                        const HoldOutOptions& options) {
  const auto start = std::chrono::steady_clock::now();
  DepthHoldOutReport report;
  report.options = options;
  const size_t num_sweeps = inputs.sweeps.size();
  std::vector<LidarSweepData> kept(num_sweeps), hidden(num_sweeps);
  for (size_t s = 0; s < num_sweeps; ++s)
    HoldOutSweep(inputs.sweeps[s], options, &kept[s], &hidden[s]);

  // The truth (hidden measurements in sight) and the kept measurements per view.
  const size_t n = inputs.views.size();
  std::vector<ImageF> truth(n), sparse(n);
  for (size_t v = 0; v < n; ++v) {
    ContextView& view = inputs.views[v];
    if (view.depth.width > 0) {
      if (!IsSparseDepth(view.depth)) continue;
      HoldOutDepthMap(view, view.depth, options, &sparse[v], &truth[v]);
      view.depth = sparse[v];
    } else {
      const int s = NearestSweep(inputs.sweeps, view.timestamp_us);
      if (s < 0) continue;
      const auto project = [&](const LidarSweepData& sweep) {
        return ProjectPoints(PointsAtTime(sweep, inputs.tracks, view.timestamp_us), view.lines());
      };
      const ImageF all = project(inputs.sweeps[s]);
      truth[v] = project(hidden[s]);
      sparse[v] = project(kept[s]);
      // A pixel whose nearest point was kept does not see the hidden one; a
      // pixel a kept point also falls in is measured, not hidden.
      for (size_t i = 0; i < all.pixels.size(); ++i) {
        if (truth[v].pixels[i] != all.pixels[i] || sparse[v].pixels[i] > 0.f)
          truth[v].pixels[i] = 0.f;
      }
    }
    int64_t in_sight = 0;
    for (size_t i = 0; i < truth[v].pixels.size(); ++i) {
      if (view.is_ego(i)) truth[v].pixels[i] = 0.f;
      in_sight += truth[v].pixels[i] > 0.f;
    }
    for (float d : sparse[v].pixels) report.kept_measurements += d > 0.f;
    report.hidden_points += in_sight;
    report.views += in_sight > 0;
  }
  if (report.hidden_points == 0) {
    return absl::FailedPreconditionError(
        "the clip's CONTEXT views have no LiDAR point and no sparse depth map pixel in sight to "
        "hide from the depth stage; pf depth-eval measures dense depth against them");
  }

  DepthStage ours = MeasureViewDepths(inputs.views, kept, inputs.tracks, completion);
  report.facade_pixels = ours.facade_pixels;
  report.stereo_pixels = ours.stereo_pixels;
  report.upward_pixels = ours.upward_pixels;
  report.enclosed_pixels = ours.enclosed_pixels;
  report.ground_pixels = ours.ground_pixels;
  report.methods = {{"nearest", {}, {}}, {"ipBasic", {}, {}}, {"ours", {}, {}}};
  for (size_t v = 0; v < n; ++v) {
    if (truth[v].width == 0) continue;
    const ImageF& visible = truth[v];
    const ImageF dense[3] = {CompleteDepth(sparse[v]), CompleteDepthIpBasic(sparse[v]),
                             std::move(ours.measured[v])};
    ImageF common = visible;
    for (size_t i = 0; i < common.pixels.size(); ++i) {
      for (const ImageF& d : dense)
        if (!(d.pixels[i] > 0.f)) common.pixels[i] = 0.f;
    }
    for (int m = 0; m < 3; ++m) {
      report.methods[m].all.Add(MeasureDepthCompletion(dense[m], visible));
      report.methods[m].common.Add(MeasureDepthCompletion(dense[m], common));
    }
  }
  report.seconds = SecondsSince(start);
  return report;
}

}  // namespace pf
