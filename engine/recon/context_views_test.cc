// Tests of decoding a clip's frames and tracks.
#include "engine/recon/context_views.h"

#include <gtest/gtest.h>

#include "engine/clip/clip_test_util.h"
#include "pointforward/v1/clip.pb.h"
#include "tests/test_util.h"

namespace pf {
namespace {

TEST(ContextViews, LoadsContextAndUnspecifiedFramesWithDepthWhereGiven) {
  const std::string dir = testing::MakeTempDir();
  const auto clip = testing::MakeTestClip(dir);
  auto loaded = LoadClip(testing::WriteTestClip(dir, clip));
  ASSERT_TRUE(loaded.ok()) << loaded.status();
  auto views = LoadContextViews(*loaded);
  ASSERT_TRUE(views.ok()) << views.status();
  ASSERT_EQ(views->size(), 2u);
  EXPECT_EQ((*views)[0].camera_id, "front");
  EXPECT_EQ((*views)[0].frame_index, 0);
  EXPECT_EQ((*views)[0].rgb.width, testing::kTestWidth);
  EXPECT_EQ((*views)[0].rgb.channels, 3);
  ASSERT_EQ((*views)[0].depth.width, testing::kTestWidth);
  EXPECT_FLOAT_EQ((*views)[0].depth.at(3, 4), 10.f);
  EXPECT_EQ((*views)[1].camera_id, "left");
  EXPECT_EQ((*views)[1].depth.width, 0);  // "left" has no depth map.

  auto targets = LoadViews(*loaded, FrameSelection::kTarget);
  ASSERT_TRUE(targets.ok()) << targets.status();
  EXPECT_EQ(targets->size(), 4u);
  EXPECT_EQ((*targets)[0].timestamp_us, 100000);
}

TEST(ContextViews, AFramesRollingShutterIsLoadedWithItsEndPose) {
  const std::string dir = testing::MakeTempDir();
  auto clip = testing::MakeTestClip(dir);
  pointforward::v1::RollingShutter* shutter = clip.mutable_frames(1)->mutable_rolling_shutter();
  shutter->set_readout(pointforward::v1::RollingShutter::RIGHT_TO_LEFT);
  shutter->set_readout_us(25000);
  *shutter->mutable_world_from_camera_end() = clip.frames(1).world_from_camera();
  shutter->set_world_from_camera_end(3, clip.frames(1).world_from_camera(3) + 0.4);
  auto loaded = LoadClip(testing::WriteTestClip(dir, clip));
  ASSERT_TRUE(loaded.ok()) << loaded.status();
  auto views = LoadContextViews(*loaded);
  ASSERT_TRUE(views.ok()) << views.status();
  ASSERT_EQ(views->size(), 2u);
  EXPECT_FALSE((*views)[0].rolling_shutter.has_value());
  const ContextView& rolling = (*views)[1];
  ASSERT_TRUE(rolling.rolling_shutter.has_value());
  EXPECT_EQ(rolling.rolling_shutter->readout, RollingShutter::Readout::kRightToLeft);
  EXPECT_EQ(rolling.rolling_shutter->readout_us, 25000);
  EXPECT_NEAR(rolling.rolling_shutter->world_from_camera_end.translation.x,
              rolling.world_from_camera.translation.x + 0.4, 1e-12);
  // Read right to left: the right column at the first pose, the left at the end.
  const double w = rolling.width();
  EXPECT_NEAR(rolling.centre_at(w - 0.5, 3).x, rolling.world_from_camera.translation.x, 1e-12);
  EXPECT_NEAR(rolling.centre_at(0.5, 3).x, rolling.world_from_camera.translation.x + 0.4, 1e-12);
  EXPECT_NEAR(rolling.lines().WorldFromCameraAt(0.5, 3).translation.x,
              rolling.world_from_camera.translation.x + 0.4, 1e-12);

  // A rolling shutter without its readout is refused, naming the field.
  shutter->clear_readout();
  auto broken = LoadClip(testing::WriteTestClip(dir, clip));
  ASSERT_TRUE(broken.ok()) << broken.status();  // Parsed; the validator names it too.
  auto refused = LoadContextViews(*broken);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(std::string(refused.status().message()).find("frames[1].rollingShutter.readout"),
            std::string::npos)
      << refused.status();
}

TEST(ContextViews, MissingImageNamesTheFrame) {
  const std::string dir = testing::MakeTempDir();
  auto clip = testing::MakeTestClip(dir);
  clip.mutable_frames(1)->set_image("images/nope.png");
  auto loaded = LoadClip(testing::WriteTestClip(dir, clip));
  ASSERT_TRUE(loaded.ok()) << loaded.status();
  auto views = LoadContextViews(*loaded);
  ASSERT_FALSE(views.ok());
  EXPECT_NE(std::string(views.status().message()).find("frames[1].image"), std::string::npos)
      << views.status();
}

TEST(ContextViews, TracksAreSortedAndBadBoxesNamed) {
  pointforward::v1::Clip clip;
  auto* instance = clip.add_instances();
  instance->set_id("car");
  for (int64_t t : {200, 100}) {
    auto* box = instance->add_boxes();
    box->set_timestamp_us(t);
    for (double v : {1.0, 2.0, 3.0}) box->add_center(v);
    for (double v : {4.0, 2.0, 1.5}) box->add_size(v);
    for (double v : {2.0, 0.0, 0.0, 0.0}) box->add_rotation(v);
  }
  auto tracks = TracksFromClip(clip);
  ASSERT_TRUE(tracks.ok()) << tracks.status();
  ASSERT_EQ((*tracks)[0].boxes.size(), 2u);
  EXPECT_EQ((*tracks)[0].boxes[0].timestamp_us, 100);
  EXPECT_DOUBLE_EQ((*tracks)[0].boxes[0].rotation.w, 1.0);  // Normalised.

  instance->mutable_boxes(1)->clear_size();
  auto bad = TracksFromClip(clip);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(std::string(bad.status().message()).find("instances[0].boxes[1]"), std::string::npos);
}

}  // namespace
}  // namespace pf
