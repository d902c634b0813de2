// The depth stage: measured depth per view, facades, stereo, the far layer.
#include "engine/recon/depth_stage.h"

#include <algorithm>

#include "engine/recon/facade_depth.h"
#include "engine/recon/stereo_depth.h"

namespace pf {

DepthStage MeasureViewDepths(const std::vector<ContextView>& views,
                             const std::vector<LidarSweepData>& sweeps,
                             const std::vector<InstanceTrack>& tracks,
                             const CompletionOptions& options) {
  DepthStage stage;
  const size_t n = views.size();
  stage.measured.resize(n);
  stage.sources.resize(n, MeasuredSource::kNone);
  stage.grounds.resize(n);
  std::vector<bool> completed(n, false);
  for (size_t v = 0; v < n; ++v) {
    int64_t ground = 0;
    stage.measured[v] = MeasuredDepth(views[v], sweeps, tracks, options, &stage.sources[v], &ground,
                                      &stage.grounds[v]);
    stage.ground_pixels += ground;
    stage.lidar_views += stage.sources[v] == MeasuredSource::kLidar;
    stage.sparse_map_views += stage.sources[v] == MeasuredSource::kSparseDepthMap;
    completed[v] = IsCompleted(stage.sources[v]);
  }
  if (options.facades) {
    stage.facade_pixels = ExtendFacades(views, completed, stage.grounds, &stage.measured);
  }
  if (options.stereo) {
    stage.stereo_pixels = ExtendByStereo(views, completed, &stage.measured).pixels;
    stage.upward_pixels = ExtendUpward(views, completed, &stage.measured);
  }
  return stage;
}

std::vector<ViewDepth> AddFarLayer(const std::vector<ContextView>& views, DepthStage* stage) {
  const size_t n = views.size();
  // The far layer lies beyond the scene, not beyond the ego body's depth.
  std::vector<float> max_depths(n, 0.f);
  for (size_t v = 0; v < n; ++v) {
    const ImageF& measured = stage->measured[v];
    for (size_t j = 0; j < measured.pixels.size(); ++j) {
      if (!views[v].is_ego(j)) max_depths[v] = std::max(max_depths[v], measured.pixels[j]);
    }
  }
  stage->views_without_depth =
      static_cast<int>(std::count(max_depths.begin(), max_depths.end(), 0.f));
  stage->far = FarLayerFor(views, max_depths);
  std::vector<ViewDepth> depths(n);
  for (size_t v = 0; v < n; ++v) {
    depths[v] =
        WithFarLayer(stage->measured[v], IsCompleted(stage->sources[v]), views[v], stage->far);
    stage->measured[v] = ImageF();
  }
  return depths;
}

}  // namespace pf
