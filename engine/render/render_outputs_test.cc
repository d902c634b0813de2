// Tests of the render outputs: the EXR read back with OpenImageIO (channel
// names, types, values, header), the PNG preview and the manifest.
#include "engine/render/render_outputs.h"

#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "absl/strings/str_format.h"
#include "common/file_util.h"
#include "common/version.h"
#include "engine/image/image_io.h"
#include "engine/render/hole_fill.h"
#include "tests/test_util.h"

namespace pf {
namespace {

namespace fs = std::filesystem;
using OIIO::TypeDesc;

constexpr int kWidth = 7, kHeight = 5, kChannels = 4;

// Buffers with a distinct, exactly checkable value in every layer and pixel.
RenderBuffers MakeBuffers() {
  RenderBuffers b;
  b.width = kWidth;
  b.height = kHeight;
  b.channels = kChannels;
  const size_t n = kWidth * kHeight;
  b.rgb.resize(3 * n);
  b.alpha.resize(n);
  b.depth.resize(n);
  b.features.resize(kChannels * n);
  b.instance.resize(n);
  for (size_t i = 0; i < n; ++i) {
    b.alpha[i] = (i % 5) / 4.f;
    for (int c = 0; c < 3; ++c) b.rgb[3 * i + c] = b.alpha[i] * (0.1f * c + 0.01f * i);
    b.depth[i] = b.alpha[i] > 0 ? 10.f + 0.123456f * i : 0.f;
    for (int c = 0; c < kChannels; ++c) b.features[kChannels * i + c] = 0.5f * c - 0.02f * i;
    b.instance[i] = i == 3 ? 70000u : static_cast<uint32_t>(i % 3);  // > 65535: not a half.
  }
  return b;
}

// The premultiplied colour `premultiplied` with coverage `alpha` of an
// sRGB-encoded scene, as linear light: alpha * EOTF(colour / alpha).
float LinearOf(float premultiplied, float alpha) {
  if (alpha <= 0.f) return 0.f;
  const float encoded = premultiplied / alpha;
  const float linear =
      encoded <= 0.04045f ? encoded / 12.92f : std::pow((encoded + 0.055f) / 1.055f, 2.4f);
  return alpha * linear;
}

RenderView MakeView() {
  RenderView view;
  view.name = "front_42";
  view.camera_id = "front";
  view.timestamp_us = 1'700'000'000'000'042;
  view.camera_model = "opencv";
  view.distortion = {-0.1, 0.01, 0.001, -0.002, 0.0001};
  view.camera.model = CameraModel(kWidth, kHeight, 100.25, 101.5, 3.5, 2.5);
  view.camera.model.SetOpenCv(-0.1, 0.01, 0.001, -0.002, 0.0001);
  // Camera at (5, 2, 1.5) looking along world +x, y down = world -z.
  const double pose[16] = {0, 0, 1, 5, -1, 0, 0, 2, 0, -1, 0, 1.5, 0, 0, 0, 1};
  view.camera.world_from_camera = Rigid::FromRowMajor(pose);
  return view;
}

class RenderOutputsTest : public ::testing::Test {
 protected:
  void SetUp() override { dir_ = testing::MakeTempDir("render_outputs"); }
  std::string dir_;
};

TEST_F(RenderOutputsTest, ExrHasEveryChannelWithItsTypeValuesAndHeader) {
  const RenderBuffers buffers = MakeBuffers();
  const std::string path = dir_ + "/front_42.exr";
  ASSERT_TRUE(
      WriteRenderExr(path, buffers, OutputChannels{}, MakeView(), {"abc123", "analytic"}).ok());

  auto in = OIIO::ImageInput::open(path);
  ASSERT_TRUE(in) << OIIO::geterror();
  const OIIO::ImageSpec& spec = in->spec();
  EXPECT_EQ(spec.width, kWidth);
  EXPECT_EQ(spec.height, kHeight);
  EXPECT_EQ(spec.tile_width, 0);  // Scanline.
  EXPECT_EQ(spec.get_string_attribute("compression"), "zip");

  // Channel names and types.
  const std::vector<std::string> expected = {
      "R",           "G",           "B",           "A",           "Z",
      "feature.000", "feature.001", "feature.002", "feature.003", "instance"};
  ASSERT_EQ(spec.nchannels, static_cast<int>(expected.size()));
  std::map<std::string, int> index;
  for (int c = 0; c < spec.nchannels; ++c) index[spec.channelnames[c]] = c;
  for (const std::string& name : expected) {
    ASSERT_TRUE(index.count(name)) << name;
    const TypeDesc type = spec.channelformat(index[name]);
    if (name == "Z") {
      EXPECT_EQ(type, TypeDesc::FLOAT) << name;
    } else if (name == "instance") {
      EXPECT_EQ(type, TypeDesc::UINT) << name;
    } else {
      EXPECT_EQ(type, TypeDesc::HALF) << name;
    }
  }

  // Values: half channels to half precision, Z exact, instance ids exact.
  std::vector<float> pixels(size_t(kWidth) * kHeight * spec.nchannels);
  ASSERT_TRUE(in->read_image(0, 0, 0, spec.nchannels, TypeDesc::FLOAT, pixels.data()));
  std::vector<uint32_t> ids(size_t(kWidth) * kHeight);
  ASSERT_TRUE(
      in->read_image(0, 0, index["instance"], index["instance"] + 1, TypeDesc::UINT, ids.data()));
  auto value = [&](size_t i, const std::string& name) {
    return pixels[i * spec.nchannels + index[name]];
  };
  for (size_t i = 0; i < size_t(kWidth) * kHeight; ++i) {
    // The scene's colours are sRGB-encoded (SceneLabel's default): RGB is linear.
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(value(i, std::string(1, "RGB"[c])),
                  LinearOf(buffers.rgb[3 * i + c], buffers.alpha[i]), 1e-3)
          << i;
    }
    EXPECT_NEAR(value(i, "A"), buffers.alpha[i], 1e-3) << i;
    EXPECT_EQ(value(i, "Z"), buffers.depth[i]) << i;
    for (int c = 0; c < kChannels; ++c) {
      const std::string name = absl::StrFormat("feature.%03d", c);
      EXPECT_NEAR(value(i, name), buffers.features[kChannels * i + c], 2e-3) << i << " " << name;
    }
    EXPECT_EQ(ids[i], buffers.instance[i]) << i;
  }
  EXPECT_EQ(ids[3], 70000u);

