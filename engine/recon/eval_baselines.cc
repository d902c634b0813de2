// The nearest-frame and forward-warp baselines of `pf eval`.
#include "engine/recon/eval_baselines.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <limits>
#include <string>
#include <tuple>

#include "common/status_macros.h"
#include "common/thread_pool.h"
#include "engine/recon/depth_completion.h"
#include "pointforward/v1/clip.pb.h"

namespace pf {
namespace {

using pointforward::v1::Clip;
using pointforward::v1::Frame;

// Sweeps this much further in time than the nearest one still count as
// "nearest" (a rig's LiDARs firing together).
constexpr int64_t kSweepTieUs = 10000;
// The warp baseline's CONTEXT frames per target.
constexpr int kWarpFrames = 2;
// Splats within this relative depth of a pixel's nearest one are blended.
constexpr float kSameSurface = 0.03f;

bool IsContext(const Frame& frame) { return frame.role() != Frame::TARGET; }

Vec3 CameraCentre(const Frame& frame) {
  if (frame.world_from_camera_size() != 16) return {};
  return Rigid::FromRowMajor(frame.world_from_camera().data()).translation;
}

// Returns `image` resized to `width` x `height` by nearest pixel.
ImageF ResizeNearest(const ImageF& image, int width, int height) {
  if (image.width == width && image.height == height) return image;
  ImageF out(width, height, image.channels);
  for (int y = 0; y < height; ++y) {
    const int sy = std::min(image.height - 1, static_cast<int>((y + 0.5) * image.height / height));
    for (int x = 0; x < width; ++x) {
      const int sx = std::min(image.width - 1, static_cast<int>((x + 0.5) * image.width / width));
      for (int c = 0; c < image.channels; ++c) out.at(x, y, c) = image.at(sx, sy, c);
    }
  }
  return out;
}

}  // namespace

std::vector<int> NearestContextFrames(const Clip& clip, int target, int count) {
  const Frame& t = clip.frames(target);
  const Vec3 centre = CameraCentre(t);
  bool same_camera = false;
  for (const Frame& frame : clip.frames()) {
    same_camera |= IsContext(frame) && frame.camera() == t.camera();
  }
  // (time gap, camera distance, time, index), smallest first.
  std::vector<std::tuple<int64_t, double, int64_t, int>> candidates;
  for (int f = 0; f < clip.frames_size(); ++f) {
    const Frame& frame = clip.frames(f);
    if (!IsContext(frame) || (same_camera && frame.camera() != t.camera())) continue;
    const double distance = same_camera ? 0.0 : Norm(CameraCentre(frame) - centre);
    candidates.emplace_back(std::abs(frame.timestamp_us() - t.timestamp_us()), distance,
                            frame.timestamp_us(), f);
  }
  std::sort(candidates.begin(), candidates.end());
  std::vector<int> frames;
  for (size_t i = 0; i < candidates.size() && static_cast<int>(i) < count; ++i) {
    frames.push_back(std::get<3>(candidates[i]));
  }
  return frames;
}

ImageF WarpSourceDepth(const ContextView& view, const std::vector<LidarSweepData>& sweeps) {
  if (view.depth.width > 0) {
    return IsSparseDepth(view.depth) ? CompleteDepthIpBasic(view.depth) : view.depth;
  }
  return CompleteDepthIpBasic(SweepDepth(view, sweeps));
}

ImageF SweepDepth(const ContextView& view, const std::vector<LidarSweepData>& sweeps) {
  const int nearest = NearestSweep(sweeps, view.timestamp_us);
  if (nearest < 0) return ImageF(view.width(), view.height(), 1);
  const int64_t gap = std::abs(sweeps[nearest].timestamp_us - view.timestamp_us);
  ImageF sparse(view.width(), view.height(), 1);
  for (const LidarSweepData& sweep : sweeps) {
    if (std::abs(sweep.timestamp_us - view.timestamp_us) > gap + kSweepTieUs) continue;
    const ImageF projected = ProjectPoints(sweep.points, view.lines());
    for (size_t i = 0; i < sparse.pixels.size(); ++i) {
      const float d = projected.pixels[i];
      if (d > 0.f && (sparse.pixels[i] == 0.f || d < sparse.pixels[i])) sparse.pixels[i] = d;
    }
  }
  return sparse;
}

WarpedView ForwardWarp(const ContextView& source, const ImageF& depth, const CameraModel& camera,
                       const Rigid& world_from_camera) {
  const int sw = source.width(), sh = source.height();
  const int tw = camera.width(), th = camera.height();
  const size_t source_pixels = static_cast<size_t>(sw) * sh;
  const size_t target_pixels = static_cast<size_t>(tw) * th;
  const Rigid target_from_source = world_from_camera.Inverse() * source.world_from_camera;
  constexpr float kInfinity = std::numeric_limits<float>::infinity();

  // Where each source pixel lands: (u, v) in the target, its z there
  // (infinity for pixels without depth); u NaN when it does not land.
  std::vector<float> land_u(source_pixels, std::numeric_limits<float>::quiet_NaN());
  std::vector<float> land_v(source_pixels), land_z(source_pixels);
  DefaultThreadPool().ParallelFor(0, sh, 8, [&](int64_t y0, int64_t y1) {
    for (int64_t y = y0; y < y1; ++y) {
      for (int x = 0; x < sw; ++x) {
        const size_t i = static_cast<size_t>(y) * sw + x;
        if (source.is_ego(i)) continue;
        Vec3 ray;
        if (!source.camera.Unproject(x + 0.5, y + 0.5, &ray)) continue;
        const float d = depth.pixels[i];
        Vec3 p;
        float z;
        if (d > 0.f && std::isfinite(d)) {
          p = target_from_source * (double(d) * ray);
          z = static_cast<float>(p.z);
        } else {
          p = target_from_source.rotation * ray;
          z = kInfinity;
        }
        double u, v;
        if (!camera.Project(p, &u, &v)) continue;
        if (!(u > -1.0 && v > -1.0 && u < tw + 1.0 && v < th + 1.0)) continue;
        land_u[i] = static_cast<float>(u);
        land_v[i] = static_cast<float>(v);
        land_z[i] = z;
      }
    }
  });

  // Calls splat(target pixel, bilinear weight, source pixel, whether the
  // source pixel lands inside it) for the 2x2 target pixels around where each
  // source pixel lands.
  auto for_each_splat = [&](auto splat) {
    for (size_t i = 0; i < source_pixels; ++i) {
      if (std::isnan(land_u[i])) continue;
      const float gx = land_u[i] - 0.5f, gy = land_v[i] - 0.5f;
      const int x0 = static_cast<int>(std::floor(gx)), y0 = static_cast<int>(std::floor(gy));
      const float fx = gx - x0, fy = gy - y0;
      for (int dy = 0; dy < 2; ++dy) {
        const int y = y0 + dy;
        if (y < 0 || y >= th) continue;
        for (int dx = 0; dx < 2; ++dx) {
          const int x = x0 + dx;
          if (x < 0 || x >= tw) continue;
          const float w = (dx ? fx : 1.f - fx) * (dy ? fy : 1.f - fy);
          const bool inside = dx == (fx >= 0.5f) && dy == (fy >= 0.5f);
          if (w > 0.f) splat(static_cast<size_t>(y) * tw + x, w, i, inside);
        }
      }
    }
  };
  // The z-buffer: the nearest surface landing inside each pixel, else (a
  // crack) the nearest whose footprint reaches it; so a surface does not
  // spread a pixel over what lies behind its edge. Then the blend of the
  // splats on that surface.
  std::vector<float> nearest(target_pixels, kInfinity), nearest_inside(target_pixels, kInfinity);
  std::vector<uint8_t> landed_inside(target_pixels, 0);
  WarpedView out;
  out.covered.assign(target_pixels, 0);
  for_each_splat([&](size_t t, float, size_t i, bool inside) {
    nearest[t] = std::min(nearest[t], land_z[i]);
    out.covered[t] = 1;
    if (!inside) return;
    nearest_inside[t] = std::min(nearest_inside[t], land_z[i]);
    landed_inside[t] = 1;
  });
  for (size_t t = 0; t < target_pixels; ++t) {
    if (landed_inside[t]) nearest[t] = nearest_inside[t];
  }
  std::vector<float> weights(target_pixels, 0.f), depth_sum(target_pixels, 0.f);
  out.rgb = ImageF(tw, th, 3);
  for_each_splat([&](size_t t, float w, size_t i, bool) {
    const float z = land_z[i];
    if (!(z <= nearest[t] * (1.f + kSameSurface) && z * (1.f + kSameSurface) >= nearest[t])) {
      return;
    }
    weights[t] += w;
    for (int c = 0; c < 3; ++c) out.rgb.pixels[3 * t + c] += w * source.rgb.pixels[3 * i + c];
    if (land_z[i] < kInfinity) depth_sum[t] += w * land_z[i];
  });
  out.depth = ImageF(tw, th, 1);
  for (size_t t = 0; t < target_pixels; ++t) {
    if (weights[t] <= 0.f) continue;
    for (int c = 0; c < 3; ++c) out.rgb.pixels[3 * t + c] /= weights[t];
    if (nearest[t] < kInfinity) out.depth.pixels[t] = depth_sum[t] / weights[t];
  }
  return out;
}

WarpedView CombineWarps(const std::vector<WarpedView>& warps) {
  WarpedView out = warps.front();
  const int w = out.rgb.width, h = out.rgb.height;
  const size_t pixels = out.covered.size();
  for (size_t k = 1; k < warps.size(); ++k) {
    for (size_t i = 0; i < pixels; ++i) {
      if (out.covered[i] || !warps[k].covered[i]) continue;
      out.covered[i] = 1;
      for (int c = 0; c < 3; ++c) out.rgb.pixels[3 * i + c] = warps[k].rgb.pixels[3 * i + c];
      out.depth.pixels[i] = warps[k].depth.pixels[i];
    }
  }
  // Breadth-first from every covered pixel: each other pixel takes the
  // colour and depth of the covered pixel its search came from.
  std::vector<int32_t> from(pixels, -1);
  std::vector<int32_t> queue;
  queue.reserve(pixels);
  for (size_t i = 0; i < pixels; ++i) {
    if (!out.covered[i]) continue;
    from[i] = static_cast<int32_t>(i);
    queue.push_back(static_cast<int32_t>(i));
  }
  for (size_t q = 0; q < queue.size(); ++q) {
    const int32_t i = queue[q];
    const int x = i % w, y = i / w;
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const int nx = x + dx, ny = y + dy;
        if (nx < 0 || ny < 0 || nx >= w || ny >= h) continue;
        const int32_t n = ny * w + nx;
        if (from[n] >= 0) continue;
        from[n] = from[i];
        queue.push_back(n);
      }
  }
  for (size_t i = 0; i < pixels; ++i) {
    if (out.covered[i] || from[i] < 0) continue;
    for (int c = 0; c < 3; ++c) out.rgb.pixels[3 * i + c] = out.rgb.pixels[3 * from[i] + c];
    out.depth.pixels[i] = out.depth.pixels[from[i]];
  }
  return out;
}

