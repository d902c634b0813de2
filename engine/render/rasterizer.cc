// Tile-based EWA splatting on the CPU.
//
// The passes (ParallelFor on DefaultThreadPool() over fixed chunks, so the
// result never depends on thread timing):
//  1. Project: per Gaussian, time-faded opacity, pose (instances moved from
//     canonical space), camera-frame mean, 2D covariance J W Sigma W^T J^T +
//     s I (s = GaussianScene::low_pass), conic, opacity-aware extent (the Mahalanobis radius where
//     alpha drops to 1/255), colour.
//  2. Sort the visible Gaussians by depth: one stable radix sort of
//     (depth bits, index) keys, so ties keep index order.
//  3. Bin: in depth order, every 16x16 tile the ellipse really touches (an
//     exact ellipse-versus-rectangle test, not its bounding box) gets the
//     Gaussian; a counting sort by tile keeps each tile's list in depth order.
//  4. Composite each tile front to back (raster_tile_kernel.h): per Gaussian
//     and pixel row only the pixels inside the ellipse's span are evaluated,
//     pixels whose transmittance fell under 1e-4 are skipped, and a tile
//     stops once all of its pixels are done.
//
// Distortion (OpenCV, fisheye, f-theta) is rendered directly: the mean is projected
// through CameraModel::Distort, and the EWA Jacobian is the product of the
// pinhole Jacobian and the distortion's own 2x2 Jacobian at the mean (a local
// linearisation per Gaussian). Centres land exactly where
// CameraModel::Project puts them; the shape is first-order accurate.
#include "engine/render/rasterizer.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <limits>
#include <memory>

#include "absl/strings/str_cat.h"
#include "common/thread_pool.h"
#include "engine/render/instance_pose.h"
#include "engine/render/raster_frame.h"
#include "engine/render/raster_sh.h"
#include "engine/render/raster_tile.h"
#include "engine/render/splat_projection.h"
#include "engine/render/tile_binning.h"

namespace pf {
namespace {

using raster::kMaxAlpha;
using raster::kMinAlpha;
using raster::kMinTransmittance;
using raster::kTile;
using raster::kTilePixels;
using raster::Projected;

using raster::RenderFrame;
using raster::Transform;

Transform ToFloat(const Rigid& x) {
  Transform f;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) f.r[3 * i + j] = static_cast<float>(x.rotation.m[i][j]);
    f.t[i] = static_cast<float>(x.translation[i]);
  }
  return f;
}

// Projects Gaussian `i` into `out` (and, for a scene with colour gradients,
// its screen-space gradients into gradients[6 i, 6 i + 6)); false when it
// cannot be seen.
bool ProjectGaussian(const GaussianScene& scene, const RenderFrame& frame, size_t i, Projected* out,
                     float* gradients) {
  const uint32_t owner = scene.owners[i];
  if (!frame.owner_live[owner]) return false;
  raster::SplatGeometry g;
  if (frame.readout.has_value()) {
    if (!raster::ProjectSplatAtItsLine(scene, i, frame, &g)) return false;
  } else {
    const Transform& cam = frame.camera_from_owner[owner];
    if (!raster::ProjectSplatGeometry(scene, i, frame, cam.r, cam.t, &g)) return false;
  }
  *out = raster::ToProjected(g, owner);
  if (gradients != nullptr) {
    raster::ScreenColourGradients(&scene.colour_gradients[6 * i], g, gradients + 6 * i);
  }
  if (scene.sh_degree >= 0) {
    // SH live in canonical space: the view direction in the owner's frame.
    raster::EvalShColorFrom(&scene.sh[i * 3 * scene.sh_coeffs()], scene.sh_degree,
                            &scene.means[3 * i], &frame.eye_in_owner[3 * owner], out->rgb);
  }
  return true;
}

// Per-thread buffers of one tile, reused across tiles and renders.
struct TileScratch {
  std::vector<float> transmittance;  // [256]
  std::vector<float> acc;            // [K, 256]
  std::vector<float> acc_rgb;        // [3, 256]
  std::vector<float> acc_depth;      // [256]
  std::vector<float> best_weight;    // [256]
  std::vector<uint32_t> best_owner;  // [256]
};