  // Header: our pose, intrinsics, model, time, scene.
  const OIIO::ParamValue* pose = spec.find_attribute("pf:worldFromCamera");
  ASSERT_NE(pose, nullptr);
  EXPECT_EQ(pose->type(), TypeDesc(TypeDesc::DOUBLE, TypeDesc::MATRIX44));
  const double* m = static_cast<const double*>(pose->data());
  EXPECT_EQ(m[3], 5);
  EXPECT_EQ(m[2], 1);
  EXPECT_EQ(m[11], 1.5);
  EXPECT_EQ(spec.get_float_attribute("pf:fx"), 100.25f);
  EXPECT_EQ(spec.get_float_attribute("pf:fy"), 101.5f);
  EXPECT_EQ(spec.get_float_attribute("pf:cx"), 3.5f);
  EXPECT_EQ(spec.get_float_attribute("pf:cy"), 2.5f);
  EXPECT_EQ(spec.get_string_attribute("pf:cameraModel"), "opencv");
  const OIIO::ParamValue* distortion = spec.find_attribute("pf:distortion");
  ASSERT_NE(distortion, nullptr);
  ASSERT_EQ(distortion->type().basetype, TypeDesc::FLOAT);
  ASSERT_EQ(distortion->type().numelements() * distortion->nvalues(), 5u);
  EXPECT_FLOAT_EQ(static_cast<const float*>(distortion->data())[3], -0.002f);
  const OIIO::ParamValue* timestamp = spec.find_attribute("timestamp_us");
  ASSERT_NE(timestamp, nullptr);
  EXPECT_EQ(timestamp->type(), TypeDesc::DOUBLE);
  EXPECT_EQ(*static_cast<const double*>(timestamp->data()), 1'700'000'000'000'042.0);
  EXPECT_EQ(spec.get_string_attribute("pf:timestampUs"), "1700000000000042");
  EXPECT_EQ(spec.get_string_attribute("pf:camera"), "front");
  EXPECT_EQ(spec.get_string_attribute("pf:view"), "front_42");
  EXPECT_EQ(spec.get_string_attribute("pf:sceneId"), "abc123");
  EXPECT_EQ(spec.get_string_attribute("pf:model"), "analytic");
  EXPECT_EQ(spec.get_string_attribute("pf:version"), SoftwareVersion());
  // Linear Rec. 709: OpenEXR's chromaticities (red, green, blue, white x y).
  EXPECT_EQ(spec.get_string_attribute("oiio:ColorSpace"), "Linear");
  const OIIO::ParamValue* chromaticities = spec.find_attribute("chromaticities");
  ASSERT_NE(chromaticities, nullptr);
  ASSERT_EQ(chromaticities->type().basetype, TypeDesc::FLOAT);
  ASSERT_EQ(chromaticities->type().numelements() * chromaticities->nvalues(), 8u);
  const float* xy = static_cast<const float*>(chromaticities->data());
  const float rec709[8] = {0.64f, 0.33f, 0.30f, 0.60f, 0.15f, 0.06f, 0.3127f, 0.3290f};
  for (int i = 0; i < 8; ++i) EXPECT_FLOAT_EQ(xy[i], rec709[i]) << i;

  // worldToCamera (Imath row vectors, camera y up): the world point 3 m in
  // front of the camera and 1 m above it maps to camera (0, +1, 3).
  const OIIO::ParamValue* w2c = spec.find_attribute("worldToCamera");
  ASSERT_NE(w2c, nullptr);
  EXPECT_EQ(w2c->type(), OIIO::TypeMatrix44);
  const float* k = static_cast<const float*>(w2c->data());
  const double p[4] = {8, 2, 2.5, 1};
  double q[4] = {0, 0, 0, 0};
  for (int c = 0; c < 4; ++c) {
    for (int r = 0; r < 4; ++r) q[c] += p[r] * k[4 * r + c];
  }
  EXPECT_NEAR(q[0], 0, 1e-6);
  EXPECT_NEAR(q[1], 1, 1e-6);
  EXPECT_NEAR(q[2], 3, 1e-6);
  EXPECT_NEAR(q[3], 1, 1e-6);
  in->close();

  // Written atomically: no temporary file left.
  int files = 0;
  for (const auto& entry : fs::directory_iterator(dir_)) files += entry.is_regular_file();
  EXPECT_EQ(files, 1);
}

TEST_F(RenderOutputsTest, OutputsSelectTheChannels) {
  absl::StatusOr<OutputChannels> channels = ParseOutputChannels({"rgb", "depth"});
  ASSERT_TRUE(channels.ok());
  EXPECT_EQ(ExrChannelNames(*channels, kChannels), (std::vector<std::string>{"R", "G", "B", "Z"}));
  const std::string path = dir_ + "/subset.exr";
  ASSERT_TRUE(WriteRenderExr(path, MakeBuffers(), *channels, MakeView(), {}).ok());
  auto in = OIIO::ImageInput::open(path);
  ASSERT_TRUE(in);
  std::vector<std::string> names = in->spec().channelnames;
  std::sort(names.begin(), names.end());
  EXPECT_EQ(names, (std::vector<std::string>{"B", "G", "R", "Z"}));

  EXPECT_EQ(ExrChannelNames(*ParseOutputChannels({}), 2),
            (std::vector<std::string>{"R", "G", "B", "A", "Z", "feature.000", "feature.001",
                                      "instance"}));
  absl::Status status = ParseOutputChannels({"rgb", "normals"}).status();
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(status.message().find("unknown layer 'normals'"), absl::string_view::npos);
}

TEST_F(RenderOutputsTest, FilledLayerIsTheRenderOverItsPushPullFill) {
  absl::StatusOr<OutputChannels> channels = ParseOutputChannels({"alpha", "filled"});
  ASSERT_TRUE(channels.ok());
  EXPECT_EQ(ExrChannelNames(*channels, kChannels),
            (std::vector<std::string>{"A", "filled.R", "filled.G", "filled.B"}));
  const RenderBuffers buffers = MakeBuffers();
  const std::string path = dir_ + "/filled.exr";
  ASSERT_TRUE(WriteRenderExr(path, buffers, *channels, MakeView(), {}).ok());
  auto in = OIIO::ImageInput::open(path);
  ASSERT_TRUE(in);
  const OIIO::ImageSpec& spec = in->spec();
  std::vector<float> pixels(size_t(kWidth) * kHeight * spec.nchannels);
  ASSERT_TRUE(in->read_image(0, 0, 0, spec.nchannels, TypeDesc::FLOAT, pixels.data()));
  std::vector<float> linear(buffers.rgb.size());
  for (size_t i = 0; i < linear.size(); ++i)
    linear[i] = LinearOf(buffers.rgb[i], buffers.alpha[i / 3]);
  const std::vector<float> expected =
      FillUncovered(linear, buffers.alpha, buffers.width, buffers.height);
  const int a = spec.channelindex("A");
  int rgb[3];
  for (int c = 0; c < 3; ++c) rgb[c] = spec.channelindex(std::string("filled.") + "RGB"[c]);
  ASSERT_GE(a, 0);
  int uncovered = 0;
  for (size_t i = 0; i < size_t(kWidth) * kHeight; ++i) {
    const float* p = &pixels[i * spec.nchannels];
    uncovered += buffers.alpha[i] == 0.f;
    for (int c = 0; c < 3; ++c) {
      ASSERT_GE(rgb[c], 0);
      // Half precision; a pixel with alpha 0 gets its neighbours' colour.
      EXPECT_NEAR(p[rgb[c]], expected[3 * i + c], 2e-3f * expected[3 * i + c] + 1e-4f) << i;
      if (buffers.alpha[i] == 0.f && c > 0) EXPECT_GT(p[rgb[c]], 0.f) << i;
    }
    EXPECT_EQ(p[a], buffers.alpha[i]);  // Alpha still says what was covered.
  }
  EXPECT_GT(uncovered, 0);
  // Not in the default set.
  EXPECT_FALSE(ParseOutputChannels({})->filled);
}

TEST_F(RenderOutputsTest, MissingLayerIsAnError) {
  RenderBuffers buffers = MakeBuffers();
  buffers.features.clear();
  absl::Status status = WriteRenderExr(dir_ + "/x.exr", buffers, OutputChannels{}, MakeView(), {});
  EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(status.message().find("layer 'features' has 0 values, expected 140"),
            absl::string_view::npos)
      << status;
  EXPECT_FALSE(fs::exists(dir_ + "/x.exr"));
  OutputChannels none{false, false, false, false, false, false};
  EXPECT_FALSE(WriteRenderExr(dir_ + "/y.exr", MakeBuffers(), none, MakeView(), {}).ok());
}

TEST_F(RenderOutputsTest, PreviewIsPremultipliedColourClampedTo8Bit) {
  RenderBuffers buffers = MakeBuffers();
  buffers.rgb[0] = 1.7f;   // Clamped to 1.
  buffers.rgb[1] = -0.2f;  // Clamped to 0.
  const std::string path = dir_ + "/preview.png";
  ASSERT_TRUE(WritePreviewPng(path, buffers, ColourEncoding::kSrgb).ok());
  absl::StatusOr<ImageF> image = ReadImage(path);
  ASSERT_TRUE(image.ok()) << image.status();
  ASSERT_EQ(image->channels, 3);
  ASSERT_EQ(image->width, kWidth);
  EXPECT_EQ(image->at(0, 0, 0), 1.f);
  EXPECT_EQ(image->at(0, 0, 1), 0.f);
  for (int y = 0; y < kHeight; ++y) {
    for (int x = 0; x < kWidth; ++x) {
      for (int c = 0; c < 3; ++c) {
        if (x == 0 && y == 0) continue;
        EXPECT_NEAR(image->at(x, y, c), buffers.rgb[3 * (y * kWidth + x) + c], 0.5 / 255 + 1e-6);
      }
    }
  }
}

// A grey ramp of opaque pixels, the way an sRGB-encoded scene (a camera
// image's values) renders it, and the way a linear scene holds the same grey.
RenderBuffers GreyRamp(bool linear) {
  RenderBuffers b;
  b.width = 256;
  b.height = 1;
  b.channels = 3;
  b.alpha.assign(256, 1.f);
  b.depth.assign(256, 5.f);
  b.instance.assign(256, 0);
  for (int x = 0; x < 256; ++x) {
    const float encoded = x / 255.f;
    for (int c = 0; c < 3; ++c) b.rgb.push_back(linear ? SrgbToLinear(encoded) : encoded);
  }
  b.features = b.rgb;
  return b;
}

TEST_F(RenderOutputsTest, GreyRampComesBackLinearInTheExrAndAsTheInputInThePng) {
  for (const bool linear_scene : {false, true}) {
    SCOPED_TRACE(linear_scene ? "linear scene" : "sRGB scene");
    const RenderBuffers ramp = GreyRamp(linear_scene);
    const ColourEncoding encoding = linear_scene ? ColourEncoding::kLinear : ColourEncoding::kSrgb;
    OutputChannels channels;
    channels.features = channels.instance = false;
    const std::string exr = dir_ + "/ramp.exr", png = dir_ + "/ramp.png";
    ASSERT_TRUE(WriteRenderExr(exr, ramp, channels, MakeView(), {"s", "analytic", encoding}).ok());
    ASSERT_TRUE(WritePreviewPng(png, ramp, encoding).ok());
    auto in = OIIO::ImageInput::open(exr);
    ASSERT_TRUE(in);
    const OIIO::ImageSpec& spec = in->spec();
    std::vector<float> pixels(size_t(256) * spec.nchannels);
    ASSERT_TRUE(in->read_image(0, 0, 0, spec.nchannels, TypeDesc::FLOAT, pixels.data()));
    const int rgb_index[3] = {spec.channelindex("R"), spec.channelindex("G"),
                              spec.channelindex("B")};
    absl::StatusOr<ImageF> png_rgb = ReadImage(png, 3);
    ASSERT_TRUE(png_rgb.ok());
    for (int x = 0; x < 256; ++x) {
      // The sRGB EOTF of each input value, to half precision.
      const double eotf =
          x / 255.0 <= 0.04045 ? x / 255.0 / 12.92 : std::pow((x / 255.0 + 0.055) / 1.055, 2.4);
      for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(pixels[x * spec.nchannels + rgb_index[c]], eotf, 1e-3 * eotf + 1e-7) << x;
        EXPECT_NEAR(png_rgb->at(x, 0, c), x / 255.f, 1e-6) << x;  // The input value.
      }
    }
  }
}

TEST_F(RenderOutputsTest, ManifestListsEveryView) {
  const RenderView view = MakeView();
  ManifestEntry entry;
  entry.exr = "front_42.exr";
  entry.png = "front_42.png";
  entry.view = &view;
  entry.channels = {"R", "G", "B", "A"};
  entry.width = kWidth;
  entry.height = kHeight;
  const std::string path = dir_ + "/manifest.json";
  ASSERT_TRUE(WriteManifest(path, {"abc123", "analytic"}, {entry}).ok());
  const nlohmann::json json = nlohmann::json::parse(*ReadFileToString(path));
  EXPECT_EQ(json["scene"]["id"], "abc123");
  ASSERT_EQ(json["views"].size(), 1u);
  const nlohmann::json& v = json["views"][0];
  EXPECT_EQ(v["name"], "front_42");
  EXPECT_EQ(v["exr"], "front_42.exr");
  EXPECT_EQ(v["png"], "front_42.png");
  EXPECT_EQ(v["camera"], "front");
  EXPECT_EQ(v["cameraModel"], "opencv");
  EXPECT_EQ(v["timestampUs"].get<int64_t>(), 1'700'000'000'000'042);
  EXPECT_EQ(v["width"], kWidth);
  EXPECT_EQ(v["height"], kHeight);
  EXPECT_EQ(v["channels"], nlohmann::json({"R", "G", "B", "A"}));
  EXPECT_EQ(v["worldFromCamera"][3], 5.0);
  EXPECT_EQ(v["intrinsics"]["fx"], 100.25);
  EXPECT_EQ(v["distortion"].size(), 5u);
}

TEST(RenderLimits, PixelsAndEstimatedMemoryOfEveryCameraAreChecked) {
  pointforward::v1::RenderViews views;
  auto add_camera = [&views](int width, int height) {
    pointforward::v1::Camera* camera = views.add_cameras();
    camera->set_width(width);
    camera->set_height(height);
  };
  add_camera(64, 48);
  add_camera(12000, 12000);
  const OutputChannels all;  // rgb, alpha, depth, features, instance.
  EXPECT_EQ(CheckRenderLimits(views, all, 8, {50'000'000, 0}).message(),
            "cameras[1]: 12000x12000 = 144000000 pixels per view exceed the limit of 50000000 "
            "(--max-pixels-per-image)");
  // Per pixel: 4 bytes x (3 rgb + alpha + depth + instance + 8 features) + 8.
  EXPECT_EQ(EstimateRenderBytes(12000, 12000, all, 8), int64_t{144000000} * 64);
  EXPECT_EQ(CheckRenderLimits(views, all, 8, {0, int64_t{144000000} * 64 - 1}).message(),
            "cameras[1]: rendering a 12000x12000 view takes about 9216000000 bytes, over the "
            "limit of 9215999999 per view (--max-render-bytes); ask for fewer outputs or pixels");
  EXPECT_TRUE(CheckRenderLimits(views, all, 8, {144000000, int64_t{144000000} * 64}).ok());
  EXPECT_TRUE(CheckRenderLimits(views, all, 8, {}).ok());  // 0: no limits.
  // Fewer outputs, less memory.
  OutputChannels rgb_only;
  rgb_only.depth = rgb_only.features = rgb_only.instance = false;
  EXPECT_EQ(EstimateRenderBytes(100, 10, rgb_only, 8), 1000 * (4 * 4 + 8));
  // The largest cameras a request can name do not overflow the estimate.
  add_camera(2147483647, 2147483647);
  EXPECT_GT(EstimateRenderBytes(2147483647, 2147483647, all, 256), int64_t{1} << 62);
  EXPECT_EQ(CheckRenderLimits(views, all, 8, {0, int64_t{1} << 40}).code(),
            absl::StatusCode::kInvalidArgument);

  // A LiDAR sweep's rays count as a view's pixels: 1024 beams x 36000 columns.
  pointforward::v1::RenderViews sweeps;
  pointforward::v1::LidarView* lidar = sweeps.add_lidars();
  for (int b = 0; b < 1024; ++b) lidar->mutable_spec()->add_beam_elevations_deg(0);
  lidar->mutable_spec()->set_azimuth_resolution_deg(0.01);
  EXPECT_EQ(CheckRenderLimits(sweeps, all, 8, {36'864'000, 0}, "views.").message(), "");
  EXPECT_EQ(CheckRenderLimits(sweeps, all, 8, {36'863'999, 0}, "views.").message(),
            "views.lidars[0]: 1024 beams x 36000 columns = 36864000 rays per sweep exceed the "
            "limit of 36863999 (--max-pixels-per-image)");
  // The default resolution (0.2 degrees: 1800 columns) when none is given.
  lidar->mutable_spec()->clear_azimuth_resolution_deg();
  EXPECT_TRUE(CheckRenderLimits(sweeps, all, 8, {1024 * 1800, 0}).ok());
  EXPECT_FALSE(CheckRenderLimits(sweeps, all, 8, {1024 * 1800 - 1, 0}).ok());
}

}  // namespace
}  // namespace pf
