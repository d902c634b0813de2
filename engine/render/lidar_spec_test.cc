// Tests of LiDAR specs: the rays of a spec, a sweep rendered along them and
// written as a range image and a point record (read back), the beams
// estimated from a sweep.
#include "engine/render/lidar_spec.h"

#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <random>
#include <string>
#include <vector>

#include "common/file_util.h"
#include "engine/render/lidar_testing.h"
#include "tests/test_util.h"

namespace pf {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kRadius = 8;  // Of the cylinder around the sensor.
constexpr double kTop = 3;     // Its wall from z = -kTop to kTop.

// Opaque discs 4 cm wide on a cylinder of radius kRadius about the z axis,
// 5 cm apart, flat along its normal.
GaussianScene Cylinder() {
  GaussianScene scene;
  scene.low_pass = 0.1f;
  const int around = static_cast<int>(2 * kPi * kRadius / 0.05);
  for (double z = -kTop; z <= kTop; z += 0.05) {
    for (int a = 0; a < around; ++a) {
      const double phi = 2 * kPi * a / around;
      const size_t i = scene.size();
      scene.Resize(i + 1);
      scene.means[3 * i] = float(kRadius * std::cos(phi));
      scene.means[3 * i + 1] = float(kRadius * std::sin(phi));
      scene.means[3 * i + 2] = float(z);
      // Rotation about z by phi: the disc's x axis along the normal.
      scene.rotations[4 * i] = float(std::cos(phi / 2));
      scene.rotations[4 * i + 1] = scene.rotations[4 * i + 2] = 0;
      scene.rotations[4 * i + 3] = float(std::sin(phi / 2));
      scene.log_scales[3 * i] = std::log(0.001f);
      scene.log_scales[3 * i + 1] = scene.log_scales[3 * i + 2] = std::log(0.04f);
      scene.opacity_logits[i] = 4.f;
      for (int c = 0; c < 3; ++c) scene.features[3 * i + c] = 0.5f;
    }
  }
  return scene;
}

LidarSpec SixteenBeams() {
  LidarSpec spec;
  for (int b = 0; b < 16; ++b) spec.beam_elevations_deg.push_back(10 - 2 * b);  // 10 .. -20.
  spec.beam_elevations_deg.push_back(40);  // Over the wall: no return.
  spec.azimuth_resolution_deg = 1;
  return spec;
}

TEST(LidarSpec, RaysRunBeamByBeamClockwiseFromBehind) {
  const LidarSpec spec = SixteenBeams();
  ASSERT_TRUE(CheckLidarSpec(spec, "spec").ok());
  EXPECT_EQ(LidarColumns(spec), 360);
  const std::vector<LidarRay> rays = LidarSpecRays(spec);
  ASSERT_EQ(rays.size(), 17u * 360u);
  // Beam 1 (8 degrees up), column 180: azimuth 180 - 180.5 = -0.5 degrees,
  // half-way through the sweep.
  const LidarRay& r = rays[360 + 180];
  EXPECT_NEAR(std::asin(r.direction.z) * 180 / kPi, 8, 1e-9);
  EXPECT_NEAR(std::atan2(r.direction.y, r.direction.x) * 180 / kPi, -0.5, 1e-9);
  EXPECT_NEAR(r.sweep_fraction, 180.5 / 360, 1e-12);
  // Column 0 looks behind and a little left, column 359 behind and right.
  EXPECT_NEAR(std::atan2(rays[0].direction.y, rays[0].direction.x) * 180 / kPi, 179.5, 1e-9);
  EXPECT_NEAR(std::atan2(rays[359].direction.y, rays[359].direction.x) * 180 / kPi, -179.5, 1e-9);
}

TEST(LidarSpec, BadSpecsNameTheField) {
  LidarSpec spec = SixteenBeams();
  spec.beam_elevations_deg[3] = 95;
  EXPECT_EQ(CheckLidarSpec(spec, "lidars[0].spec").message(),
            "lidars[0].spec.beamElevationsDeg[3]: must be in (-90, 90) degrees, got 95");
  spec = SixteenBeams();
  spec.azimuth_resolution_deg = 0;
  EXPECT_NE(CheckLidarSpec(spec, "s").message().find("s.azimuthResolutionDeg"), std::string::npos);
  spec = SixteenBeams();
  spec.beam_elevations_deg.clear();
  EXPECT_NE(CheckLidarSpec(spec, "s").message().find("1 to 1024 beams, got 0"), std::string::npos);
}

// Reads a float channel of an EXR by name.
std::vector<float> ReadChannel(const std::string& path, const std::string& name, int* width,
                               int* height, OIIO::ImageSpec* spec_out = nullptr) {
  auto in = OIIO::ImageInput::open(path);
  EXPECT_TRUE(in) << path;
  if (!in) return {};
  const OIIO::ImageSpec& spec = in->spec();
  *width = spec.width, *height = spec.height;
  if (spec_out) *spec_out = spec;
  const int c = spec.channelindex(name);
  EXPECT_GE(c, 0) << name;
  std::vector<float> out(static_cast<size_t>(spec.width) * spec.height);
  EXPECT_TRUE(in->read_image(0, 0, c, c + 1, OIIO::TypeDesc::FLOAT, out.data()));
  return out;
}

std::vector<float> ReadRecords(const std::string& path) {
  absl::StatusOr<std::string> bytes = ReadFileToString(path);
  EXPECT_TRUE(bytes.ok()) << bytes.status();
  std::vector<float> out(bytes->size() / sizeof(float));
  if (!out.empty()) std::memcpy(out.data(), bytes->data(), bytes->size());
  return out;
}

TEST(LidarSpec, ASweepIsTheCylinderInTheRangeImageAndThePointRecord) {
  const GaussianScene scene = Cylinder();
  const LidarSpec spec = SixteenBeams();
  LidarSweepPose pose;  // At the origin, at rest.
  absl::StatusOr<RenderedSweep> sweep = RenderLidarSweep(scene, spec, pose);
  ASSERT_TRUE(sweep.ok()) << sweep.status();
  EXPECT_EQ(sweep->hits, 16 * 360);  // Every beam but the one over the wall.

  const std::string dir = testing::MakeTempDir("lidar_spec");
  ASSERT_TRUE(WriteRangeImageExr(dir + "/s.range.exr", *sweep).ok());
  ASSERT_TRUE(WriteSweepPoints(dir + "/s.lidar.bin", *sweep).ok());
  int width = 0, height = 0;
  OIIO::ImageSpec header;
  const std::vector<float> range =
      ReadChannel(dir + "/s.range.exr", "range", &width, &height, &header);
  const std::vector<float> hit = ReadChannel(dir + "/s.range.exr", "hit", &width, &height);
  ASSERT_EQ(width, 360);
  ASSERT_EQ(height, 17);
  EXPECT_EQ(header.get_string_attribute("pf:timestampUs"), "0");
  EXPECT_DOUBLE_EQ(header.get_float_attribute("pf:rotationHz"), 10);
  double worst = 0;
  for (int b = 0; b < 17; ++b) {
    const double truth = kRadius / std::cos(spec.beam_elevations_deg[b] * kPi / 180);
    for (int k = 0; k < 360; ++k) {
      const size_t i = static_cast<size_t>(b) * 360 + k;
      if (b == 16) {
        EXPECT_EQ(hit[i], 0.f);
        EXPECT_EQ(range[i], 0.f);
        continue;
      }
      ASSERT_EQ(hit[i], 1.f) << b << " " << k;
      worst = std::max(worst, std::abs(range[i] - truth));
    }
  }
  EXPECT_LT(worst, 0.06);  // Discs 5 cm apart on a wall seen at up to 20 degrees.

  const std::vector<float> records = ReadRecords(dir + "/s.lidar.bin");
  ASSERT_EQ(records.size(), 4u * 16 * 360);
  for (size_t p = 0; p < records.size(); p += 4) {
    EXPECT_NEAR(std::hypot(records[p], records[p + 1]), kRadius, 0.06) << p;
    EXPECT_EQ(records[p + 3], 0.f);  // No intensity channel.
  }
}

TEST(LidarSpec, TheIntensityChannelIsWrittenToBothFiles) {
  // The cylinder with a fourth channel, 5 + the disc's height, as its intensity.
  GaussianScene scene = Cylinder();
  testing::AddIntensityChannel(&scene, [&](size_t i) { return 5 + scene.means[3 * i + 2]; });
  const LidarSpec spec = SixteenBeams();
  absl::StatusOr<RenderedSweep> sweep = RenderLidarSweep(scene, spec, LidarSweepPose{});
  ASSERT_TRUE(sweep.ok()) << sweep.status();
  const std::string dir = testing::MakeTempDir("lidar_intensity");
  ASSERT_TRUE(WriteRangeImageExr(dir + "/s.range.exr", *sweep).ok());
  ASSERT_TRUE(WriteSweepPoints(dir + "/s.lidar.bin", *sweep).ok());
  int width = 0, height = 0;
  const std::vector<float> intensity =
      ReadChannel(dir + "/s.range.exr", "intensity", &width, &height);
  ASSERT_EQ(intensity.size(), 17u * 360);
  // A ray at elevation e meets the wall at height kRadius tan(e); discs 5 cm
  // apart blend over about a disc's width.
  double worst = 0;
  for (int b = 0; b < 16; ++b) {
    const double truth = 5 + kRadius * std::tan(spec.beam_elevations_deg[b] * kPi / 180);
    for (int k = 0; k < 360; ++k) worst = std::max(worst, std::abs(intensity[b * 360 + k] - truth));
  }
  EXPECT_LT(worst, 0.06);
  for (int k = 0; k < 360; ++k) EXPECT_EQ(intensity[16 * 360 + k], 0.f);  // No return.
  const std::vector<float> records = ReadRecords(dir + "/s.lidar.bin");
  ASSERT_EQ(records.size(), 4u * 16 * 360);
  for (size_t p = 0; p < records.size(); p += 4) {
    EXPECT_NEAR(records[p + 3], 5 + records[p + 2], 0.06) << p;
  }
}

TEST(LidarSpec, AMovingSensorsPointsAreInItsStartFrame) {
  const GaussianScene scene = Cylinder();
  LidarSpec spec;
  spec.beam_elevations_deg = {0};
  spec.azimuth_resolution_deg = 2;
  // The sensor moves 2 m along x during the sweep.
  LidarSweepPose pose;
  pose.world_from_sensor_end.translation = {2, 0, 0};
  pose.end_us = 100000;
  absl::StatusOr<RenderedSweep> sweep = RenderLidarSweep(scene, spec, pose);
  ASSERT_TRUE(sweep.ok()) << sweep.status();
  const std::string dir = testing::MakeTempDir("lidar_spec_moving");
  ASSERT_TRUE(WriteSweepPoints(dir + "/m.lidar.bin", *sweep).ok());
  const std::vector<float> records = ReadRecords(dir + "/m.lidar.bin");
  ASSERT_EQ(records.size(), 4u * 180);
  // The start frame is the world frame here: every point on the cylinder,
  // though the rays fired from up to 2 m away from the start.
  double worst = 0, farthest_origin_shift = 0;
  for (size_t p = 0; p < records.size(); p += 4) {
    worst =
        std::max(worst, std::abs(std::hypot(double(records[p]), double(records[p + 1])) - kRadius));
  }
  for (int k = 0; k < 180; ++k) {
    // A ray's range differs from the range from the start by the sensor's
    // own motion: the ray straight ahead (column 90) fires half-way, 1 m on.
    if (k == 90) farthest_origin_shift = kRadius - sweep->returns[k].range;
  }
  // Each sector is rendered at its mean time, a ray placed at its own:
  // up to half a sector (7.5 degrees of 360, 4 cm of the 2 m) apart.
  EXPECT_LT(worst, 0.1);
  EXPECT_NEAR(farthest_origin_shift, 1.0, 0.1);
}

TEST(LidarSpec, BeamsAreEstimatedFromASweep) {
  // An uneven 32-beam head (0.39 to 2.2 degrees apart), 0.2 degrees between
  // firings, ranges 3-60 m, elevations jittered by 0.01 degrees.
  LidarSpec truth;
  for (int b = 0; b < 32; ++b) {
    const double t = b / 31.0;
    truth.beam_elevations_deg.push_back(15 - 40 * (0.3 * t + 0.7 * t * t));
  }
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> range(3, 60);
  std::normal_distribution<double> jitter(0, 0.01);
  std::vector<float> xyz;
  for (double e : truth.beam_elevations_deg) {
    for (int k = 0; k < 1800; ++k) {
      if (k % 7 == 3) continue;  // Dropped returns.
      const double a = (180 - (k + 0.5) * 0.2) * kPi / 180, el = (e + jitter(rng)) * kPi / 180;
      const double r = range(rng);
      xyz.insert(xyz.end(), {float(r * std::cos(el) * std::cos(a)),
                             float(r * std::cos(el) * std::sin(a)), float(r * std::sin(el))});
    }
  }
  absl::StatusOr<EstimatedLidarSpec> estimated = EstimateLidarSpec(xyz);
  ASSERT_TRUE(estimated.ok()) << estimated.status();
  ASSERT_EQ(estimated->spec.beam_elevations_deg.size(), 32u);
  for (int b = 0; b < 32; ++b) {
    EXPECT_NEAR(estimated->spec.beam_elevations_deg[b], truth.beam_elevations_deg[b], 0.005) << b;
  }
  EXPECT_NEAR(estimated->spec.azimuth_resolution_deg, 0.2, 0.002);
  EXPECT_NEAR(estimated->elevation_rms_deg, 0.01, 0.003);
  EXPECT_GT(estimated->points, 31 * 1500);

  // Too few points: an error that says how many.
  xyz.resize(3 * 500);
  EXPECT_NE(EstimateLidarSpec(xyz).status().message().find("500 within"), std::string::npos);
}

}  // namespace
}  // namespace pf