// Composites tile (tx, ty) from its depth-ordered `indices` and writes its
// pixels.
void RenderTile(const RenderFrame& frame, const Projected* projected, const uint32_t* indices,
                size_t num_indices, int tx, int ty, const float* features, int stride, int count,
                bool sh_rgb, const float* gradients, const RenderOptions& options,
                RenderBuffers* out, int64_t* tested, int64_t* contributing) {
  thread_local TileScratch s;
  constexpr int kPad = raster::kTilePadding;
  s.transmittance.resize(kTilePixels + kPad);
  s.acc.resize(static_cast<size_t>(raster::kChannelStride) * std::max(count, 1) + kPad);
  s.acc_rgb.resize(3 * raster::kChannelStride + kPad);
  s.acc_depth.resize(kTilePixels + kPad);
  s.best_weight.resize(kTilePixels + kPad);
  s.best_owner.resize(kTilePixels + kPad);
  raster::TileJob job;
  job.projected = projected;
  job.indices = indices;
  job.num_indices = num_indices;
  job.x_begin = tx * kTile;
  job.y_begin = ty * kTile;
  job.x_end = std::min(job.x_begin + kTile, frame.width);
  job.y_end = std::min(job.y_begin + kTile, frame.height);
  job.features = features;
  job.stride = stride;
  job.count = count;
  job.sh_rgb = sh_rgb;
  job.gradients = gradients;
  job.transmittance = s.transmittance.data();
  job.acc = s.acc.data();
  job.acc_rgb = s.acc_rgb.data();
  job.acc_depth = s.acc_depth.data();
  job.best_weight = s.best_weight.data();
  job.best_owner = s.best_owner.data();
  raster::CompositeTile(&job);

  // Write the tile's pixels (channel-major tile buffers to [H, W, C]).
  const int channels = out->channels;
  for (int y = job.y_begin; y < job.y_end; ++y) {
    for (int x = job.x_begin; x < job.x_end; ++x) {
      const int p = (y - job.y_begin) * kTile + (x - job.x_begin);
      const size_t pixel = static_cast<size_t>(y) * frame.width + x;
      const float alpha = 1.f - job.transmittance[p];
      out->alpha[pixel] = alpha;
      const float* rgb = sh_rgb ? job.acc_rgb : job.acc;
      for (int c = 0; c < 3; ++c) out->rgb[3 * pixel + c] = rgb[c * raster::kChannelStride + p];
      if (options.features) {
        float* f = &out->features[pixel * channels];
        for (int c = 0; c < channels; ++c) f[c] = job.acc[c * raster::kChannelStride + p];
      }
      if (options.depth) out->depth[pixel] = alpha > 0 ? job.acc_depth[p] / alpha : 0.f;
      if (options.instance) out->instance[pixel] = job.best_owner[p];
    }
  }
  *tested += job.tested;
  *contributing += job.contributing;
}

}  // namespace

absl::Status CheckRenderable(const GaussianScene& scene) {
  const size_t n = scene.size();
  if (scene.num_channels < 3 || scene.num_channels > 256) {
    return absl::InvalidArgumentError(
        absl::StrCat("scene.num_channels: ", scene.num_channels, " is outside [3, 256]"));
  }
  if (scene.sh_degree < -1 || scene.sh_degree > 3) {
    return absl::InvalidArgumentError(
        absl::StrCat("scene.sh_degree: ", scene.sh_degree, " is outside [-1, 3]"));
  }
  if (n >= (size_t{1} << 32)) {
    return absl::InvalidArgumentError("scene: more than 2^32 Gaussians");
  }
  auto check = [&](const char* name, size_t actual, size_t per) -> absl::Status {
    if (actual != n * per) {
      return absl::InvalidArgumentError(
          absl::StrCat("scene.", name, ": has ", actual, " values, expected ", n * per));
    }
    return absl::OkStatus();
  };
  for (const absl::Status& s :
       {check("means", scene.means.size(), 3), check("rotations", scene.rotations.size(), 4),
        check("log_scales", scene.log_scales.size(), 3),
        check("features", scene.features.size(), scene.num_channels),
        check("sh", scene.sh.size(), 3 * static_cast<size_t>(scene.sh_coeffs())),
        check("times", scene.times.size(), 1), check("lifespans", scene.lifespans.size(), 1),
        check("owners", scene.owners.size(), 1)}) {
    if (!s.ok()) return s;
  }
  if (scene.has_colour_gradients()) {
    if (absl::Status s = check("colour_gradients", scene.colour_gradients.size(), 6); !s.ok()) {
      return s;
    }
    if (scene.sh_degree >= 0) {
      return absl::InvalidArgumentError(
          "scene.colour_gradients: only for scenes without SH (colour from the features)");
    }
  }
  for (size_t i = 0; i < n; ++i) {
    if (scene.owners[i] > scene.instances.size()) {
      return absl::InvalidArgumentError(absl::StrCat("scene.owners[", i, "]: ", scene.owners[i],
                                                     " but the scene has ", scene.instances.size(),
                                                     " instances"));
    }
  }
  return absl::OkStatus();
}

