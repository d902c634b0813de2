// Tests of `pf eval`'s baselines: which CONTEXT frames they take, the depth
// they warp with, the forward warp and its z-buffer, and the hole filling.
#include "engine/recon/eval_baselines.h"

#include <gtest/gtest.h>

#include <cmath>

#include "engine/recon/image_metrics.h"
#include "engine/synth/synth_ray_caster.h"
#include "engine/synth/synth_scene.h"
#include "pointforward/v1/clip.pb.h"

namespace pf {
namespace {

using pointforward::v1::Clip;
using pointforward::v1::Frame;

void AddBaselineFrame(Clip* clip, const std::string& camera, int64_t t, Frame::Role role,
                      double x = 0) {
  Frame* frame = clip->add_frames();
  frame->set_camera(camera);
  frame->set_timestamp_us(t);
  frame->set_role(role);
  Rigid pose;
  pose.translation = {x, 0, 0};
  for (double v : pose.ToRowMajor()) frame->add_world_from_camera(v);
}

TEST(EvalBaselines, NearestFramesAreTheSameCamerasNearestInTime) {
  Clip clip;
  AddBaselineFrame(&clip, "a", 0, Frame::CONTEXT);
  AddBaselineFrame(&clip, "a", 100, Frame::CONTEXT);
  AddBaselineFrame(&clip, "a", 300, Frame::ROLE_UNSPECIFIED);  // Counts as CONTEXT.
  AddBaselineFrame(&clip, "b", 180, Frame::CONTEXT);           // Nearer in time, other camera.
  AddBaselineFrame(&clip, "a", 180, Frame::TARGET);            // 4
  AddBaselineFrame(&clip, "a", 290, Frame::TARGET);            // 5
  AddBaselineFrame(&clip, "a", 200, Frame::TARGET);            // 6: 100 from both neighbours.
  EXPECT_EQ(NearestContextFrames(clip, 4, 2), (std::vector<int>{1, 2}));
  EXPECT_EQ(NearestContextFrames(clip, 4, 1), (std::vector<int>{1}));
  EXPECT_EQ(NearestContextFrames(clip, 5, 2), (std::vector<int>{2, 1}));
  EXPECT_EQ(NearestContextFrames(clip, 6, 2), (std::vector<int>{1, 2}));  // Earlier first.
  EXPECT_EQ(NearestContextFrames(clip, 4, 5), (std::vector<int>{1, 2, 0}));
}

TEST(EvalBaselines, ACameraWithoutContextTakesTheNearestCamerasFrames) {
  Clip clip;
  AddBaselineFrame(&clip, "left", 100, Frame::CONTEXT, -0.5);
  AddBaselineFrame(&clip, "far", 100, Frame::CONTEXT, 3.0);
  AddBaselineFrame(&clip, "left", 0, Frame::CONTEXT, -0.5);
  AddBaselineFrame(&clip, "right", 100, Frame::TARGET, 0.5);
  // Same time gap: the nearer camera centre first.
  EXPECT_EQ(NearestContextFrames(clip, 3, 3), (std::vector<int>{0, 1, 2}));
  Clip targets_only;
  AddBaselineFrame(&targets_only, "a", 0, Frame::TARGET);
  EXPECT_TRUE(NearestContextFrames(targets_only, 0, 2).empty());
}

// A 40x30 view at the origin looking along +z: left half red at 5 m, right
// half blue at 10 m.
ContextView TwoPlanes() {
  ContextView view;
  view.camera = CameraModel(40, 30, 40, 40, 20, 15);
  view.rgb = ImageF(40, 30, 3);
  view.depth = ImageF(40, 30, 1);
  for (int y = 0; y < 30; ++y)
    for (int x = 0; x < 40; ++x) {
      view.rgb.at(x, y, x < 20 ? 0 : 2) = 1.f;
      view.depth.at(x, y) = x < 20 ? 5.f : 10.f;
    }
  return view;
}

TEST(EvalBaselines, TheZBufferKeepsTheNearerSurface) {
  const ContextView source = TwoPlanes();
  // Moved 0.4 m to the left: the near plane moves 3.2 px right, its last
  // column landing at u = 22.7; the far plane 1.6 px, its first columns
  // landing at 22.1 and 23.1.
  Rigid target_pose;
  target_pose.translation = {-0.4, 0, 0};
  const WarpedView warp = ForwardWarp(source, source.depth, source.camera, target_pose);
  // Pixel 22: both surfaces land in it; the near one wins.
  EXPECT_FLOAT_EQ(warp.rgb.at(22, 15, 0), 1.f);
  EXPECT_FLOAT_EQ(warp.rgb.at(22, 15, 2), 0.f);
  EXPECT_NEAR(warp.depth.at(22, 15), 5.f, 1e-4);
  // Pixel 23: only the far one lands in it; the near one's footprint
  // reaches it, but does not spread over what lies behind its edge.
  EXPECT_FLOAT_EQ(warp.rgb.at(23, 15, 0), 0.f);
  EXPECT_FLOAT_EQ(warp.rgb.at(23, 15, 2), 1.f);
  EXPECT_NEAR(warp.depth.at(23, 15), 10.f, 1e-4);
  EXPECT_NEAR(warp.depth.at(30, 15), 10.f, 1e-4);
  // The left edge: nothing lands on the 3 columns the view did not see.
  EXPECT_EQ(warp.covered[15 * 40 + 2], 0);
  EXPECT_EQ(warp.covered[15 * 40 + 3], 1);
  // The ego body is never warped.
  ContextView with_ego = source;
  with_ego.ego.assign(40 * 30, 1);
  const WarpedView none = ForwardWarp(with_ego, with_ego.depth, source.camera, target_pose);
  for (uint8_t c : none.covered) ASSERT_EQ(c, 0);
}

TEST(EvalBaselines, PixelsWithoutDepthMoveAsIfInfinitelyFar) {
  ContextView source = TwoPlanes();
  ImageF no_depth(40, 30, 1);
  Rigid target_pose;
  target_pose.translation = {-0.5, 0, 0};  // A translation moves nothing at infinity.
  const WarpedView warp = ForwardWarp(source, no_depth, source.camera, target_pose);
  EXPECT_FLOAT_EQ(warp.rgb.at(19, 15, 0), 1.f);
  EXPECT_FLOAT_EQ(warp.rgb.at(20, 15, 2), 1.f);
  EXPECT_EQ(warp.depth.at(20, 15), 0.f);  // No finite depth.
  EXPECT_EQ(warp.covered[15 * 40 + 0], 1);
}

TEST(EvalBaselines, HolesAreFilledFromTheOtherWarpThenTheNearestPixel) {
  auto view = [](float r, float depth, int covered_from, int covered_to) {
    WarpedView v;
    v.rgb = ImageF(10, 1, 3);
    v.depth = ImageF(10, 1, 1);
    v.covered.assign(10, 0);
    for (int x = covered_from; x < covered_to; ++x) {
      v.rgb.at(x, 0, 0) = r;
      v.depth.at(x, 0) = depth;
      v.covered[x] = 1;
    }
    return v;
  };
  const WarpedView combined = CombineWarps({view(0.2f, 4.f, 0, 5), view(0.8f, 9.f, 3, 7)});
  EXPECT_FLOAT_EQ(combined.rgb.at(4, 0, 0), 0.2f);  // The first warp wins where both cover.
  EXPECT_FLOAT_EQ(combined.rgb.at(5, 0, 0), 0.8f);  // Its holes from the second.
  EXPECT_FLOAT_EQ(combined.depth.at(6, 0), 9.f);
  EXPECT_FLOAT_EQ(combined.rgb.at(9, 0, 0), 0.8f);  // Then the nearest covered pixel (6).
  EXPECT_FLOAT_EQ(combined.depth.at(9, 0), 9.f);
  EXPECT_EQ(combined.covered, (std::vector<uint8_t>{1, 1, 1, 1, 1, 1, 1, 0, 0, 0}));
}

TEST(EvalBaselines, WarpDepthComesFromTheNearestSweepCompleted) {
  ContextView view;
  view.camera = CameraModel(80, 60, 80, 80, 40, 30);
  view.timestamp_us = 100000;
  // A wall 10 m ahead at 0.05 s, one 20 m ahead at 1 s, sampled like rings.
  auto wall = [](double z, int64_t t) {
    LidarSweepData sweep;
    sweep.timestamp_us = t;
    for (double y = -3; y <= 3; y += 0.25)
      for (double x = -5; x <= 5; x += 0.1) {
        sweep.points.insert(sweep.points.end(), {float(x), float(y), float(z)});
      }
    return sweep;
  };
  const std::vector<LidarSweepData> sweeps = {wall(10, 50000), wall(20, 1000000)};
  const ImageF depth = WarpSourceDepth(view, sweeps);
  for (int y = 10; y < 50; y += 7)
    for (int x = 0; x < 80; x += 9) EXPECT_NEAR(depth.at(x, y), 10.f, 0.05f) << x << "," << y;
  // A dense depth map is taken as it is; a sparse one is completed.
  view.depth = ImageF(80, 60, 1);
  for (int y = 0; y < 60; ++y)
    for (int x = 0; x < 80; ++x) view.depth.at(x, y) = y < 20 ? 0.f : 7.f;
  EXPECT_EQ(WarpSourceDepth(view, sweeps).pixels, view.depth.pixels);
  view.depth = ImageF(80, 60, 1);
  for (int y = 20; y < 60; y += 3)
    for (int x = y % 4; x < 80; x += 4) view.depth.at(x, y) = 7.f;
  EXPECT_NEAR(WarpSourceDepth(view, sweeps).at(41, 40), 7.f, 1e-3);
}

// The synth scene without its vehicles, rendered by `camera` at `t` seconds
// with exact depth.
ContextView StaticSynthView(const SynthScene& scene, int camera, double t) {
  const RenderedView rendered =
      RenderView(SnapshotAt(scene, t), scene.cameras[camera].model,
                 scene.WorldFromCamera(camera, t), scene.options.antialias);
  ContextView view;
  view.camera_id = scene.cameras[camera].id;
  view.camera = scene.cameras[camera].model;
  view.world_from_camera = scene.WorldFromCamera(camera, t);
  view.timestamp_us = std::llround(t * 1e6);
  view.rgb = rendered.rgb;
  view.depth = rendered.depth;
  return view;
}

TEST(EvalBaselines, TheWarpReproducesANearbyViewOfAKnownScene) {
  SynthOptions options;
  options.width = 160;
  options.height = 120;
  absl::StatusOr<SynthScene> scene = GenerateSynthScene(options);
  ASSERT_TRUE(scene.ok()) << scene.status();
  scene->vehicles.clear();
  // The right camera (facades sweep across it) 0.1 s (0.8 m) before and
  // 0.2 s after the target.
  const ContextView before = StaticSynthView(*scene, 2, 0.0);
  const ContextView after = StaticSynthView(*scene, 2, 0.3);
  const ContextView target = StaticSynthView(*scene, 2, 0.1);
  const WarpedView warp =
      ForwardWarp(before, before.depth, target.camera, target.world_from_camera);
  // Where the target sees a surface the context saw: far ahead of the
  // unchanged frame (measured 24.4 against 17.1 dB; the rest is resampling
  // the antialiased texture), at the true depth (99 % within 5 %).
  std::vector<uint8_t> seen(warp.covered.size());
  int64_t surface = 0, right_depth = 0;
  for (size_t i = 0; i < seen.size(); ++i) {
    seen[i] = warp.covered[i] && target.depth.pixels[i] > 0.f;
    if (!seen[i] || warp.depth.pixels[i] == 0.f) continue;
    ++surface;
    right_depth +=
        std::abs(warp.depth.pixels[i] - target.depth.pixels[i]) < 0.05f * target.depth.pixels[i];
  }
  EXPECT_GT(surface, 160 * 120 / 2);
  const double warped = Psnr(target.rgb, warp.rgb, seen).value_or(0);
  const double unchanged = Psnr(target.rgb, before.rgb, seen).value_or(0);
  // Where the view hardly changes (the unchanged frame above 18.5 dB, as the
  // clang build of this scene renders it: 25.2 dB, cause not found), the
  // warp must still reach 23.5 dB.
  EXPECT_GT(warped, 23.0);
  EXPECT_GT(warped, std::min(unchanged + 5.0, 23.5));
  EXPECT_GT(right_depth, surface * 95 / 100);
  // The whole image, holes filled from the other frame, then the nearest
  // pixel (measured 24.4 against 17.2 dB).
  const WarpedView both = CombineWarps(
      {warp, ForwardWarp(after, after.depth, target.camera, target.world_from_camera)});
  EXPECT_GT(Psnr(target.rgb, both.rgb).value_or(0),
            std::min(Psnr(target.rgb, before.rgb).value_or(0) + 5.0, 23.5));
}

}  // namespace
}  // namespace pf
