// Tests of the hidden-measurement depth evaluation (pf depth-eval).
#include "engine/recon/depth_holdout.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

namespace pf {
namespace {

// A street seen by a level camera 1.5 m up at the origin, looking along +x:
// the road z = 0 and a wall x = 12 (|y| <= 10, up to 8 m). The LiDAR, 1.9 m
// up, has beams from -15 to +5 degrees every 0.5 degrees, azimuths -60 to 60
// every 0.2 degrees; each point is where its beam meets the road or the wall.
LidarSweepData HoldOutStreetSweep() {
  LidarSweepData sweep;
  sweep.sensor_origin = {0, 0, 1.9};
  for (double el = -15; el <= 5 + 1e-9; el += 0.5) {
    for (double az = -60; az <= 60 + 1e-9; az += 0.2) {
      const double ce = std::cos(el * M_PI / 180), se = std::sin(el * M_PI / 180);
      const Vec3 d{ce * std::cos(az * M_PI / 180), ce * std::sin(az * M_PI / 180), se};
      double t = (12 - sweep.sensor_origin.x) / d.x;               // The wall.
      if (d.z < 0) t = std::min(t, -sweep.sensor_origin.z / d.z);  // The road, if nearer.
      const Vec3 p = sweep.sensor_origin + d * t;
      if (std::abs(p.y) > 10 || p.z > 8) continue;
      sweep.points.insert(sweep.points.end(), {float(p.x), float(p.y), float(p.z)});
    }
  }
  return sweep;
}

ContextView HoldOutStreetView() {
  ContextView view;
  view.camera = CameraModel(160, 120, 160, 160, 80, 60);
  view.world_from_camera.rotation = Mat3::FromColumns({0, -1, 0}, {0, 0, -1}, {1, 0, 0});
  view.world_from_camera.translation = {0, 0, 1.5};
  view.rgb = ImageF(160, 120, 3);
  return view;
}

double SweepElevation(const LidarSweepData& sweep, size_t i) {
  const Vec3 d = Vec3{sweep.points[3 * i], sweep.points[3 * i + 1], sweep.points[3 * i + 2]} -
                 sweep.sensor_origin;
  return Dot(d, sweep.sensor_up) / Norm(d);
}

TEST(DepthHoldOut, HalfHidesAFixedRandomHalf) {
  const LidarSweepData sweep = HoldOutStreetSweep();
  const size_t n = sweep.points.size() / 3;
  LidarSweepData kept, hidden, kept2, hidden2;
  HoldOutSweep(sweep, {}, &kept, &hidden);
  EXPECT_EQ(kept.points.size() + hidden.points.size(), sweep.points.size());
  EXPECT_NEAR(double(hidden.points.size() / 3) / n, 0.5, 0.03);
  HoldOutSweep(sweep, {}, &kept2, &hidden2);
  EXPECT_EQ(hidden.points, hidden2.points);  // Reproducible.
  // Not every other point: both halves hold neighbours of each other.
  EXPECT_NE(hidden.points[0], sweep.points[3]);
}

TEST(DepthHoldOut, TopHidesTheHighestBeams) {
  const LidarSweepData sweep = HoldOutStreetSweep();
  HoldOutOptions options;
  options.mode = HoldOutOptions::Mode::kTop;
  options.top_share = 0.25;
  LidarSweepData kept, hidden;
  HoldOutSweep(sweep, options, &kept, &hidden);
  const size_t n = sweep.points.size() / 3, nh = hidden.points.size() / 3;
  EXPECT_NEAR(double(nh) / n, 0.25, 0.03);
  double lowest_hidden = 1, highest_kept = -1;
  for (size_t i = 0; i < nh; ++i)
    lowest_hidden = std::min(lowest_hidden, SweepElevation(hidden, i));
  for (size_t i = 0; i < kept.points.size() / 3; ++i)
    highest_kept = std::max(highest_kept, SweepElevation(kept, i));
  EXPECT_GT(lowest_hidden, highest_kept);
}

TEST(DepthHoldOut, MeasuresEachMethodAtTheHiddenPoints) {
  // Between the kept points completion copies the nearest one's depth: on
  // the wall (one depth) that is right, on the road a few % off; the depth
  // stage's ground plane gives each road pixel its own depth.
  ReconInputs inputs;
  inputs.views = {HoldOutStreetView()};
  inputs.sweeps = {HoldOutStreetSweep()};
  CompletionOptions completion;
  completion.facades = false;  // One view: no other view to check a facade.
  const absl::StatusOr<DepthHoldOutReport> result = EvaluateDepthHoldOut(inputs, completion, {});
  ASSERT_TRUE(result.ok()) << result.status();
  const DepthHoldOutReport& report = *result;
  EXPECT_EQ(report.views, 1);
  EXPECT_GT(report.hidden_points, 500);
  EXPECT_GT(report.kept_measurements, report.hidden_points / 2);
  EXPECT_GT(report.ground_pixels, 1000);
  ASSERT_EQ(report.methods.size(), 3u);
  EXPECT_EQ(report.methods[0].name, "nearest");
  EXPECT_EQ(report.methods[1].name, "ipBasic");
  EXPECT_EQ(report.methods[2].name, "ours");
  for (const DepthHoldOutMethod& method : report.methods) {
    const DepthErrors all = method.all.Mean();
    EXPECT_EQ(all.points + all.missing, report.hidden_points) << method.name;
    EXPECT_GT(all.points, report.hidden_points * 9 / 10) << method.name;
    EXPECT_LT(all.abs_rel, 0.05) << method.name;
  }
  const DepthErrors nearest = report.methods[0].common.Mean();
  const DepthErrors ours = report.methods[2].common.Mean();
  EXPECT_EQ(nearest.points, ours.points);
  EXPECT_LT(ours.abs_rel, 0.005);
  EXPECT_LT(ours.abs_rel, 0.5 * nearest.abs_rel);
  EXPECT_GT(ours.within_5pct, 0.97);  // Measured 0.983.
}

TEST(DepthHoldOut, HidesPixelsOfASparseDepthMap) {
  ReconInputs inputs;
  inputs.views = {HoldOutStreetView()};
  ContextView& view = inputs.views[0];
  view.depth = ProjectPoints(HoldOutStreetSweep().points, view.camera, view.world_from_camera);
  const int64_t known = std::count_if(view.depth.pixels.begin(), view.depth.pixels.end(),
                                      [](float d) { return d > 0.f; });
  CompletionOptions completion;
  completion.facades = false;
  const absl::StatusOr<DepthHoldOutReport> result = EvaluateDepthHoldOut(inputs, completion, {});
  ASSERT_TRUE(result.ok()) << result.status();
  const DepthHoldOutReport& report = *result;
  EXPECT_EQ(report.hidden_points + report.kept_measurements, known);
  EXPECT_NEAR(double(report.hidden_points) / known, 0.5, 0.05);
  EXPECT_LT(report.methods[2].all.Mean().abs_rel, 0.01);
  // A dense map has nothing to hide.
  for (float& d : view.depth.pixels) d = 5.f;
  const absl::StatusOr<DepthHoldOutReport> dense = EvaluateDepthHoldOut(inputs, completion, {});
  EXPECT_EQ(dense.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_NE(dense.status().message().find("no LiDAR point"), std::string::npos);
}

TEST(DepthHoldOut, ParsesTheModes) {
  EXPECT_EQ(*ParseHoldOutMode("half"), HoldOutOptions::Mode::kHalf);
  EXPECT_EQ(*ParseHoldOutMode("top"), HoldOutOptions::Mode::kTop);
  const absl::Status bad = ParseHoldOutMode("rings").status();
  EXPECT_EQ(bad.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(bad.message().find("--hide"), std::string::npos);
}

}  // namespace
}  // namespace pf