namespace raster {

absl::Status SetUpRenderFrame(const std::vector<InstanceTrack>& instances, int64_t time_origin_us,
                              const FadeSpan& fade_span, const RenderCamera& camera,
                              int64_t timestamp_us, const std::vector<ActorEdit>& edits,
                              float near_plane, RenderFrame* frame) {
  const CameraModel& model = camera.model;
  if (model.width() <= 0 || model.height() <= 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("camera: image size ", model.width(), "x", model.height(), " has no pixels"));
  }
  if (int64_t{model.width()} * model.height() > kMaxRenderPixels) {
    return absl::InvalidArgumentError(absl::StrCat("camera: image size ", model.width(), "x",
                                                   model.height(), " exceeds ", kMaxRenderPixels,
                                                   " pixels"));
  }
  // The edits: which instances are drawn, and which follow a new track.
  const size_t num_instances = instances.size();
  std::vector<uint8_t> live(num_instances + 1, 1);
  std::vector<const ActorEdit*> new_track(num_instances, nullptr);
  for (size_t e = 0; e < edits.size(); ++e) {
    const ActorEdit& edit = edits[e];
    size_t k = 0;
    while (k < num_instances && instances[k].id != edit.instance_id) ++k;
    if (k == num_instances) {
      return absl::InvalidArgumentError(
          absl::StrCat("edits[", e, "].instance_id: '", edit.instance_id, "' is not in the scene"));
    }
    if (edit.kind == ActorEdit::Kind::kRemove) {
      live[k + 1] = 0;
    } else {
      if (edit.boxes.empty()) {
        return absl::InvalidArgumentError(
            absl::StrCat("edits[", e, "].boxes: a trajectory edit needs at least one box"));
      }
      new_track[k] = &edit;
    }
  }
  // Owner poses at time `t`, with the edits applied.
  auto owner_poses = [&](int64_t t) {
    std::vector<Rigid> world_from_owner(num_instances + 1);
    for (size_t k = 0; k < num_instances; ++k) {
      if (new_track[k] == nullptr) {
        world_from_owner[k + 1] = InstancePoseAt(instances[k].boxes, t);
      } else {
        const std::vector<TrackBox>& track = instances[k].boxes;
        const Rigid canonical = track.empty() ? Rigid{} : BoxPose(track.front());
        world_from_owner[k + 1] =
            BoxPose(InterpolateBox(new_track[k]->boxes, t)) * canonical.Inverse();
      }
    }
    return world_from_owner;
  };
  const std::vector<Rigid> world_from_owner = owner_poses(timestamp_us);

