// Tests of the binary scene file: exact round trips and every rejection.
#include "engine/render/scene_file.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>

#include "absl/strings/str_cat.h"
#include "common/file_util.h"
#include "common/hash.h"
#include "tests/test_util.h"

namespace pf {
namespace {

namespace fs = std::filesystem;

// A small scene with SH, 4 channels, an instance and a few finite lifespans.
GaussianScene MakeScene() {
  GaussianScene scene;
  scene.num_channels = 4;
  scene.sh_degree = 1;
  scene.time_origin_us = 1'700'000'000'123'456;
  scene.low_pass = 0.1f;
  InstanceTrack car;
  car.id = "car1";
  car.category = "car";
  car.boxes.push_back({1'700'000'000'123'456, {1, 2, 3}, {4.5, 1.8, 1.5}, {1, 0, 0, 0}});
  car.boxes.push_back(
      {1'700'000'000'623'456, {3, 2, 3}, {4.5, 1.8, 1.5}, QuatNormalized({0.9, 0.05, -0.03, 0.1})});
  scene.instances.push_back(car);
  scene.Resize(7);
  for (size_t i = 0; i < scene.size(); ++i) {
    for (int a = 0; a < 3; ++a) {
      scene.means[3 * i + a] = 0.5f * i - a;
      scene.log_scales[3 * i + a] = -1.f - 0.1f * a;
    }
    scene.rotations[4 * i + 1] = 0.1f * i;
    scene.opacity_logits[i] = 0.25f * i - 1.f;
    for (int c = 0; c < scene.num_channels; ++c) scene.features[i * 4 + c] = 0.1f * (c + i);
    for (int k = 0; k < 3 * scene.sh_coeffs(); ++k) scene.sh[i * 12 + k] = 0.01f * (k - 5) * i;
    scene.times[i] = 0.05f * i;
    if (i % 2 == 1) scene.lifespans[i] = 0.3f;
    scene.owners[i] = i >= 5 ? 1 : 0;
  }
  return scene;
}

void ExpectScenesEqual(const GaussianScene& a, const GaussianScene& b) {
  EXPECT_EQ(a.num_channels, b.num_channels);
  EXPECT_EQ(a.sh_degree, b.sh_degree);
  EXPECT_EQ(a.time_origin_us, b.time_origin_us);
  EXPECT_EQ(a.low_pass, b.low_pass);
  EXPECT_EQ(a.order_band, b.order_band);
  EXPECT_EQ(a.fade_span.begin, b.fade_span.begin);
  EXPECT_EQ(a.fade_span.end, b.fade_span.end);
  EXPECT_EQ(a.render_blur, b.render_blur);
  EXPECT_EQ(a.render_blur_growth, b.render_blur_growth);
  ASSERT_EQ(a.blur_anchors.size(), b.blur_anchors.size());
  for (size_t k = 0; k < a.blur_anchors.size(); ++k) {
    EXPECT_EQ(a.blur_anchors[k].centre, b.blur_anchors[k].centre);
    EXPECT_EQ(a.blur_anchors[k].axis, b.blur_anchors[k].axis);
  }
  EXPECT_EQ(a.colour_encoding, b.colour_encoding);
  EXPECT_EQ(a.lidar_intensity_channel, b.lidar_intensity_channel);
  EXPECT_EQ(a.means, b.means);
  EXPECT_EQ(a.rotations, b.rotations);
  EXPECT_EQ(a.log_scales, b.log_scales);
  EXPECT_EQ(a.opacity_logits, b.opacity_logits);
  EXPECT_EQ(a.features, b.features);
  EXPECT_EQ(a.sh, b.sh);
  EXPECT_EQ(a.times, b.times);
  EXPECT_EQ(a.lifespans, b.lifespans);
  EXPECT_EQ(a.owners, b.owners);
  EXPECT_EQ(a.colour_gradients, b.colour_gradients);
  ASSERT_EQ(a.instances.size(), b.instances.size());
  for (size_t k = 0; k < a.instances.size(); ++k) {
    EXPECT_EQ(a.instances[k].id, b.instances[k].id);
    EXPECT_EQ(a.instances[k].category, b.instances[k].category);
    ASSERT_EQ(a.instances[k].boxes.size(), b.instances[k].boxes.size());
    for (size_t j = 0; j < a.instances[k].boxes.size(); ++j) {
      const TrackBox& x = a.instances[k].boxes[j];
      const TrackBox& y = b.instances[k].boxes[j];
      EXPECT_EQ(x.timestamp_us, y.timestamp_us);
      for (int i = 0; i < 3; ++i) {
        EXPECT_EQ(x.center[i], y.center[i]);
        EXPECT_EQ(x.size[i], y.size[i]);
      }
      EXPECT_EQ(x.rotation.w, y.rotation.w);
      EXPECT_EQ(x.rotation.x, y.rotation.x);
      EXPECT_EQ(x.rotation.y, y.rotation.y);
      EXPECT_EQ(x.rotation.z, y.rotation.z);
    }
  }
}

class SceneFileTest : public ::testing::Test {
 protected:
  void SetUp() override { path_ = testing::MakeTempDir("scene_file") + "/scene.pfscene"; }

  // Saves MakeScene(), lets `edit` change the bytes, and returns the load status.
  template <typename Edit>
  absl::Status LoadEdited(Edit edit) {
    EXPECT_TRUE(SaveScene(MakeScene(), path_).ok());
    std::string bytes = *ReadFileToString(path_);
    edit(bytes);
    EXPECT_TRUE(WriteFileAtomic(path_, bytes).ok());
    return ReadSceneFile(path_).status();
  }

  std::string path_;
};

TEST_F(SceneFileTest, RoundTripPreservesEveryArrayAndMetadata) {
  const GaussianScene scene = MakeScene();
  ASSERT_TRUE(SaveScene(scene, path_, {{"model", "analytic"}, {"clip", "abc"}}).ok());
  absl::StatusOr<SceneFile> loaded = ReadSceneFile(path_);
  ASSERT_TRUE(loaded.ok()) << loaded.status();
  ExpectScenesEqual(scene, loaded->scene);
  EXPECT_TRUE(std::isinf(loaded->scene.lifespans[0]));
  EXPECT_EQ(loaded->metadata.at("model"), "analytic");
  EXPECT_EQ(loaded->metadata.at("clip"), "abc");
  EXPECT_EQ(loaded->checksum_hex.size(), 64u);
  // The same content gives the same checksum; different content another.
  const std::string other = path_ + ".2";
  ASSERT_TRUE(SaveScene(scene, other, {{"model", "analytic"}, {"clip", "abc"}}).ok());
  EXPECT_EQ(ReadSceneFile(other)->checksum_hex, loaded->checksum_hex);
  ASSERT_TRUE(SaveScene(scene, other).ok());
  EXPECT_NE(ReadSceneFile(other)->checksum_hex, loaded->checksum_hex);
}

TEST_F(SceneFileTest, RoundTripWithoutShAndEmptyScene) {
  GaussianScene scene = MakeScene();
  scene.sh_degree = -1;
  scene.sh.clear();
  ASSERT_TRUE(SaveScene(scene, path_).ok());
  absl::StatusOr<GaussianScene> loaded = LoadScene(path_);
  ASSERT_TRUE(loaded.ok()) << loaded.status();
  ExpectScenesEqual(scene, *loaded);

  GaussianScene empty;
  ASSERT_TRUE(SaveScene(empty, path_).ok());
  loaded = LoadScene(path_);
  ASSERT_TRUE(loaded.ok()) << loaded.status();
  EXPECT_EQ(loaded->size(), 0u);
  EXPECT_EQ(loaded->num_channels, 3);
}

TEST_F(SceneFileTest, FileSizeIsHeaderPlusArraysPlusChecksum) {
  const GaussianScene scene = MakeScene();
  ASSERT_TRUE(SaveScene(scene, path_).ok());
  const std::string bytes = *ReadFileToString(path_);
  uint32_t header_bytes = 0;
  std::memcpy(&header_bytes, bytes.data() + 12, 4);
  // Per Gaussian: 3 + 4 + 3 + 1 + 4 features + 12 SH + 3 = 30 four-byte values.
  EXPECT_EQ(bytes.size(), 16 + header_bytes + 7 * 30 * 4 + 32);
  EXPECT_TRUE(LooksLikeSceneFile(path_));
  // No temporary file is left beside it.
  int files = 0;
  for (const auto& entry : fs::directory_iterator(fs::path(path_).parent_path())) {
    (void)entry;
    ++files;
  }
  EXPECT_EQ(files, 1);
}

TEST_F(SceneFileTest, RejectsWrongMagic) {
  const absl::Status status = LoadEdited([](std::string& b) { b[0] = 'X'; });
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(status.message().find("wrong magic"), absl::string_view::npos) << status;
  EXPECT_NE(status.message().find(path_), absl::string_view::npos) << status;
  EXPECT_FALSE(LooksLikeSceneFile(path_));
}

TEST_F(SceneFileTest, RejectsWrongVersion) {
  for (int version : {0, 12}) {
    const absl::Status status =
        LoadEdited([version](std::string& b) { b[8] = static_cast<char>(version); });
    EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
    EXPECT_NE(status.message().find(absl::StrCat("unsupported scene file version ", version,
                                                 " (this build reads versions 1 to 11)")),
              absl::string_view::npos)
        << status;
  }
}

// Rewrites the file at `path` as an older version: drops `drop` header
// bytes at `offset`, sets the version and header size, fixes the checksum.
void RewriteAsVersion(const std::string& path, uint32_t version, size_t offset, size_t drop) {
  std::string bytes = *ReadFileToString(path);
  uint32_t header_bytes = 0;
  std::memcpy(&header_bytes, bytes.data() + 12, 4);
  if (version < 11) {  // Nor the blur's growth and anchor count (byte 72; no anchors).
    bytes.erase(72, 8);
    header_bytes -= 8;
  }
  if (version < 10) {  // Nor the render blur (a float32 at byte 68).
    bytes.erase(68, 4);
    header_bytes -= 4;
  }
  if (version < 8) {  // Nor the fade span (two float32 at byte 60).
    bytes.erase(60, 8);
    header_bytes -= 8;
  }
  bytes.erase(offset, drop);
  header_bytes -= static_cast<uint32_t>(drop);
  if (version < 7) {  // Nor the ego layer count (0) at the header's end.
    bytes.erase(16 + header_bytes - 4, 4);
    header_bytes -= 4;
  }
  std::memcpy(bytes.data() + 8, &version, 4);
  std::memcpy(bytes.data() + 12, &header_bytes, 4);
  Sha256 hasher;
  hasher.Update(bytes.data(), bytes.size() - 32);
  const std::array<uint8_t, 32> digest = hasher.Finish();
  std::memcpy(bytes.data() + bytes.size() - 32, digest.data(), 32);
  ASSERT_TRUE(WriteFileAtomic(path, bytes).ok());
}

TEST_F(SceneFileTest, RoundTripWithColourGradients) {
  GaussianScene scene = MakeScene();
  scene.sh_degree = -1;
  scene.sh.clear();
  scene.colour_gradients.resize(6 * scene.size());
  for (size_t k = 0; k < scene.colour_gradients.size(); ++k) {
    scene.colour_gradients[k] = 0.01f * static_cast<float>(k) - 0.2f;
  }
  ASSERT_TRUE(SaveScene(scene, path_).ok());
  absl::StatusOr<SceneFile> loaded = ReadSceneFile(path_);
  ASSERT_TRUE(loaded.ok()) << loaded.status();
  EXPECT_EQ(loaded->version, kSceneFileVersion);
  ExpectScenesEqual(scene, loaded->scene);
  // 6 more floats per Gaussian than the same scene with flat colours.
  const std::string flat_path = path_ + ".flat";
  GaussianScene flat = scene;
  flat.colour_gradients.clear();
  ASSERT_TRUE(SaveScene(flat, flat_path).ok());
  EXPECT_EQ(ReadFileToString(path_)->size(),
            ReadFileToString(flat_path)->size() + 6 * 4 * scene.size());

  // Bad gradients are named: with SH, the wrong size, not finite.
  GaussianScene bad = scene;
  bad.sh_degree = 0;
  bad.sh.assign(3 * scene.size(), 0.f);
  EXPECT_NE(SaveScene(bad, path_).message().find("colour_gradients"), absl::string_view::npos);
  bad = scene;
  bad.colour_gradients.pop_back();
  EXPECT_NE(SaveScene(bad, path_).message().find("colour_gradients"), absl::string_view::npos);
  bad = scene;
  bad.colour_gradients[13] = std::numeric_limits<float>::infinity();
  EXPECT_NE(SaveScene(bad, path_).message().find("colour_gradients[2]"), absl::string_view::npos);
}

TEST_F(SceneFileTest, RoundTripKeepsLinearColours) {
  GaussianScene scene = MakeScene();
  scene.colour_encoding = ColourEncoding::kLinear;
  ASSERT_TRUE(SaveScene(scene, path_).ok());
  uint32_t flag = 7;
  std::memcpy(&flag, ReadFileToString(path_)->data() + 48, 4);
  EXPECT_EQ(flag, 1u);
  absl::StatusOr<SceneFile> loaded = ReadSceneFile(path_);
  ASSERT_TRUE(loaded.ok()) << loaded.status();
  EXPECT_EQ(loaded->scene.colour_encoding, ColourEncoding::kLinear);
  ExpectScenesEqual(scene, loaded->scene);
}

TEST_F(SceneFileTest, RoundTripKeepsTheFadeSpanAndVersionSevenFilesHaveNone) {
  GaussianScene scene = MakeScene();
  scene.fade_span = {-0.25f, 1.5f};
  ASSERT_TRUE(SaveScene(scene, path_).ok());
  float stored[2] = {0, 0};
  std::memcpy(stored, ReadFileToString(path_)->data() + 60, 8);
  EXPECT_EQ(stored[0], -0.25f);
  EXPECT_EQ(stored[1], 1.5f);
  absl::StatusOr<SceneFile> loaded = ReadSceneFile(path_);
  ASSERT_TRUE(loaded.ok()) << loaded.status();
  ExpectScenesEqual(scene, loaded->scene);
  // A version-7 file is a version-8 file without the fade span: unbounded.
  RewriteAsVersion(path_, 7, 0, 0);
  loaded = ReadSceneFile(path_);
  ASSERT_TRUE(loaded.ok()) << loaded.status();
  EXPECT_EQ(loaded->version, 7u);
  EXPECT_FALSE(loaded->scene.fade_span.bounded());
  scene.fade_span = FadeSpan{};
  ExpectScenesEqual(scene, loaded->scene);
  // Not an interval: refused, naming it.
  scene.fade_span = {2.f, 1.f};
  const absl::Status status = SaveScene(scene, path_);
  EXPECT_NE(status.message().find("fade_span: [2, 1] is not an interval"), absl::string_view::npos)
      << status;
}

TEST_F(SceneFileTest, RoundTripKeepsTheRenderBlurAndVersionNineFilesHaveNone) {
  GaussianScene scene = MakeScene();
  scene.render_blur = 1.25f;
  ASSERT_TRUE(SaveScene(scene, path_).ok());
  float stored = 0;
  std::memcpy(&stored, ReadFileToString(path_)->data() + 68, 4);
  EXPECT_EQ(stored, 1.25f);
  absl::StatusOr<SceneFile> loaded = ReadSceneFile(path_);
  ASSERT_TRUE(loaded.ok()) << loaded.status();
  ExpectScenesEqual(scene, loaded->scene);
  // A version-9 file is a version-10 file without it: no blur.
  RewriteAsVersion(path_, 9, 0, 0);
  loaded = ReadSceneFile(path_);
  ASSERT_TRUE(loaded.ok()) << loaded.status();
  EXPECT_EQ(loaded->version, 9u);
  EXPECT_EQ(loaded->scene.render_blur, 0.f);
  // Outside [0, 4]: refused on save, by name.
  scene.render_blur = 5.f;
  EXPECT_NE(SaveScene(scene, path_).message().find("render_blur: 5 pixels is outside [0, 4]"),
            absl::string_view::npos);
}

TEST_F(SceneFileTest, RoundTripKeepsTheBlursGrowthAndAnchorsAndVersionTenFilesHaveNone) {
  GaussianScene scene = MakeScene();
  scene.render_blur = 0.5f;
  scene.render_blur_growth = 2.5f;
  scene.blur_anchors = {{{1.5f, -2.f, 0.25f}, {0.f, 0.6f, 0.8f}}, {{-3.f, 4.f, 1.f}, {1.f, 0, 0}}};
  ASSERT_TRUE(SaveScene(scene, path_).ok());
  const std::string bytes = *ReadFileToString(path_);
  float growth = 0, centre_y = 0;
  uint32_t anchors = 0;
  std::memcpy(&growth, bytes.data() + 72, 4);
  std::memcpy(&anchors, bytes.data() + 76, 4);
  std::memcpy(&centre_y, bytes.data() + 84, 4);
  EXPECT_EQ(growth, 2.5f);
  EXPECT_EQ(anchors, 2u);
  EXPECT_EQ(centre_y, -2.f);
  absl::StatusOr<SceneFile> loaded = ReadSceneFile(path_);
  ASSERT_TRUE(loaded.ok()) << loaded.status();
  EXPECT_EQ(loaded->version, 11u);
  ExpectScenesEqual(scene, loaded->scene);
  // An anchor whose axis is not of unit length in the file: refused, by name
  // (the header is checked before the checksum).
  {
    std::string edited = bytes;
    const float two = 2.f;
    std::memcpy(edited.data() + 80 + 24 + 12, &two, 4);  // The second anchor's axis x.
    ASSERT_TRUE(WriteFileAtomic(path_, edited).ok());
    const absl::Status status = ReadSceneFile(path_).status();
    EXPECT_NE(status.message().find("header blur anchor 1: axis of length 2, not 1"),
              absl::string_view::npos)
        << status;
  }
  // A version-10 file is a version-11 file without them: no growth.
  scene.blur_anchors.clear();
  ASSERT_TRUE(SaveScene(scene, path_).ok());
  RewriteAsVersion(path_, 10, 0, 0);
  loaded = ReadSceneFile(path_);
  ASSERT_TRUE(loaded.ok()) << loaded.status();
  EXPECT_EQ(loaded->version, 10u);
  EXPECT_EQ(loaded->scene.render_blur, 0.5f);
  EXPECT_EQ(loaded->scene.render_blur_growth, 0.f);
  EXPECT_TRUE(loaded->scene.blur_anchors.empty());
  // Refused on save, by name: a growth out of range, an axis not of unit
  // length, a centre that is not finite.
  scene.render_blur_growth = 150.f;
  EXPECT_NE(
      SaveScene(scene, path_).message().find("render_blur_growth: 150 mrad/m is outside [0, 100]"),
      absl::string_view::npos);
  scene.render_blur_growth = 2.f;
  scene.blur_anchors = {{{0, 0, 0}, {0, 0, 1}}, {{0, 0, 0}, {0, 0, 2}}};
  EXPECT_NE(SaveScene(scene, path_).message().find("blur_anchors[1]: axis of length 2, not 1"),
            absl::string_view::npos)
      << SaveScene(scene, path_);
  scene.blur_anchors = {{{0, std::nanf(""), 0}, {0, 0, 1}}};
  EXPECT_NE(SaveScene(scene, path_).message().find("blur_anchors[0]: a coordinate is not finite"),
            absl::string_view::npos);
}

TEST_F(SceneFileTest, RoundTripKeepsTheOrderBandAndVersionFourFilesHaveNone) {
  GaussianScene scene = MakeScene();
  scene.order_band = 0.002f;
  ASSERT_TRUE(SaveScene(scene, path_).ok());
  float stored = 0;
  std::memcpy(&stored, ReadFileToString(path_)->data() + 52, 4);
  EXPECT_EQ(stored, 0.002f);
  absl::StatusOr<SceneFile> loaded = ReadSceneFile(path_);
  ASSERT_TRUE(loaded.ok()) << loaded.status();
  EXPECT_EQ(loaded->scene.order_band, 0.002f);
  ExpectScenesEqual(scene, loaded->scene);
  // A version-4 file is a version-6 file without the order band (a float32
  // after the colour-encoding flag, at byte 52) and the intensity channel
  // after it: strict depth order.
  RewriteAsVersion(path_, 4, 52, 8);
  loaded = ReadSceneFile(path_);
  ASSERT_TRUE(loaded.ok()) << loaded.status();
  EXPECT_EQ(loaded->version, 4u);
  scene.order_band = 0;
  ExpectScenesEqual(scene, loaded->scene);
  // Out of range, in the file or in a scene to save: refused by name.
  scene.order_band = 0.5f;
  EXPECT_NE(SaveScene(scene, path_).message().find("order_band: 0.5 is outside [0, 0.05]"),
            absl::string_view::npos);
}

TEST_F(SceneFileTest, RoundTripKeepsTheIntensityChannelAndVersionFiveFilesHaveNone) {
  GaussianScene scene = MakeScene();
  scene.lidar_intensity_channel = 3;
  ASSERT_TRUE(SaveScene(scene, path_).ok());
  int32_t stored = 0;
  std::memcpy(&stored, ReadFileToString(path_)->data() + 56, 4);
  EXPECT_EQ(stored, 3);
  absl::StatusOr<SceneFile> loaded = ReadSceneFile(path_);
  ASSERT_TRUE(loaded.ok()) << loaded.status();
  ExpectScenesEqual(scene, loaded->scene);
  // A version-5 file is a version-6 file without the channel (an int32 after
  // the order band, at byte 56): no intensity.
  RewriteAsVersion(path_, 5, 56, 4);
  loaded = ReadSceneFile(path_);
  ASSERT_TRUE(loaded.ok()) << loaded.status();
  EXPECT_EQ(loaded->version, 5u);
  scene.lidar_intensity_channel = -1;
  ExpectScenesEqual(scene, loaded->scene);
  // A channel the scene lacks: refused by name, in a scene to save or a file.
  scene.lidar_intensity_channel = 4;
  EXPECT_NE(SaveScene(scene, path_)
                .message()
                .find("lidar_intensity_channel: 4 is neither -1 nor a channel of the 4"),
            absl::string_view::npos);
  const absl::Status status = LoadEdited([](std::string& b) {
    const int32_t channel = 9;
    std::memcpy(b.data() + 56, &channel, 4);
  });
  EXPECT_NE(
      status.message().find("header lidar_intensity_channel 9 is neither -1 nor one of the 4"),
      absl::string_view::npos)
      << status;
}

// Two layers: the body in the bottom rows of a 6x4 camera and one pixel of a
// 3x2 one.
std::vector<EgoLayer> TwoEgoLayers() {
  EgoLayer front{"front", 6, 4, std::vector<uint8_t>(24, 0), std::vector<float>(72, 0.f)};
  for (size_t i = 12; i < 24; ++i) {
    front.mask[i] = 1;
    for (int c = 0; c < 3; ++c) front.rgb[i * 3 + c] = 0.01f * float(i) + 0.1f * float(c);
  }
  EgoLayer back{"back", 3, 2, {0, 0, 0, 0, 1, 0}, std::vector<float>(18, 0.f)};
  back.rgb[12] = 0.5f, back.rgb[13] = 0.25f, back.rgb[14] = 1.5f;
  return {front, back};
}

TEST_F(SceneFileTest, RoundTripKeepsTheEgoLayersAndVersionSixFilesHaveNone) {
  GaussianScene scene = MakeScene();
  scene.ego_layers = TwoEgoLayers();
  ASSERT_TRUE(SaveScene(scene, path_).ok());
  absl::StatusOr<SceneFile> loaded = ReadSceneFile(path_);
  ASSERT_TRUE(loaded.ok()) << loaded.status();
  EXPECT_EQ(loaded->version, kSceneFileVersion);
  ExpectScenesEqual(scene, loaded->scene);
  ASSERT_EQ(loaded->scene.ego_layers.size(), 2u);
  for (size_t k = 0; k < 2; ++k) {
    EXPECT_EQ(loaded->scene.ego_layers[k].camera_id, scene.ego_layers[k].camera_id);
    EXPECT_EQ(loaded->scene.ego_layers[k].width, scene.ego_layers[k].width);
    EXPECT_EQ(loaded->scene.ego_layers[k].height, scene.ego_layers[k].height);
    EXPECT_EQ(loaded->scene.ego_layers[k].mask, scene.ego_layers[k].mask);
    EXPECT_EQ(loaded->scene.ego_layers[k].rgb, scene.ego_layers[k].rgb);
    EXPECT_TRUE(loaded->scene.ego_layers[k].frames.empty());
  }
  // The size: header, arrays, then per layer the mask and 3 floats per body pixel.
  std::string bytes = *ReadFileToString(path_);
  uint32_t header_bytes = 0;
  std::memcpy(&header_bytes, bytes.data() + 12, 4);
  EXPECT_EQ(bytes.size(), 16 + header_bytes + 7 * 30 * 4 + (24 + 12 * 12) + (6 + 12 * 1) + 32);
  // A mask that disagrees with the header's body count: refused by name.
  const size_t back_mask = 16 + header_bytes + 7 * 30 * 4 + 24 + 12 * 12;
  bytes[back_mask] = 1;
  ASSERT_TRUE(WriteFileAtomic(path_, bytes).ok());
  const absl::Status status = ReadSceneFile(path_).status();
  EXPECT_NE(
      status.message().find("ego layer 'back': its mask has 2 body pixels, the header says 1"),
      absl::string_view::npos)
      << status;
  // Two layers of one camera, or a mask of the wrong size: refused on save.
  scene.ego_layers[1].camera_id = "front";
  EXPECT_NE(
      SaveScene(scene, path_).message().find("ego_layers[1]: a second layer of camera 'front'"),
      absl::string_view::npos);
  scene.ego_layers = TwoEgoLayers();
  scene.ego_layers[0].mask.pop_back();
  EXPECT_NE(SaveScene(scene, path_).message().find("ego_layers[0]: mask or colour is not 6x4"),
            absl::string_view::npos);
  // A version-6 file has no layers.
  scene.ego_layers.clear();
  ASSERT_TRUE(SaveScene(scene, path_).ok());
  RewriteAsVersion(path_, 6, 0, 0);
  loaded = ReadSceneFile(path_);
  ASSERT_TRUE(loaded.ok()) << loaded.status();
  EXPECT_EQ(loaded->version, 6u);
  EXPECT_TRUE(loaded->scene.ego_layers.empty());
}

TEST_F(SceneFileTest, RoundTripKeepsTheEgoFramesAndVersionEightFilesHaveNone) {
  GaussianScene scene = MakeScene();
  scene.ego_layers = TwoEgoLayers();
  // The front body (12 pixels) at two times, the back one (1 pixel) at one.
  for (int64_t time : {1'000'000, 1'100'000}) {
    EgoLayer::Frame frame{time, std::vector<float>(36)};
    for (size_t k = 0; k < 36; ++k) frame.rgb[k] = 1e-6f * float(time) + 0.01f * float(k);
    scene.ego_layers[0].frames.push_back(frame);
  }
  scene.ego_layers[1].frames = {{-5, {0.25f, 0.5f, 0.75f}}};
  ASSERT_TRUE(SaveScene(scene, path_).ok());
  absl::StatusOr<SceneFile> loaded = ReadSceneFile(path_);
  ASSERT_TRUE(loaded.ok()) << loaded.status();
  ASSERT_EQ(loaded->scene.ego_layers.size(), 2u);
  for (size_t k = 0; k < 2; ++k) {
    const std::vector<EgoLayer::Frame>& want = scene.ego_layers[k].frames;
    const std::vector<EgoLayer::Frame>& got = loaded->scene.ego_layers[k].frames;
    ASSERT_EQ(got.size(), want.size()) << k;
    for (size_t f = 0; f < want.size(); ++f) {
      EXPECT_EQ(got[f].timestamp_us, want[f].timestamp_us) << k << " " << f;
      EXPECT_EQ(got[f].rgb, want[f].rgb) << k << " " << f;
    }
  }
  // The size: each frame 3 floats per body pixel after its layer's colours.
  std::string bytes = *ReadFileToString(path_);
  uint32_t header_bytes = 0;
  std::memcpy(&header_bytes, bytes.data() + 12, 4);
  EXPECT_EQ(bytes.size(), 16 + header_bytes + 7 * 30 * 4 + (24 + 3 * 12 * 12) + (6 + 2 * 12) + 32);

  // Frames out of time order, or of the wrong size: refused on save, by name.
  GaussianScene bad = scene;
  bad.ego_layers[0].frames[1].timestamp_us = 1'000'000;
  EXPECT_NE(SaveScene(bad, path_)
                .message()
                .find("ego_layers[0].frames[1]: time 1000000 us is not after 1000000 us"),
            absl::string_view::npos);
  bad = scene;
  bad.ego_layers[1].frames[0].rgb.push_back(0.f);
  EXPECT_NE(SaveScene(bad, path_)
                .message()
                .find("ego_layers[1].frames[0]: 4 colours for 1 body pixels (3 each)"),
            absl::string_view::npos);

  // A version-8 file is a version-9 file without each layer's frame count
  // (a uint32 after its body pixel count, the last 4 bytes of the layer's
  // header) and frames: the mean colour at every time.
  for (EgoLayer& layer : scene.ego_layers) layer.frames.clear();
  ASSERT_TRUE(SaveScene(scene, path_).ok());
  bytes = *ReadFileToString(path_);
  std::memcpy(&header_bytes, bytes.data() + 12, 4);
  const size_t end = 16 + header_bytes;
  const size_t back_layer = 4 + 4 + 4 + 4 + 8 + 4;  // "back": its id, size, count, frames
  bytes.erase(end - 4, 4);
  bytes.erase(end - back_layer - 4, 4);
  header_bytes -= 8;
  std::memcpy(bytes.data() + 12, &header_bytes, 4);
  ASSERT_TRUE(WriteFileAtomic(path_, bytes).ok());
  RewriteAsVersion(path_, 8, 0, 0);
  loaded = ReadSceneFile(path_);
  ASSERT_TRUE(loaded.ok()) << loaded.status();
  EXPECT_EQ(loaded->version, 8u);
  ASSERT_EQ(loaded->scene.ego_layers.size(), 2u);
  EXPECT_EQ(loaded->scene.ego_layers[0].rgb, scene.ego_layers[0].rgb);
  EXPECT_TRUE(loaded->scene.ego_layers[0].frames.empty());
  EXPECT_EQ(loaded->scene.ego_layers[1].rgb, scene.ego_layers[1].rgb);
}

TEST_F(SceneFileTest, ReadsVersionThreeFilesAsSrgb) {
  // A version-3 file is a version-6 file without the colour-encoding flag (a
  // uint32 after the colour-gradient flag, at byte 48) and the order band and
  // intensity channel after it.
  GaussianScene scene = MakeScene();
  scene.colour_encoding = ColourEncoding::kLinear;
  ASSERT_TRUE(SaveScene(scene, path_).ok());
  RewriteAsVersion(path_, 3, 48, 12);
  absl::StatusOr<SceneFile> loaded = ReadSceneFile(path_);
  ASSERT_TRUE(loaded.ok()) << loaded.status();
  EXPECT_EQ(loaded->version, 3u);
  scene.colour_encoding = ColourEncoding::kSrgb;
  ExpectScenesEqual(scene, loaded->scene);
}

TEST_F(SceneFileTest, ReadsVersionTwoFilesWithFlatColours) {
  // A version-2 file is a version-6 file without the colour-gradient flag
  // (a uint32 after the low-pass, at byte 44), the colour-encoding flag, the
  // order band and the intensity channel after it, and without gradients.
  const GaussianScene scene = MakeScene();
  ASSERT_TRUE(SaveScene(scene, path_, {{"model", "analytic"}}).ok());
  uint32_t flag = 7;
  std::memcpy(&flag, ReadFileToString(path_)->data() + 44, 4);
  ASSERT_EQ(flag, 0u);
  RewriteAsVersion(path_, 2, 44, 16);
  absl::StatusOr<SceneFile> loaded = ReadSceneFile(path_);
  ASSERT_TRUE(loaded.ok()) << loaded.status();
  EXPECT_EQ(loaded->version, 2u);
  ExpectScenesEqual(scene, loaded->scene);
}

TEST_F(SceneFileTest, ReadsVersionOneFilesWithTheThreeDgsLowPass) {
  // A version-1 file is a version-2 file without the low-pass in the header
  // (a float32 after time_origin_us, at byte 16 + 8 + 4 + 4 + 8 = 40), so a
  // version-6 file without the low-pass and the two flags, the band and the
  // intensity channel after it.
  const GaussianScene scene = MakeScene();
  ASSERT_TRUE(SaveScene(scene, path_, {{"model", "analytic"}}).ok());
  float stored = 0;
  std::memcpy(&stored, ReadFileToString(path_)->data() + 40, 4);
  ASSERT_EQ(stored, 0.1f);
  RewriteAsVersion(path_, 1, 40, 20);

  absl::StatusOr<SceneFile> loaded = ReadSceneFile(path_);
  ASSERT_TRUE(loaded.ok()) << loaded.status();
  EXPECT_EQ(loaded->version, 1u);
  EXPECT_EQ(loaded->scene.low_pass, kThreeDgsLowPass);
  GaussianScene expected = scene;
  expected.low_pass = kThreeDgsLowPass;
  ExpectScenesEqual(expected, loaded->scene);
  EXPECT_EQ(loaded->metadata.at("model"), "analytic");
}

TEST(ValidateScene, RejectsALowPassOutsideItsRange) {
  for (float bad : {-0.1f, 4.5f, std::numeric_limits<float>::quiet_NaN()}) {
    GaussianScene scene = MakeScene();
    scene.low_pass = bad;
    const absl::Status status = ValidateScene(scene);
    EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument) << bad;
    EXPECT_NE(status.message().find("low_pass"), absl::string_view::npos) << status;
  }
  GaussianScene scene = MakeScene();
  scene.low_pass = 0;  // No low-pass at all is allowed.
  EXPECT_TRUE(ValidateScene(scene).ok());
}

TEST_F(SceneFileTest, RejectsTruncationNamingBothSizes) {
  size_t full = 0;
  const absl::Status status = LoadEdited([&full](std::string& b) {
    full = b.size();
    b.resize(b.size() - 10);
  });
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(status.message().find("truncated"), absl::string_view::npos) << status;
  EXPECT_NE(status.message().find(absl::StrCat("expected ", full, " bytes")),
            absl::string_view::npos)
      << status;
  EXPECT_NE(status.message().find(absl::StrCat("has ", full - 10, " bytes")),
            absl::string_view::npos)
      << status;
}

TEST_F(SceneFileTest, RejectsTruncationInsideHeader) {
  const absl::Status status = LoadEdited([](std::string& b) { b.resize(30); });
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(status.message().find("header"), absl::string_view::npos) << status;
}

TEST_F(SceneFileTest, RejectsChecksumMismatch) {
  const absl::Status status = LoadEdited([](std::string& b) { b[b.size() - 100] ^= 0x40; });
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(status.message().find("checksum mismatch"), absl::string_view::npos) << status;
}

TEST_F(SceneFileTest, RejectsHostileCountsWithoutAllocating) {
  // num_gaussians is the first header field, at byte 16.
  absl::Status status = LoadEdited([](std::string& b) {
    const uint64_t huge = uint64_t{1} << 60;
    std::memcpy(b.data() + 16, &huge, 8);
  });
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(status.message().find("promises 1152921504606846976 Gaussians"),
            absl::string_view::npos)
      << status;

  status = LoadEdited([](std::string& b) {
    const uint32_t huge = 0xFFFFFFFFu;
    std::memcpy(b.data() + 12, &huge, 4);
  });
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(status.message().find("header of 4294967295 bytes"), absl::string_view::npos) << status;

  // colour_encoding follows num_gaussians, num_channels, sh_degree, time
  // origin, low-pass, colour-gradient flag; the order band follows it, then
  // the intensity channel, the fade span and num_instances.
  status = LoadEdited([](std::string& b) {
    const uint32_t huge = 0x7FFFFFFFu;
    std::memcpy(b.data() + 16 + 8 + 4 + 4 + 8 + 4 + 4, &huge, 4);
  });
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(status.message().find("colour_encoding 2147483647"), absl::string_view::npos) << status;
  status = LoadEdited([](std::string& b) {
    const uint32_t huge = 0x7FFFFFFFu;
    std::memcpy(b.data() + 16 + 8 + 4 + 4 + 8 + 4 + 4 + 4, &huge, 4);
  });
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(status.message().find("order_band nan is outside"), absl::string_view::npos) << status;
  status = LoadEdited([](std::string& b) {
    const uint32_t huge = 0x7FFFFFFFu;
    std::memcpy(b.data() + 16 + 8 + 4 + 4 + 8 + 4 + 4 + 4 + 4 + 4, &huge, 4);
  });
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(status.message().find("header fade span [nan, inf] is not an interval"),
            absl::string_view::npos)
      << status;
  status = LoadEdited([](std::string& b) {
    const uint32_t huge = 0x7FFFFFFFu;
    std::memcpy(b.data() + 16 + 8 + 4 + 4 + 8 + 4 + 4 + 4 + 4 + 4 + 8, &huge, 4);
  });
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(status.message().find("header render_blur nan is outside [0, 4]"),
            absl::string_view::npos)
      << status;
  status = LoadEdited([](std::string& b) {
    const uint32_t huge = 0x7FFFFFFFu;
    std::memcpy(b.data() + 16 + 8 + 4 + 4 + 8 + 4 + 4 + 4 + 4 + 4 + 8 + 4, &huge, 4);
  });
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(status.message().find("header render_blur_growth nan is outside [0, 100]"),
            absl::string_view::npos)
      << status;
  status = LoadEdited([](std::string& b) {
    const uint32_t huge = 0x7FFFFFFFu;
    std::memcpy(b.data() + 16 + 8 + 4 + 4 + 8 + 4 + 4 + 4 + 4 + 4 + 8 + 4 + 4, &huge, 4);
  });
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(status.message().find("header num_blur_anchors 2147483647 does not fit in the header"),
            absl::string_view::npos)
      << status;
  status = LoadEdited([](std::string& b) {
    const uint32_t huge = 0x7FFFFFFFu;
    std::memcpy(b.data() + 16 + 8 + 4 + 4 + 8 + 4 + 4 + 4 + 4 + 4 + 8 + 4 + 4 + 4, &huge, 4);
  });
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(status.message().find("num_instances"), absl::string_view::npos) << status;

  status = LoadEdited([](std::string& b) {
    const uint32_t flag = 2;
    std::memcpy(b.data() + 16 + 8 + 4 + 4 + 8 + 4, &flag, 4);
  });
  EXPECT_NE(status.message().find("header colour_gradients 2 is neither 0 nor 1"),
            absl::string_view::npos)
      << status;

  status = LoadEdited([](std::string& b) {
    const int32_t channels = 100000;
    std::memcpy(b.data() + 16 + 8, &channels, 4);
  });
  EXPECT_NE(status.message().find("num_channels 100000"), absl::string_view::npos) << status;
}

TEST_F(SceneFileTest, MissingFileIsNotFound) {
  EXPECT_EQ(LoadScene(path_ + ".missing").status().code(), absl::StatusCode::kNotFound);
}

TEST(ValidateSceneTest, NamesTheInconsistentField) {
  GaussianScene scene = MakeScene();
  scene.owners[2] = 3;
  absl::Status status = ValidateScene(scene);
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(status.message().find("owners[2]"), absl::string_view::npos) << status;

  scene = MakeScene();
  scene.features.pop_back();
  status = ValidateScene(scene);
  EXPECT_NE(status.message().find("features: has 27 values, expected 28"), absl::string_view::npos)
      << status;

  scene = MakeScene();
  scene.means[4] = std::numeric_limits<float>::quiet_NaN();
  status = ValidateScene(scene);
  EXPECT_NE(status.message().find("means[1]"), absl::string_view::npos) << status;

  scene = MakeScene();
  std::swap(scene.instances[0].boxes[0], scene.instances[0].boxes[1]);
  status = ValidateScene(scene);
  EXPECT_NE(status.message().find("instances[0] ('car1').boxes[1]"), absl::string_view::npos)
      << status;

  // SaveScene refuses an inconsistent scene and writes nothing.
  const std::string path = testing::MakeTempDir("scene_file") + "/bad.pfscene";
  EXPECT_FALSE(SaveScene(scene, path).ok());
  EXPECT_FALSE(fs::exists(path));
}

}  // namespace
}  // namespace pf
