// Tests of the rendered LiDAR's figures against a recorded sweep.
#include "engine/recon/lidar_eval.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "engine/render/lidar_testing.h"

namespace pf {
namespace {

constexpr double kPi = 3.14159265358979323846;

// A wall of opaque discs 5 cm apart on the plane x = 8, y and z in [-6, 6].
GaussianScene Wall() {
  GaussianScene scene;
  scene.low_pass = 0.1f;
  for (double y = -6; y <= 6; y += 0.05) {
    for (double z = -6; z <= 6; z += 0.05) {
      const size_t i = scene.size();
      scene.Resize(i + 1);
      scene.means[3 * i] = 8.f, scene.means[3 * i + 1] = float(y);
      scene.means[3 * i + 2] = float(z);
      scene.log_scales[3 * i] = std::log(0.001f);
      scene.log_scales[3 * i + 1] = scene.log_scales[3 * i + 2] = std::log(0.04f);
      scene.opacity_logits[i] = 4.f;
    }
  }
  return scene;
}

// A sweep from the origin: 8 beams from -8 to +6 degrees, every 2 degrees of
// azimuth; a ray that meets the wall returns there (`offset` metres past
// it), the others 20 m out (what stands beyond the scene).
// With `drop_beyond_y`, rays that meet the wall's plane farther than that
// from y = 0 (but within 5.5 m) return nothing. With `jitter_deg`, each
// point's elevation is off by up to that, spread evenly. Each point's
// intensity is 10 + 5 y.
LidarSweepData Sweep(double offset, double drop_beyond_y = 0, double jitter_deg = 0) {
  LidarSweepData sweep;
  sweep.timestamp_us = 5;
  for (int a = 0; a < 180; ++a) {
    const double azimuth = a * 2 * kPi / 180;
    for (int b = 0; b < 8; ++b) {
      const double u = 97 * (a * 0.6180339887 + b * 0.4142135624);
      const double jitter = jitter_deg * (2 * (u - std::floor(u)) - 1);
      const double elevation = (-8 + 2 * b + jitter) * kPi / 180;
      const Vec3 d{std::cos(elevation) * std::cos(azimuth), std::cos(elevation) * std::sin(azimuth),
                   std::sin(elevation)};
      double range = 20;
      if (d.x > 0) {
        const double t = 8 / d.x;
        const Vec3 p = t * d;
        if (std::abs(p.y) < 5.5 && std::abs(p.z) < 5.5) range = t + offset;
        if (drop_beyond_y > 0 && std::abs(p.y) >= drop_beyond_y && std::abs(p.y) < 5.5) continue;
      }
      for (double v : {range * d.x, range * d.y, range * d.z}) sweep.points.push_back(float(v));
      sweep.intensities.push_back(float(10 + 5 * range * d.y));
    }
  }
  return sweep;
}

// A camera at the origin looking along +x (OpenCV axes: z forward = world x),
// 67 degrees across: azimuths within 33.7 degrees of +x, every one on the
// wall.
SeeingCamera ForwardCamera() {
  SeeingCamera camera;
  camera.model = CameraModel(200, 200, 150, 150, 100, 100);
  camera.world_from_camera.rotation.m = {{{0, 0, 1}, {-1, 0, 0}, {0, -1, 0}}};
  return camera;
}

TEST(LidarEval, TheWallTheCamerasSawIsMeasuredAndTheRestLeftOut) {
  const GaussianScene wall = Wall();
  absl::StatusOr<LidarSweepFigures> figures =
      EvaluateLidarRender(wall, Sweep(0), {ForwardCamera()});
  ASSERT_TRUE(figures.ok()) << figures.status();
  EXPECT_EQ(figures->timestamp_us, 5);
  EXPECT_EQ(figures->sweep_points, 180 * 8);
  // Azimuths 0, +-2, ..., +-32 degrees: 33 of the 180.
  EXPECT_EQ(figures->points, 33 * 8);
  EXPECT_DOUBLE_EQ(figures->hit_share, 1.0);
  EXPECT_LT(figures->range_error_median, 0.02);
  EXPECT_LT(figures->range_error_p90, 0.04);
  EXPECT_LT(figures->chamfer, 0.03);
  EXPECT_EQ(figures->early_share, 0.0);
  EXPECT_EQ(figures->late_share, 0.0);

  // The recorded returns 0.5 m behind the wall: every figure says so.
  figures = EvaluateLidarRender(wall, Sweep(0.5), {ForwardCamera()});
  ASSERT_TRUE(figures.ok()) << figures.status();
  EXPECT_NEAR(figures->range_error_median, 0.5, 0.03);
  EXPECT_GT(figures->chamfer, 0.3);

  // 2 m behind it (the wall stands where the LiDAR saw through): every ray
  // returns early; 2 m before it (the scene lacks a surface): late.
  figures = EvaluateLidarRender(wall, Sweep(2.0), {ForwardCamera()});
  ASSERT_TRUE(figures.ok()) << figures.status();
  EXPECT_DOUBLE_EQ(figures->early_share, 1.0);
  EXPECT_EQ(figures->late_share, 0.0);
  figures = EvaluateLidarRender(wall, Sweep(-2.0), {ForwardCamera()});
  ASSERT_TRUE(figures.ok()) << figures.status();
  EXPECT_EQ(figures->early_share, 0.0);
  EXPECT_DOUBLE_EQ(figures->late_share, 1.0);

  // No camera: nothing to measure.
  EXPECT_TRUE(absl::IsFailedPrecondition(EvaluateLidarRender(wall, Sweep(0), {}).status()));
}

TEST(LidarEval, OneHeadsSweepIsMeasuredPerBeamAndItsDropsCounted) {
  const GaussianScene wall = Wall();
  absl::StatusOr<LidarSweepFigures> figures =
      EvaluateLidarRender(wall, Sweep(0), {ForwardCamera()});
  ASSERT_TRUE(figures.ok()) << figures.status();
  ASSERT_EQ(figures->beams.size(), 8u) << figures->beams_note;
  for (int b = 0; b < 8; ++b) {
    const LidarBeamFigures& beam = figures->beams[b];
    EXPECT_NEAR(beam.elevation_deg, 6 - 2 * b, 1e-3) << b;
    EXPECT_EQ(beam.points, 33) << b;
    EXPECT_DOUBLE_EQ(beam.hit_share, 1.0) << b;
    EXPECT_LT(beam.range_error_median, 0.02) << b;
  }
  // Every cell the camera sees (33 azimuths x 8 beams) returned, rendered too.
  EXPECT_EQ(figures->cells, 33 * 8);
  EXPECT_EQ(figures->recorded_drop_share, 0.0);
  EXPECT_EQ(figures->rendered_drop_share, 0.0);
  EXPECT_DOUBLE_EQ(figures->drop_agreement, 1.0);

  // On the wall the LiDAR returned only within 3 m of y = 0 (azimuths up to
  // 20 degrees): the 12 seen azimuths beyond, where the scene's wall goes on
  // to 6 m, are recorded drops the render returns. The upper beam's figures
  // are over its 21 returns the camera saw.
  figures = EvaluateLidarRender(wall, Sweep(0, 3), {ForwardCamera()});
  ASSERT_TRUE(figures.ok()) << figures.status();
  ASSERT_EQ(figures->beams.size(), 8u) << figures->beams_note;
  EXPECT_EQ(figures->beams[0].points, 21);
  EXPECT_EQ(figures->cells, 33 * 8);
  EXPECT_NEAR(figures->recorded_drop_share, 12.0 / 33, 1e-9);
  EXPECT_EQ(figures->rendered_drop_share, 0.0);
  EXPECT_NEAR(figures->drop_agreement, 21.0 / 33, 1e-9);

  // Elevations off by up to 0.8 degrees either way: not one head's beams; no
  // per-beam figures or cells, and the note says why.
  figures = EvaluateLidarRender(wall, Sweep(0, 0, 0.8), {ForwardCamera()});
  ASSERT_TRUE(figures.ok()) << figures.status();
  EXPECT_TRUE(figures->beams.empty());
  EXPECT_EQ(figures->cells, 0);
  EXPECT_NE(figures->beams_note.find("not one spinning head's sweep"), std::string::npos)
      << figures->beams_note;
  EXPECT_GT(figures->points, 0);
}

TEST(LidarEval, TheIntensityIsMeasuredAgainstTheBestConstant) {
  // The wall with an intensity channel of 10 + 5 y, as the sweep recorded.
  GaussianScene wall = Wall();
  testing::AddIntensityChannel(&wall, [&](size_t i) { return 10 + 5 * wall.means[3 * i + 1]; });
  absl::StatusOr<LidarSweepFigures> figures =
      EvaluateLidarRender(wall, Sweep(0), {ForwardCamera()});
  ASSERT_TRUE(figures.ok()) << figures.status();
  EXPECT_EQ(figures->intensity_rays, 33 * 8);
  // Discs 5 cm apart: the blend is within a disc's 0.25 of the truth. The
  // recorded y spread over +-5 m: the best constant (10) is off by a median 5 x
  // 8 tan(16 degrees).
  EXPECT_LT(figures->intensity_error_median, 0.25);
  EXPECT_NEAR(figures->intensity_constant_error_median, 5 * 8 * std::tan(16 * kPi / 180), 0.6);
  // 0.3 m behind the wall: the same surface by SignedTolerance (0.5 m here),
  // so measured; 2 m behind: none is.
  figures = EvaluateLidarRender(wall, Sweep(0.3), {ForwardCamera()});
  ASSERT_TRUE(figures.ok()) << figures.status();
  EXPECT_EQ(figures->intensity_rays, 33 * 8);
  figures = EvaluateLidarRender(wall, Sweep(2.0), {ForwardCamera()});
  ASSERT_TRUE(figures.ok()) << figures.status();
  EXPECT_EQ(figures->intensity_rays, 0);
  // No channel in the scene, or no intensities in the sweep: no figures.
  figures = EvaluateLidarRender(Wall(), Sweep(0), {ForwardCamera()});
  ASSERT_TRUE(figures.ok()) << figures.status();
  EXPECT_EQ(figures->intensity_rays, 0);
  LidarSweepData unknown = Sweep(0);
  unknown.intensities.clear();
  figures = EvaluateLidarRender(wall, unknown, {ForwardCamera()});
  ASSERT_TRUE(figures.ok()) << figures.status();
  EXPECT_EQ(figures->intensity_rays, 0);
}

TEST(LidarEval, MeansPoolBeamsAndDropsOverTheSweepsThatHaveThem) {
  LidarSweepFigures a, b;
  a.beams = {{2, 10, 1.0, 0.1, 0.2}};
  b.beams = {{2, 30, 0.5, 0.3, 0.4}};
  a.cells = 100, a.drop_agreement = 0.9, a.recorded_drop_share = 0.2;
  a.intensity_rays = 50, a.intensity_error_median = 2, a.intensity_constant_error_median = 7;
  const LidarSweepFigures mean = MeanLidarFigures({a, b});
  EXPECT_EQ(mean.intensity_rays, 50);
  EXPECT_DOUBLE_EQ(mean.intensity_error_median, 2);  // b has no intensity.
  EXPECT_DOUBLE_EQ(mean.intensity_constant_error_median, 7);
  ASSERT_EQ(mean.beams.size(), 1u);
  EXPECT_EQ(mean.beams[0].points, 40);
  EXPECT_DOUBLE_EQ(mean.beams[0].hit_share, 0.75);
  EXPECT_DOUBLE_EQ(mean.beams[0].range_error_median, 0.2);
  EXPECT_EQ(mean.cells, 100);
  EXPECT_DOUBLE_EQ(mean.drop_agreement, 0.9);  // b has no cells.
  EXPECT_DOUBLE_EQ(mean.recorded_drop_share, 0.2);
  b.beams.clear();
  EXPECT_TRUE(MeanLidarFigures({a, b}).beams.empty());
}

}  // namespace
}  // namespace pf