  SetUpProjectionCamera(model, near_plane,
                        fade_span.Clamp(static_cast<float>(
                            static_cast<double>(timestamp_us - time_origin_us) * 1e-6)),
                        frame);
  frame->tiles_x = (frame->width + kTile - 1) / kTile;
  frame->tiles_y = (frame->height + kTile - 1) / kTile;
  const Rigid camera_from_world = camera.world_from_camera.Inverse();
  frame->owner_live = live;
  frame->camera_from_owner.resize(num_instances + 1);
  frame->eye_in_owner.resize(3 * (num_instances + 1));
  for (size_t k = 0; k <= num_instances; ++k) {
    frame->camera_from_owner[k] = ToFloat(camera_from_world * world_from_owner[k]);
    const Vec3 eye = world_from_owner[k].Inverse() * camera.world_from_camera.translation;
    for (int c = 0; c < 3; ++c) frame->eye_in_owner[3 * k + c] = static_cast<float>(eye[c]);
  }
  frame->readout.reset();
  frame->readout_camera_from_owner.clear();
  if (camera.rolling_shutter.has_value()) {
    const RollingShutter& shutter = *camera.rolling_shutter;
    frame->readout = shutter.readout;
    frame->readout_camera_from_owner.resize((num_instances + 1) * kReadoutSamples);
    for (int j = 0; j < kReadoutSamples; ++j) {
      const double f = static_cast<double>(j) / (kReadoutSamples - 1);
      const Rigid line_from_world =
          InterpolateRigid(camera.world_from_camera, shutter.world_from_camera_end, f).Inverse();
      const std::vector<Rigid> owners =
          owner_poses(timestamp_us + std::llround(f * static_cast<double>(shutter.readout_us)));
      for (size_t k = 0; k <= num_instances; ++k) {
        frame->readout_camera_from_owner[k * kReadoutSamples + j] =
            ToFloat(line_from_world * owners[k]);
      }
    }
  }
  return absl::OkStatus();
}

}  // namespace raster

namespace {

// The per-render arrays, kept per calling thread between renders so that
// repeated renders do not page in fresh memory (they only grow).
struct Workspace {
  std::vector<Projected> projected;                 // [N]
  std::vector<float> gradients;                     // [N, 6] screen colour gradients
  std::vector<std::vector<uint64_t>> visible_keys;  // Per projection chunk.
  std::vector<uint64_t> by_depth;                   // [visible]
  std::vector<uint64_t> radix_buffer;               // [visible]
  raster::TileBinScratch bins;                      // Binning's chunks.
  std::vector<uint32_t> tile_lists;                 // [pairs]
};

}  // namespace