EvalBaselines::EvalBaselines(const LoadedClip& loaded, const LoadViewsOptions& options)
    : loaded_(loaded), options_(options) {
  for (int f = 0; f < loaded.clip.frames_size(); ++f) {
    if (loaded.clip.frames(f).role() != Frame::TARGET) continue;
    for (int source : NearestContextFrames(loaded.clip, f, kWarpFrames)) last_target_[source] = f;
  }
}

absl::StatusOr<const EvalBaselines::Source*> EvalBaselines::SourceFor(int frame) {
  auto found = sources_.find(frame);
  if (found != sources_.end()) return &found->second;
  ASSIGN_OR_RETURN(std::vector<ContextView> views, LoadFrames(loaded_, {frame}, options_));
  Source source;
  source.view = std::move(views.front());
  if (source.view.depth.width == 0) {
    ASSIGN_OR_RETURN(const std::vector<LidarSweepData>* sweeps, Sweeps());
    source.depth = WarpSourceDepth(source.view, *sweeps);
  } else {
    source.depth = WarpSourceDepth(source.view, {});
  }
  return &sources_.emplace(frame, std::move(source)).first->second;
}

absl::StatusOr<const std::vector<LidarSweepData>*> EvalBaselines::Sweeps() {
  if (!sweeps_.has_value()) {
    if (loaded_.clip.lidar_size() == 0) {
      sweeps_.emplace();
    } else {
      ASSIGN_OR_RETURN(sweeps_, LoadLidarSweeps(loaded_, options_.allow_outside_paths));
    }
  }
  return &*sweeps_;
}

