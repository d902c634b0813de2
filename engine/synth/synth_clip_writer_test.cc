// Tests of the clip directory `pf synth` writes: manifest, roles, files and
// their agreement with the ray caster.
#include "engine/synth/synth_clip_writer.h"

#include <google/protobuf/util/json_util.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <set>

#include "common/file_util.h"
#include "engine/image/image_io.h"
#include "engine/synth/synth_params.h"
#include "engine/synth/synth_ray_caster.h"
#include "tests/test_util.h"

namespace pf {
namespace {

namespace v1 = pointforward::v1;

SynthOptions SmallOptions() {
  SynthOptions options;
  options.seed = 11;
  options.num_frames = 6;
  options.width = 96;
  options.height = 72;
  options.antialias = 1;
  return options;
}

TEST(SynthClipWriter, ManifestFollowsTheProtocol) {
  SynthOptions options;  // Defaults: 3 cameras, 20 frames.
  auto scene = GenerateSynthScene(options);
  ASSERT_TRUE(scene.ok());
  const v1::Clip clip = BuildSynthClip(*scene);
  ASSERT_EQ(clip.cameras_size(), 3);
  EXPECT_EQ(clip.cameras(1).id(), "cam_front");
  EXPECT_DOUBLE_EQ(clip.cameras(1).intrinsics().cx(), 384.0);
  EXPECT_DOUBLE_EQ(clip.cameras(1).intrinsics().cy(), 288.0);
  ASSERT_EQ(clip.frames_size(), 60);
  std::set<int64_t> context_times;
  int context = 0;
  for (const v1::Frame& frame : clip.frames()) {
    const bool is_context = frame.role() == v1::Frame::CONTEXT;
    EXPECT_TRUE(is_context || frame.role() == v1::Frame::TARGET);
    if (is_context) {
      ++context;
      context_times.insert(frame.timestamp_us());
    }
    ASSERT_EQ(frame.world_from_camera_size(), 16);
    EXPECT_LT(RigidityError(frame.world_from_camera().data()), 1e-12);
    EXPECT_EQ(frame.image(),
              "images/" + frame.camera() + "_" + std::to_string(frame.timestamp_us()) + ".png");
    EXPECT_EQ(frame.depth(),
              "depth/" + frame.camera() + "_" + std::to_string(frame.timestamp_us()) + ".exr");
  }
  EXPECT_EQ(context, 12);
  EXPECT_EQ(context_times, (std::set<int64_t>{0, 500000, 1000000, 1500000}));
  ASSERT_EQ(clip.lidar_size(), 20);
  EXPECT_EQ(clip.lidar(3).points(), "lidar/300000.bin");
  ASSERT_EQ(clip.instances_size(), static_cast<int>(scene->vehicles.size()));
  for (const v1::Instance& instance : clip.instances()) {
    ASSERT_EQ(instance.boxes_size(), 20);
    for (const v1::Box& box : instance.boxes()) {
      ASSERT_EQ(box.center_size(), 3);
      ASSERT_EQ(box.size_size(), 3);
      ASSERT_EQ(box.rotation_size(), 4);
      EXPECT_GT(box.size(0), box.size(1));  // Longer than wide.
      EXPECT_NEAR(QuatNorm({box.rotation(0), box.rotation(1), box.rotation(2), box.rotation(3)}),
                  1.0, 1e-9);
    }
    // The box moves over the clip.
    EXPECT_GT(std::abs(instance.boxes(19).center(0) - instance.boxes(0).center(0)) +
                  std::abs(instance.boxes(19).center(1) - instance.boxes(0).center(1)),
              5.0)
        << instance.id();
  }
}

TEST(SynthClipWriter, WritesFilesThatAgreeWithTheScene) {
  const std::string dir = testing::MakeTempDir("synth_clip");
  const SynthOptions options = SmallOptions();
  const auto summary = WriteSynthClip(options, dir);
  ASSERT_TRUE(summary.ok()) << summary.status();
  EXPECT_EQ(summary->frames, 18);
  EXPECT_EQ(summary->context_frames, 6);  // t = 0 and 0.5 s.
  EXPECT_EQ(summary->target_frames, 12);
  EXPECT_EQ(summary->lidar_sweeps, 6);

  // clip.json is lowerCamelCase proto3 JSON of the manifest.
  const auto json = ReadFileToString(dir + "/clip.json");
  ASSERT_TRUE(json.ok());
  EXPECT_NE(json->find("\"worldFromCamera\""), std::string::npos);
  EXPECT_NE(json->find("\"timestampUs\""), std::string::npos);
  v1::Clip clip;
  ASSERT_TRUE(google::protobuf::util::JsonStringToMessage(*json, &clip).ok());
  ASSERT_EQ(clip.frames_size(), 18);

  // synth.json regenerates the same options.
  const auto params = ReadSynthParams(dir + "/synth.json");
  ASSERT_TRUE(params.ok()) << params.status();
  EXPECT_EQ(params->seed, options.seed);
  EXPECT_EQ(params->width, options.width);

  auto scene = GenerateSynthScene(options);
  ASSERT_TRUE(scene.ok());
  for (const v1::Frame& frame : clip.frames()) {
    const auto info = ReadImageInfo(dir + "/" + frame.image());
    ASSERT_TRUE(info.ok()) << info.status();
    EXPECT_EQ(info->width, 96);
    EXPECT_EQ(info->height, 72);
  }
  // A depth map read back equals the ray caster's depth at the frame's pose.
  const v1::Frame& frame = clip.frames(4);
  const auto depth = ReadDepth(dir + "/" + frame.depth());
  ASSERT_TRUE(depth.ok()) << depth.status();
  const int cam = scene->FindCamera(frame.camera());
  ASSERT_GE(cam, 0);
  const double t = frame.timestamp_us() * 1e-6;
  const RenderedView view = RenderView(SnapshotAt(*scene, t), scene->cameras[cam].model,
                                       Rigid::FromRowMajor(frame.world_from_camera().data()), 1);
  ASSERT_EQ(depth->pixels.size(), view.depth.pixels.size());
  for (size_t i = 0; i < view.depth.pixels.size(); ++i) {
    ASSERT_NEAR(depth->pixels[i], view.depth.pixels[i], 1e-5 * (1 + view.depth.pixels[i]));
  }
  // The PNG is the rendered colour, quantised to 8 bits.
  const auto image = ReadImage(dir + "/" + frame.image(), 3);
  ASSERT_TRUE(image.ok());
  for (size_t i = 0; i < view.rgb.pixels.size(); ++i) {
    ASSERT_NEAR(image->pixels[i], view.rgb.pixels[i], 0.5 / 255 + 1e-6);
  }

  // LiDAR files hold whole float32 records and lie within range.
  for (const v1::LidarSweep& sweep : clip.lidar()) {
    const auto bytes = ReadFileToString(dir + "/" + sweep.points());
    ASSERT_TRUE(bytes.ok());
    ASSERT_GT(bytes->size(), 0u);
    ASSERT_EQ(bytes->size() % 16, 0u);
    std::vector<float> points(bytes->size() / 4);
    std::memcpy(points.data(), bytes->data(), bytes->size());
    for (size_t i = 0; i < points.size(); i += 4) {
      ASSERT_LE(std::hypot(points[i], points[i + 1], points[i + 2]), 80.01);
    }
  }
}

TEST(SynthClipWriter, EncodesLidarLittleEndian) {
  const std::string bytes = EncodeLidarPoints({1.0f, -2.0f});
  ASSERT_EQ(bytes.size(), 8u);
  EXPECT_EQ(static_cast<unsigned char>(bytes[2]), 0x80);
  EXPECT_EQ(static_cast<unsigned char>(bytes[3]), 0x3F);
  EXPECT_EQ(static_cast<unsigned char>(bytes[7]), 0xC0);
}

TEST(SynthClipWriter, RejectsBadOptions) {
  SynthOptions options = SmallOptions();
  options.antialias = 9;
  const auto status = WriteSynthClip(options, testing::MakeTempDir("synth_bad")).status();
  EXPECT_TRUE(absl::IsInvalidArgument(status));
  EXPECT_NE(std::string(status.message()).find("antialias"), std::string::npos);
}

}  // namespace
}  // namespace pf