absl::StatusOr<RenderBuffers> Render(const GaussianScene& scene, const RenderCamera& camera,
                                     int64_t timestamp_us, const std::vector<ActorEdit>& edits,
                                     const RenderOptions& options) {
  RenderFrame frame;
  if (absl::Status status =
          raster::SetUpRenderFrame(scene.instances, scene.time_origin_us, scene.fade_span, camera,
                                   timestamp_us, edits, options.near_plane, &frame);
      !status.ok()) {
    return status;
  }
  if (auto status = CheckRenderable(scene); !status.ok()) return status;

  RenderBuffers out;
  out.width = frame.width;
  out.height = frame.height;
  out.channels = scene.num_channels;
  const size_t pixels = static_cast<size_t>(frame.width) * frame.height;
  out.rgb.resize(pixels * 3);
  out.alpha.resize(pixels);
  if (options.features) out.features.resize(pixels * scene.num_channels);
  if (options.depth) out.depth.resize(pixels);
  if (options.instance) out.instance.resize(pixels);

  ThreadPool& pool = DefaultThreadPool();
  using Clock = std::chrono::steady_clock;
  auto ms_since = [](Clock::time_point t) {
    return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
  };
  const Clock::time_point t_start = Clock::now();
  const size_t n = scene.size();
  const int num_tiles = frame.tiles_x * frame.tiles_y;

  // 1. Project, per fixed chunk of Gaussians; list the visible ones as
  // (depth bits << 32 | index) keys, in index order.
  constexpr int64_t kChunk = 8192;
  thread_local Workspace ws;
  if (ws.projected.size() < n) ws.projected.resize(n);
  Projected* projected = ws.projected.data();
  float* gradients = nullptr;
  if (scene.has_colour_gradients()) {
    if (ws.gradients.size() < 6 * n) ws.gradients.resize(6 * n);
    gradients = ws.gradients.data();
  }
  const int64_t num_project_chunks = static_cast<int64_t>((n + kChunk - 1) / kChunk);
  std::vector<std::vector<uint64_t>>& visible_keys = ws.visible_keys;
  if (visible_keys.size() < static_cast<size_t>(num_project_chunks)) {
    visible_keys.resize(num_project_chunks);
  }
  pool.ParallelFor(0, num_project_chunks, 1, [&](int64_t c0, int64_t c1) {
    for (int64_t c = c0; c < c1; ++c) {
      const size_t begin = static_cast<size_t>(c) * kChunk;
      const size_t end = std::min(n, begin + kChunk);
      std::vector<uint64_t>& keys = visible_keys[c];
      keys.clear();
      keys.reserve(end - begin);
      for (size_t i = begin; i < end; ++i) {
        if (!ProjectGaussian(scene, frame, i, &projected[i], gradients)) continue;
        const uint32_t depth_bits =
            raster::SortDepthBits(projected[i].depth, static_cast<uint32_t>(i), scene.order_band);
        keys.push_back((static_cast<uint64_t>(depth_bits) << 32) | i);
      }
    }
  });
  const double ms_project = ms_since(t_start);

  // 2. One global, stable radix sort by depth: ties stay in index order.
  std::vector<uint64_t>& by_depth = ws.by_depth;
  by_depth.clear();
  for (int64_t c = 0; c < num_project_chunks; ++c) {
    by_depth.insert(by_depth.end(), visible_keys[c].begin(), visible_keys[c].end());
  }
  raster::RadixSortByHighWord(&by_depth, &ws.radix_buffer, pool);

  // 3. Bin: in depth order, each Gaussian emits the tiles its ellipse
  // touches; a counting sort by tile (chunks in order) keeps each tile's
  // list in depth order.
  std::vector<uint64_t> tile_begin;
  std::vector<uint32_t>& tile_lists = ws.tile_lists;
  const int64_t visible = raster::BinByTile(
      by_depth.size(), num_tiles,
      [&](size_t k, auto&& emit) {
        if (k + 8 < by_depth.size())
          __builtin_prefetch(&projected[static_cast<uint32_t>(by_depth[k + 8])]);
        const uint32_t i = static_cast<uint32_t>(by_depth[k]);
        const Projected& g = projected[i];
        raster::VisitTiles(g.mx, g.my, g.ca, g.cb, g.cc, g.span_d2, g.ext_x, g.ext_y, frame.width,
                           frame.height, frame.tiles_x, [&](uint32_t tile) { emit(tile, i); });
      },
      pool, &ws.bins, &tile_begin, &tile_lists);
  const double ms_bin = ms_since(t_start) - ms_project;

  // 4. Composite each tile.
  const bool sh_rgb = scene.sh_degree >= 0;
  const int count = options.features ? scene.num_channels : (sh_rgb ? 0 : 3);
  std::vector<int64_t> tested(num_tiles, 0), contributing(num_tiles, 0);
  pool.ParallelFor(0, num_tiles, 1, [&](int64_t t0, int64_t t1) {
    for (int64_t t = t0; t < t1; ++t) {
      const uint32_t* begin = tile_lists.data() + tile_begin[t];
      const size_t size = tile_begin[t + 1] - tile_begin[t];
      const int tx = static_cast<int>(t % frame.tiles_x), ty = static_cast<int>(t / frame.tiles_x);
      RenderTile(frame, projected, begin, size, tx, ty, scene.features.data(), scene.num_channels,
                 count, sh_rgb, gradients, options, &out, &tested[t], &contributing[t]);
    }
  });
  const double ms_composite = ms_since(t_start) - ms_project - ms_bin;
  spdlog::debug("render: project {:.2f} ms, sort+bin {:.2f} ms ({} pairs), composite {:.2f} ms",
                ms_project, ms_bin, tile_begin[num_tiles], ms_composite);
  out.stats.gaussians_visible = visible;
  out.stats.project_ms = ms_project;
  out.stats.sort_bin_ms = ms_bin;
  out.stats.composite_ms = ms_composite;
  for (int t = 0; t < num_tiles; ++t) {
    out.stats.pairs_tested += tested[t];
    out.stats.pairs_contributing += contributing[t];
  }
  return out;
}

}  // namespace pf