absl::StatusOr<FrameBaselines> EvalBaselines::Make(const ContextView& target) {
  FrameBaselines b;
  const std::vector<int> frames =
      NearestContextFrames(loaded_.clip, target.frame_index, kWarpFrames);
  if (frames.empty()) {
    return absl::InvalidArgumentError("frames: the clip has no CONTEXT frame for the baselines");
  }
  const int w = target.width(), h = target.height();
  std::vector<WarpedView> warps;
  for (int frame : frames) {
    ASSIGN_OR_RETURN(const Source* source, SourceFor(frame));
    if (b.nearest_frames.empty()) {
      b.nearest_frames = {frame};
      b.nearest_rgb = ResizeNearest(source->view.rgb, w, h);
      if (source->view.depth.width == w && source->view.depth.height == h) {
        b.nearest_depth = source->view.depth;
      }
    }
    warps.push_back(
        ForwardWarp(source->view, source->depth, target.camera, target.world_from_camera));
    b.warp_frames.push_back(frame);
  }
  b.warp = CombineWarps(warps);
  if (loaded_.clip.lidar_size() > 0) {
    ASSIGN_OR_RETURN(const std::vector<LidarSweepData>* sweeps, Sweeps());
    b.target_lidar = SweepDepth(target, *sweeps);
  }
  for (auto it = sources_.begin(); it != sources_.end();) {
    const auto last = last_target_.find(it->first);
    const bool needed = last != last_target_.end() && last->second > target.frame_index;
    it = needed ? std::next(it) : sources_.erase(it);
  }
  return b;
}

}  // namespace pf
