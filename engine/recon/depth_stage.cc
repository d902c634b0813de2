// The depth stage: measured depth per view, facades, stereo, the far layer.
#include "engine/recon/depth_stage.h"

#include <algorithm>
#include <cstdlib>

#include "common/thread_pool.h"
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
    stage.enclosed_pixels = FillEnclosedGaps(views, completed, &stage.measured);
  }
  return stage;
}

int64_t FillEnclosedGaps(const std::vector<ContextView>& views, const std::vector<bool>& extend,
                         std::vector<ImageF>* measured, int max_gap_px) {
  int64_t total = 0;
  for (size_t v = 0; v < views.size(); ++v) {
    if (!extend[v]) continue;
    ImageF& depth = (*measured)[v];
    const int w = depth.width, h = depth.height;
    // The deepest of the nearest known depths each way (0 where a way has
    // none within reach), the horizontal ways first.
    std::vector<float> deepest(size_t(w) * h, 0.f);
    std::vector<uint8_t> ways(size_t(w) * h, 0);
    // Along each row, both ways.
    DefaultThreadPool().ParallelFor(0, h, 16, [&](int64_t y0, int64_t y1) {
      for (int64_t y = y0; y < y1; ++y) {
        for (int direction = 0; direction < 2; ++direction) {
          float last = 0.f;
          int last_at = -1;
          for (int k = 0; k < w; ++k) {
            const int x = direction == 0 ? k : w - 1 - k;
            const size_t j = size_t(y) * w + x;
            if (depth.pixels[j] > 0.f) {
              last = depth.pixels[j];
              last_at = x;
            } else if (last_at >= 0 && std::abs(x - last_at) <= max_gap_px) {
              deepest[j] = std::max(deepest[j], last);
              ++ways[j];
            }
          }
        }
      }
    });
    // Along each column, both ways: rows in memory order, a block of
    // columns per task with the last known depth of each.
    constexpr int kColumns = 64;
    DefaultThreadPool().ParallelFor(
        0, (w + kColumns - 1) / kColumns, 1, [&](int64_t b0, int64_t b1) {
          float last[kColumns];
          int last_at[kColumns];
          for (int64_t block = b0; block < b1; ++block) {
            const int x0 = int(block) * kColumns, x1 = std::min(w, x0 + kColumns);
            for (int direction = 0; direction < 2; ++direction) {
              std::fill(last, last + kColumns, 0.f);
              std::fill(last_at, last_at + kColumns, -1);
              for (int k = 0; k < h; ++k) {
                const int y = direction == 0 ? k : h - 1 - k;
                const size_t row = size_t(y) * w;
                for (int x = x0; x < x1; ++x) {
                  const size_t j = row + x;
                  const int c = x - x0;
                  if (depth.pixels[j] > 0.f) {
                    last[c] = depth.pixels[j];
                    last_at[c] = y;
                  } else if (last_at[c] >= 0 && std::abs(y - last_at[c]) <= max_gap_px) {
                    deepest[j] = std::max(deepest[j], last[c]);
                    ++ways[j];
                  }
                }
              }
            }
          }
        });
    int64_t set = 0;
    for (size_t j = 0; j < deepest.size(); ++j) {
      if (ways[j] == 4 && !views[v].is_ego(j)) {
        depth.pixels[j] = deepest[j];
        ++set;
      }
    }
    total += set;
  }
  return total;
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
