// Tests of the Waymo range-image conversion on small range images built here,
// with answers worked out by hand from the documented geometry.
#include "engine/importers/waymo_lidar.h"

#include <gtest/gtest.h>
#include <zlib.h>

#include <cmath>
#include <string>

namespace pf {
namespace {

namespace waymo = pointforward::waymo;

// Returns zlib(MatrixFloat{values, shape [h, w, c]}).
std::string CompressedMatrix(int h, int w, int c, const std::vector<float>& values) {
  waymo::MatrixFloat m;
  for (float v : values) m.add_data(v);
  for (int d : {h, w, c}) m.mutable_shape()->add_dims(d);
  const std::string raw = m.SerializeAsString();
  uLongf size = compressBound(raw.size());
  std::string out(size, '\0');
  compress(reinterpret_cast<Bytef*>(out.data()), &size, reinterpret_cast<const Bytef*>(raw.data()),
           raw.size());
  out.resize(size);
  return out;
}

void SetTransform(const Rigid& t, waymo::Transform* out) {
  for (double v : t.ToRowMajor()) out->add_transform(v);
}

// A frame with one TOP laser turned 30 degrees about z, 1 m ahead and 2 m up,
// beams at -0.1 and +0.1 rad, a 2 x 4 range image of 10 m returns (intensity
// = 0.25 * column) except one pixel without a return.
waymo::Frame MakeFrame() {
  waymo::Frame frame;
  waymo::LaserCalibration* cal = frame.mutable_context()->add_laser_calibrations();
  cal->set_name(waymo::LaserName::TOP);
  cal->add_beam_inclinations(-0.1);
  cal->add_beam_inclinations(0.1);
  SetTransform(Rigid{RotationZ(M_PI / 6), Vec3{1, 0, 2}}, cal->mutable_extrinsic());
  std::vector<float> values;
  for (int row = 0; row < 2; ++row) {
    for (int col = 0; col < 4; ++col) {
      const bool hole = row == 1 && col == 3;
      values.insert(values.end(), {hole ? -1.0f : 10.0f, 0.25f * col, 0.0f, 0.0f});
    }
  }
  waymo::Laser* laser = frame.add_lasers();
  laser->set_name(waymo::LaserName::TOP);
  laser->mutable_ri_return1()->set_range_image_compressed(CompressedMatrix(2, 4, 4, values));
  return frame;
}

TEST(WaymoLidar, ConvertsRangeImageByBeamAndColumn) {
  const waymo::Frame frame = MakeFrame();
  ASSERT_TRUE(HasWaymoRangeImages(frame));
  auto points = WaymoRangeImagesToPoints(frame, Rigid{});
  ASSERT_TRUE(points.ok()) << points.status();
  ASSERT_EQ(points->size(), 7u * 4);  // 8 pixels, one without a return.
  // Row 0, column 1: the highest beam (+0.1 rad); column 1 of 4 looks at
  // ((4 - 1 - 0.5) / 4 * 2 - 1) * pi = +45 degrees in the vehicle frame (the
  // laser's own 30 degrees are taken out, then put back by its extrinsic).
  const float* p = &(*points)[1 * 4];
  const Vec3 from_laser = Vec3{p[0], p[1], p[2]} - Vec3{1, 0, 2};
  EXPECT_NEAR(Norm(from_laser), 10.0, 1e-4);
  EXPECT_NEAR(std::asin(from_laser.z / 10.0), 0.1, 1e-5);
  EXPECT_NEAR(std::atan2(from_laser.y, from_laser.x), M_PI / 4, 1e-5);
  EXPECT_FLOAT_EQ(p[3], 0.25f);
  // Row 1, column 2: the lower beam, azimuth -45 degrees.
  const float* q = &(*points)[(4 + 2) * 4];
  const Vec3 q_from_laser = Vec3{q[0], q[1], q[2]} - Vec3{1, 0, 2};
  EXPECT_NEAR(std::asin(q_from_laser.z / 10.0), -0.1, 1e-5);
  EXPECT_NEAR(std::atan2(q_from_laser.y, q_from_laser.x), -M_PI / 4, 1e-5);
}

TEST(WaymoLidar, PixelPosesMoveReturnsIntoTheFramePose) {
  waymo::Frame frame = MakeFrame();
  // Every pixel was taken with the car 2 m further along world x than the
  // frame pose: the points must come out 2 m further ahead.
  std::vector<float> poses;
  for (int i = 0; i < 8; ++i) poses.insert(poses.end(), {0, 0, 0, 2, 0, 0});
  frame.mutable_lasers(0)->mutable_ri_return1()->set_range_image_pose_compressed(
      CompressedMatrix(2, 4, 6, poses));
  const auto still = WaymoRangeImagesToPoints(MakeFrame(), Rigid{});
  const auto moved = WaymoRangeImagesToPoints(frame, Rigid{});
  ASSERT_TRUE(still.ok() && moved.ok());
  ASSERT_EQ(still->size(), moved->size());
  for (size_t i = 0; i < still->size(); i += 4) {
    EXPECT_NEAR((*moved)[i] - (*still)[i], 2.0, 1e-4);
    EXPECT_NEAR((*moved)[i + 1], (*still)[i + 1], 1e-4);
  }
}

TEST(WaymoLidar, UniformInclinationsWhenTheCalibrationListsNone) {
  waymo::Frame frame = MakeFrame();
  auto* cal = frame.mutable_context()->mutable_laser_calibrations(0);
  cal->clear_beam_inclinations();
  cal->set_beam_inclination_min(-0.2);
  cal->set_beam_inclination_max(0.2);
  auto points = WaymoRangeImagesToPoints(frame, Rigid{});
  ASSERT_TRUE(points.ok()) << points.status();
  // Two rows split [-0.2, 0.2] into halves: centres at +0.1 (row 0), -0.1.
  const float* p = &(*points)[0];
  EXPECT_NEAR(std::asin((p[2] - 2.0) / 10.0), 0.1, 1e-5);
}

TEST(WaymoLidar, RejectsMissingCalibrationAndDamagedData) {
  waymo::Frame frame = MakeFrame();
  frame.mutable_context()->clear_laser_calibrations();
  const auto no_cal = WaymoRangeImagesToPoints(frame, Rigid{});
  EXPECT_EQ(no_cal.status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(std::string(no_cal.status().message()).find("lasers[TOP]"), std::string::npos);

  waymo::Frame damaged = MakeFrame();
  damaged.mutable_lasers(0)->mutable_ri_return1()->set_range_image_compressed("not zlib");
  EXPECT_EQ(WaymoRangeImagesToPoints(damaged, Rigid{}).status().code(),
            absl::StatusCode::kDataLoss);
}

}  // namespace
}  // namespace pf
