// Tests of 3DGS PLY export and import: the standard layout, foreign files,
// errors, instances placed in the world, and export-import-render round trips.
#include "engine/render/ply_io.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "engine/render/rasterizer.h"
#include "engine/render/scene_file.h"
#include "tests/test_util.h"

namespace pf {
namespace {

// A few Gaussians 3-6 m in front of a camera at the origin looking along +z.
GaussianScene MakeScene(int sh_degree, int channels) {
  GaussianScene scene;
  scene.num_channels = channels;
  scene.sh_degree = sh_degree;
  scene.Resize(6);
  for (size_t i = 0; i < scene.size(); ++i) {
    scene.means[3 * i + 0] = -0.6f + 0.25f * i;
    scene.means[3 * i + 1] = 0.3f * std::sin(1.0f * i);
    scene.means[3 * i + 2] = 3.f + 0.5f * i;
    const float q[4] = {1.f, 0.2f * i, -0.1f, 0.05f * i};
    for (int a = 0; a < 4; ++a) scene.rotations[4 * i + a] = q[a];
    scene.log_scales[3 * i + 0] = std::log(0.2f + 0.02f * i);
    scene.log_scales[3 * i + 1] = std::log(0.1f);
    scene.log_scales[3 * i + 2] = std::log(0.05f);
    scene.opacity_logits[i] = 0.5f + 0.3f * i;
    for (int c = 0; c < channels; ++c) {
      scene.features[i * channels + c] = 0.1f + 0.13f * ((i + 2 * c) % 7);
    }
    for (int k = 0; k < 3 * scene.sh_coeffs(); ++k) {
      scene.sh[i * 3 * scene.sh_coeffs() + k] = (k % 4 == 0 ? 0.8f : 0.05f) * ((i + k) % 5 - 2);
    }
  }
  return scene;
}

RenderCamera MakeCamera() {
  RenderCamera camera;
  camera.model = CameraModel(64, 48, 60, 60, 32, 24);
  return camera;
}

float MaxAbsDiff(const std::vector<float>& a, const std::vector<float>& b) {
  EXPECT_EQ(a.size(), b.size());
  float diff = 0;
  for (size_t i = 0; i < a.size() && i < b.size(); ++i)
    diff = std::max(diff, std::abs(a[i] - b[i]));
  return diff;
}

void ExpectNear(const std::vector<float>& a, const std::vector<float>& b, float tolerance,
                const char* name) {
  EXPECT_LE(MaxAbsDiff(a, b), tolerance) << name;
}

// Returns the float properties of an exported PLY (binary little endian,
// all float) as rows keyed by name.
struct ParsedPly {
  std::vector<std::string> names;
  std::vector<float> values;  // [n, names.size()]
  std::vector<std::string> header_lines;
  float at(size_t row, const std::string& name) const {
    for (size_t p = 0; p < names.size(); ++p) {
      if (names[p] == name) return values[row * names.size() + p];
    }
    ADD_FAILURE() << "no property " << name;
    return 0;
  }
};

ParsedPly ParseOurPly(const std::string& bytes) {
  ParsedPly out;
  const size_t end = bytes.find("end_header\n");
  EXPECT_NE(end, std::string::npos);
  out.header_lines = absl::StrSplit(bytes.substr(0, end), '\n', absl::SkipEmpty());
  for (const std::string& line : out.header_lines) {
    std::vector<std::string> words = absl::StrSplit(line, ' ');
    if (words[0] == "property") {
      EXPECT_EQ(words[1], "float");
      out.names.push_back(words[2]);
    }
  }
  const size_t body = end + std::strlen("end_header\n");
  out.values.resize((bytes.size() - body) / 4);
  std::memcpy(out.values.data(), bytes.data() + body, out.values.size() * 4);
  return out;
}

TEST(PlyExport, WritesStandardPropertiesInOrderWithChannelMajorRest) {
  GaussianScene scene = MakeScene(3, 3);
  const int k = scene.sh_coeffs();
  for (size_t i = 0; i < scene.size(); ++i) {
    for (int c = 0; c < 3; ++c) {
      for (int j = 0; j < k; ++j) scene.sh[i * 3 * k + c * k + j] = 100.f * c + j + 1000.f * i;
    }
  }
  absl::StatusOr<std::string> bytes = EncodePly(scene);
  ASSERT_TRUE(bytes.ok()) << bytes.status();
  const ParsedPly ply = ParseOurPly(*bytes);
  EXPECT_EQ(ply.header_lines[0], "ply");
  EXPECT_EQ(ply.header_lines[1], "format binary_little_endian 1.0");
  EXPECT_NE(std::find(ply.header_lines.begin(), ply.header_lines.end(), "element vertex 6"),
            ply.header_lines.end());
  const std::vector<std::string> first = {"x",  "y",      "z",      "nx",     "ny",
                                          "nz", "f_dc_0", "f_dc_1", "f_dc_2", "f_rest_0"};
  EXPECT_EQ(std::vector<std::string>(ply.names.begin(), ply.names.begin() + 10), first);
  // 45 rest coefficients, then opacity, scales, rotation.
  EXPECT_EQ(ply.names[9 + 44], "f_rest_44");
  EXPECT_EQ(ply.names[9 + 45], "opacity");
  EXPECT_EQ(ply.names[9 + 45 + 1], "scale_0");
  EXPECT_EQ(ply.names[9 + 45 + 4], "rot_0");
  EXPECT_EQ(ply.names[9 + 45 + 7], "rot_3");
  ASSERT_EQ(ply.values.size(), scene.size() * ply.names.size());
  // f_rest: all of R's 15 coefficients, then G's, then B's.
  EXPECT_EQ(ply.at(2, "f_dc_1"), 2000.f + 100.f);
  EXPECT_EQ(ply.at(2, "f_rest_0"), 2000.f + 1.f);
  EXPECT_EQ(ply.at(2, "f_rest_14"), 2000.f + 15.f);
  EXPECT_EQ(ply.at(2, "f_rest_15"), 2000.f + 100.f + 1.f);
  EXPECT_EQ(ply.at(2, "f_rest_44"), 2000.f + 200.f + 15.f);
  EXPECT_EQ(ply.at(3, "opacity"), scene.opacity_logits[3]);
  EXPECT_EQ(ply.at(3, "scale_0"), scene.log_scales[9]);
  EXPECT_EQ(ply.at(3, "rot_1"), scene.rotations[13]);
  EXPECT_EQ(ply.at(4, "z"), scene.means[14]);
}

TEST(PlyExport, WithoutShWritesDcFromFirstThreeFeatures) {
  GaussianScene scene = MakeScene(-1, 3);
  scene.features[0] = 0.2f;
  scene.features[1] = 0.5f;
  scene.features[2] = 0.9f;
  const ParsedPly ply = ParseOurPly(*EncodePly(scene));
  EXPECT_NEAR(ply.at(0, "f_dc_0"), (0.2 - 0.5) / kShC0, 1e-5);
  EXPECT_NEAR(ply.at(0, "f_dc_1"), 0.0, 1e-6);
  EXPECT_NEAR(ply.at(0, "f_dc_2"), (0.9 - 0.5) / kShC0, 1e-5);
  // Three channels without SH: no extras, no f_rest.
  for (const std::string& name : ply.names) {
    EXPECT_EQ(name.find("pf_"), std::string::npos) << name;
    EXPECT_EQ(name.find("f_rest"), std::string::npos) << name;
  }
}

TEST(PlyExport, LinearSceneWritesItsSrgbEncodedColourAndReadsBackLinear) {
  GaussianScene scene = MakeScene(-1, 3);
  scene.colour_encoding = ColourEncoding::kLinear;
  scene.features[0] = 0.2f;
  scene.features[1] = 0.5f;
  scene.features[2] = 0.0031308f;
  const std::string ply = *EncodePly(scene);
  const ParsedPly parsed = ParseOurPly(ply);
  // f_dc carries what a viewer shows: the sRGB-encoded colour.
  EXPECT_NEAR(parsed.at(0, "f_dc_0"), (0.48452920 - 0.5) / kShC0, 1e-5);
  EXPECT_NEAR(parsed.at(0, "f_dc_1"), (0.73535698 - 0.5) / kShC0, 1e-5);
  EXPECT_NEAR(parsed.at(0, "f_dc_2"), (0.04044994 - 0.5) / kShC0, 1e-5);
  EXPECT_NE(ply.find("colour_encoding=linear"), std::string::npos);
  absl::StatusOr<GaussianScene> back = DecodePly(ply, "mem.ply");
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->colour_encoding, ColourEncoding::kLinear);
  ExpectNear(back->features, scene.features, 2e-6f, "features");
  // A PLY without our comment (a 3DGS tool's) is sRGB.
  std::string foreign = ply;
  foreign.replace(foreign.find("colour_encoding=linear"), 22, "colour_encoding=other!");
  absl::StatusOr<GaussianScene> srgb = DecodePly(foreign, "mem.ply");
  ASSERT_TRUE(srgb.ok()) << srgb.status();
  EXPECT_EQ(srgb->colour_encoding, ColourEncoding::kSrgb);
  EXPECT_NEAR(srgb->features[0], 0.48452920f, 1e-5);
}

TEST(PlyRoundTrip, ShSceneArraysAreExact) {
  GaussianScene scene = MakeScene(2, 5);
  scene.time_origin_us = 123456789;
  scene.lifespans[1] = 0.25f;
  scene.times[1] = 0.5f;
  scene.low_pass = 0.1f;
  absl::StatusOr<GaussianScene> back = DecodePly(*EncodePly(scene), "mem.ply");
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->low_pass, 0.1f);  // From our header comment.
  EXPECT_EQ(back->sh_degree, 2);
  EXPECT_EQ(back->num_channels, 5);
  EXPECT_EQ(back->time_origin_us, 123456789);
  EXPECT_EQ(back->means, scene.means);
  EXPECT_EQ(back->rotations, scene.rotations);
  EXPECT_EQ(back->log_scales, scene.log_scales);
  EXPECT_EQ(back->opacity_logits, scene.opacity_logits);
  EXPECT_EQ(back->sh, scene.sh);
  EXPECT_EQ(back->features, scene.features);
  EXPECT_EQ(back->times, scene.times);
  EXPECT_EQ(back->lifespans, scene.lifespans);
  EXPECT_EQ(back->owners, scene.owners);
}

TEST(PlyRoundTrip, FeatureSceneArraysMatchWithinFloatTolerance) {
  GaussianScene scene = MakeScene(-1, 3);
  scene.lidar_intensity_channel = 2;
  absl::StatusOr<GaussianScene> back = DecodePly(*EncodePly(scene), "mem.ply");
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->sh_degree, -1);  // Restored from our header comment.
  EXPECT_EQ(back->num_channels, 3);
  EXPECT_EQ(back->lidar_intensity_channel, 2);
  EXPECT_FALSE(back->fade_span.bounded());  // None given, none made up.
  ExpectNear(back->features, scene.features, 1e-6f, "features");
  EXPECT_EQ(back->means, scene.means);
  EXPECT_EQ(back->log_scales, scene.log_scales);
  EXPECT_EQ(back->opacity_logits, scene.opacity_logits);
  EXPECT_EQ(back->rotations, scene.rotations);
}

TEST(PlyRoundTrip, KeepsTheFadeSpan) {
  GaussianScene scene = MakeScene(-1, 3);
  scene.fade_span = {-0.125f, 2.75f};
  absl::StatusOr<GaussianScene> back = DecodePly(*EncodePly(scene), "mem.ply");
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->fade_span.begin, -0.125f);
  EXPECT_EQ(back->fade_span.end, 2.75f);
  // One end only: the other stays unbounded.
  scene.fade_span = {-std::numeric_limits<float>::infinity(), 2.75f};
  back = DecodePly(*EncodePly(scene), "mem.ply");
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_TRUE(std::isinf(back->fade_span.begin) && back->fade_span.begin < 0);
  EXPECT_EQ(back->fade_span.end, 2.75f);
}

TEST(PlyRoundTrip, KeepsTheRenderBlur) {
  GaussianScene scene = MakeScene(-1, 3);
  absl::StatusOr<GaussianScene> back = DecodePly(*EncodePly(scene), "mem.ply");
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->render_blur, 0.f);
  scene.render_blur = 0.75f;
  back = DecodePly(*EncodePly(scene), "mem.ply");
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->render_blur, 0.75f);
  // Out of range in the comment: refused, by name.
  std::string ply = *EncodePly(scene);
  ply.replace(ply.find("render_blur=0.75"), 16, "render_blur=9");
  back = DecodePly(ply, "mem.ply");
  EXPECT_NE(back.status().message().find("render_blur: 9 pixels is outside [0, 4]"),
            absl::string_view::npos)
      << back.status();
}

TEST(PlyRoundTrip, KeepsTheBlursGrowthAndAnchors) {
  GaussianScene scene = MakeScene(-1, 3);
  scene.render_blur = 0.5f;
  scene.render_blur_growth = 2.f;
  scene.blur_anchors = {{{1234.5678f, -0.001f, 3.f}, {0.6f, 0.f, 0.8f}},
                        {{0.1f, 0.2f, 0.3f}, {0.f, 1.f, 0.f}}};
  absl::StatusOr<GaussianScene> back = DecodePly(*EncodePly(scene), "mem.ply");
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_EQ(back->render_blur_growth, 2.f);
  ASSERT_EQ(back->blur_anchors.size(), 2u);
  for (size_t k = 0; k < 2; ++k) {  // %.9g keeps a float32 to the bit.
    EXPECT_EQ(back->blur_anchors[k].centre, scene.blur_anchors[k].centre);
    EXPECT_EQ(back->blur_anchors[k].axis, scene.blur_anchors[k].axis);
  }
  // An anchor that is not six numbers: refused, naming the comment.
  std::string ply = *EncodePly(scene);
  const size_t at = ply.find("blur_anchor=0.100000001");
  ASSERT_NE(at, std::string::npos) << ply.substr(0, 600);
  ply.replace(at, 23, "blur_anchor=x");
  back = DecodePly(ply, "mem.ply");
  EXPECT_NE(back.status().message().find("mem.ply: comment blur_anchor=x,"),
            absl::string_view::npos)
      << back.status();
}

TEST(PlyRoundTrip, ExportImportRenderGivesIdenticalImages) {
  const RenderCamera camera = MakeCamera();
  const std::string dir = testing::MakeTempDir("ply_io");
  for (const auto& [degree, channels] :
       {std::pair{-1, 3}, std::pair{3, 3}, std::pair{1, 8}, std::pair{-1, 7}}) {
    SCOPED_TRACE(absl::StrCat("sh_degree ", degree, ", channels ", channels));
    GaussianScene scene = MakeScene(degree, channels);
    if (channels == 8) scene.low_pass = 0.1f;  // Renders differ unless it is kept.
    if (channels == 7) {
      // Colour gradients travel as pf_colour_gradient_0..5.
      scene.colour_gradients.resize(6 * scene.size());
      for (size_t k = 0; k < scene.colour_gradients.size(); ++k) {
        scene.colour_gradients[k] = 0.05f * static_cast<float>(k % 9) - 0.2f;
      }
    }
    const std::string path = absl::StrCat(dir, "/scene_", degree, "_", channels, ".ply");
    ASSERT_TRUE(ExportPly(scene, path).ok());
    absl::StatusOr<GaussianScene> back = ImportPly(path);
    ASSERT_TRUE(back.ok()) << back.status();
    absl::StatusOr<RenderBuffers> a = Render(scene, camera, 0, {});
    absl::StatusOr<RenderBuffers> b = Render(*back, camera, 0, {});
    ASSERT_TRUE(a.ok()) << a.status();
    ASSERT_TRUE(b.ok()) << b.status();
    // The scene is visible, so the comparison is not between two blanks.
    EXPECT_GT(*std::max_element(a->alpha.begin(), a->alpha.end()), 0.5f);
    ExpectNear(a->rgb, b->rgb, 1e-5f, "rgb");
    ExpectNear(a->alpha, b->alpha, 0.f, "alpha");
    ExpectNear(a->depth, b->depth, 0.f, "depth");
    ExpectNear(a->features, b->features, 1e-5f, "features");
    EXPECT_EQ(back->colour_gradients, scene.colour_gradients);
  }
}

// An instance moving 10 m along x and turning 90 degrees about z.
GaussianScene MakeInstanceScene() {
  GaussianScene scene = MakeScene(-1, 3);
  scene.time_origin_us = 1'000'000;
  InstanceTrack track;
  track.id = "car1";
  track.boxes.push_back({1'000'000, {0, 0, 5}, {4, 2, 1.5}, {1, 0, 0, 0}});
  track.boxes.push_back(
      {2'000'000, {10, 0, 5}, {4, 2, 1.5}, {std::sqrt(0.5), 0, 0, std::sqrt(0.5)}});
  scene.instances.push_back(track);
  // Gaussian 5: canonical position 1 m ahead of the box centre along box x.
  scene.owners[5] = 1;
  scene.means[15] = 1;
  scene.means[16] = 0;
  scene.means[17] = 5;
  scene.rotations[20] = 1;
  scene.rotations[21] = scene.rotations[22] = scene.rotations[23] = 0;
  return scene;
}

TEST(PlyExport, InstancesAreWrittenInWorldSpaceAtTheRequestedTime) {
  const GaussianScene scene = MakeInstanceScene();
  // Default: the time origin, where the instance sits at its first box.
  ParsedPly ply = ParseOurPly(*EncodePly(scene));
  EXPECT_NEAR(ply.at(5, "x"), 1, 1e-6);
  EXPECT_NEAR(ply.at(5, "y"), 0, 1e-6);
  EXPECT_NEAR(ply.at(5, "z"), 5, 1e-6);
  EXPECT_NEAR(ply.at(5, "rot_0"), 1, 1e-6);
  // At the last box: turned 90 degrees about z and moved 10 m along x.
  PlyExportOptions options;
  options.timestamp_us = 2'000'000;
  ply = ParseOurPly(*EncodePly(scene, options));
  EXPECT_NEAR(ply.at(5, "x"), 10, 1e-5);
  EXPECT_NEAR(ply.at(5, "y"), 1, 1e-5);
  EXPECT_NEAR(ply.at(5, "z"), 5, 1e-5);
  EXPECT_NEAR(ply.at(5, "rot_0"), std::sqrt(0.5), 1e-6);
  EXPECT_NEAR(ply.at(5, "rot_3"), std::sqrt(0.5), 1e-6);
  // Background Gaussians do not move.
  EXPECT_EQ(ply.at(0, "x"), scene.means[0]);
  absl::StatusOr<GaussianScene> back = DecodePly(*EncodePly(scene, options), "mem.ply");
  ASSERT_TRUE(back.ok()) << back.status();
  EXPECT_TRUE(back->instances.empty());
  EXPECT_EQ(back->owners[5], 0u);
}

TEST(PlyRoundTrip, InstanceBakedAtTimeRendersLikeTheSceneAtThatTime) {
  GaussianScene scene = MakeInstanceScene();
  // Place the instance so that it is visible at t = 1.5 s.
  scene.instances[0].boxes[1].center = {1, 0, 5};
  const int64_t t = 1'500'000;
  PlyExportOptions options;
  options.timestamp_us = t;
  absl::StatusOr<GaussianScene> back = DecodePly(*EncodePly(scene, options), "mem.ply");
  ASSERT_TRUE(back.ok()) << back.status();
  absl::StatusOr<RenderBuffers> a = Render(scene, MakeCamera(), t, {});
  absl::StatusOr<RenderBuffers> b = Render(*back, MakeCamera(), t, {});
  ASSERT_TRUE(a.ok() && b.ok());
  ExpectNear(a->rgb, b->rgb, 1e-4f, "rgb");
  ExpectNear(a->alpha, b->alpha, 1e-4f, "alpha");
  ExpectNear(a->depth, b->depth, 1e-4f, "depth");
}

TEST(PlyImport, ReadsAsciiWithAnyOrderExtraPropertiesAndOtherElements) {
  const std::string ply =
      "ply\r\n"
      "format ascii 1.0\n"
      "comment from another tool\n"
      "element camera 1\n"
      "property float fov\n"
      "element vertex 2\n"
      "property float opacity\n"
      "property uchar flag\n"
      "property double z\n"
      "property float rot_3\nproperty float rot_2\nproperty float rot_1\nproperty float rot_0\n"
      "property float scale_2\nproperty float scale_1\nproperty float scale_0\n"
      "property float y\nproperty float x\n"
      "property float f_dc_2\nproperty float f_dc_1\nproperty float f_dc_0\n"
      "property float f_rest_0\nproperty float f_rest_1\nproperty float f_rest_2\n"
      "property float f_rest_3\nproperty float f_rest_4\nproperty float f_rest_5\n"
      "property float f_rest_6\nproperty float f_rest_7\nproperty float f_rest_8\n"
      "element face 1\n"
      "property list uchar int vertex_indices\n"
      "end_header\n"
      "0.9\n"
      "0.5 7 3.25 0.4 0.3 0.2 0.1 -1 -2 -3 2 1 0.1 0.2 0.3 1 2 3 4 5 6 7 8 9\n"
      "-0.5 0 4 0 0 0 1 -1 -1 -1 0 0 0 0 0 0 0 0 0 0 0 0 0 0\n"
      "3 0 1 1\n";
  absl::StatusOr<GaussianScene> scene = DecodePly(ply, "ascii.ply");
  ASSERT_TRUE(scene.ok()) << scene.status();
  ASSERT_EQ(scene->size(), 2u);
  EXPECT_EQ(scene->low_pass, kThreeDgsLowPass);  // Another tool's scene: the 3DGS low-pass.
  EXPECT_EQ(scene->sh_degree, 1);
  EXPECT_EQ(scene->num_channels, 3);
  EXPECT_EQ(scene->means[0], 1.f);
  EXPECT_EQ(scene->means[1], 2.f);
  EXPECT_EQ(scene->means[2], 3.25f);
  EXPECT_EQ(scene->opacity_logits[0], 0.5f);
  EXPECT_EQ(scene->log_scales[0], -3.f);
  EXPECT_EQ(scene->log_scales[2], -1.f);
  EXPECT_FLOAT_EQ(scene->rotations[0], 0.1f);  // rot_0 = w
  EXPECT_FLOAT_EQ(scene->rotations[3], 0.4f);
  // sh[c][0] = f_dc_c; sh[c][1..3] = f_rest[3c .. 3c+2].
  const std::vector<float> expected_sh = {0.3f, 1, 2, 3, 0.2f, 4, 5, 6, 0.1f, 7, 8, 9};
  ASSERT_EQ(scene->sh.size(), 24u);
  for (int k = 0; k < 12; ++k) EXPECT_FLOAT_EQ(scene->sh[k], expected_sh[k]) << k;
  for (int k = 12; k < 24; ++k) EXPECT_EQ(scene->sh[k], 0.f) << k;
  EXPECT_NEAR(scene->features[0], 0.5 + kShC0 * 0.3, 1e-6);
  EXPECT_TRUE(std::isinf(scene->lifespans[0]));
}

TEST(PlyImport, ReadsBigEndianBinaryAndPlainRgb) {
  std::string ply =
      "ply\nformat binary_big_endian 1.0\nelement vertex 1\n"
      "property float x\nproperty float y\nproperty float z\n"
      "property uchar red\nproperty uchar green\nproperty uchar blue\n"
      "property float opacity\nproperty float scale_0\nproperty float scale_1\n"
      "property float scale_2\nproperty float rot_0\nproperty float rot_1\n"
      "property float rot_2\nproperty float rot_3\nend_header\n";
  auto put_float = [&ply](float v) {
    char b[4];
    std::memcpy(b, &v, 4);
    for (int i = 3; i >= 0; --i) ply.push_back(b[i]);
  };
  put_float(1.5f);
  put_float(-2.f);
  put_float(8.f);
  ply.push_back(static_cast<char>(255));
  ply.push_back(static_cast<char>(0));
  ply.push_back(static_cast<char>(51));
  for (float v : {2.f, -1.f, -1.f, -1.f, 1.f, 0.f, 0.f, 0.f}) put_float(v);
  absl::StatusOr<GaussianScene> scene = DecodePly(ply, "big.ply");
  ASSERT_TRUE(scene.ok()) << scene.status();
  EXPECT_EQ(scene->sh_degree, -1);
  EXPECT_EQ(scene->means, (std::vector<float>{1.5f, -2.f, 8.f}));
  EXPECT_FLOAT_EQ(scene->features[0], 1.f);
  EXPECT_FLOAT_EQ(scene->features[1], 0.f);
  EXPECT_FLOAT_EQ(scene->features[2], 0.2f);
  EXPECT_EQ(scene->opacity_logits[0], 2.f);
}

TEST(PlyImport, ErrorsNameTheProblem) {
  const std::string good = *EncodePly(MakeScene(1, 3));
  auto message = [](const std::string& bytes) {
    absl::Status status = DecodePly(bytes, "x.ply").status();
    EXPECT_FALSE(status.ok());
    return std::string(status.message());
  };
  EXPECT_NE(message("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                    "property float y\nproperty float z\nproperty float scale_0\n"
                    "property float scale_1\nproperty float scale_2\nproperty float rot_0\n"
                    "property float rot_1\nproperty float rot_2\nproperty float rot_3\n"
                    "property float opacity\nproperty float f_dc_0\nproperty float f_dc_1\n"
                    "property float f_dc_2\nproperty float pf_colour_gradient_0\n"
                    "property float pf_colour_gradient_1\nend_header\n"
                    "0 0 1 -3 -3 -3 1 0 0 0 2 0 0 0 0.1 0.2\n")
                .find("2 of the 6 pf_colour_gradient_* properties"),
            std::string::npos);
  EXPECT_NE(message("plx\n").find("not a PLY file"), std::string::npos);
  EXPECT_NE(message("ply\nformat ascii 1.0\nelement vertex 1\n").find("no end_header"),
            std::string::npos);
  EXPECT_NE(message("ply\nformat ascii 1.0\nelement vertex many\nend_header\n")
                .find("x.ply: PLY header line 3: expected 'element <name> <count>'"),
            std::string::npos);
  EXPECT_NE(message("ply\nformat ascii 1.0\nelement vertex 1\nproperty quad x\nend_header\n")
                .find("line 4: unknown type 'quad'"),
            std::string::npos);
  // Truncated body: both sizes named.
  const std::string truncated = good.substr(0, good.size() - 7);
  const std::string m = message(truncated);
  EXPECT_NE(m.find("truncated"), std::string::npos) << m;
  EXPECT_NE(m.find("declares 6 items of 116 bytes (696 bytes) but only 689 bytes follow"),
            std::string::npos)
      << m;
  EXPECT_NE(m.find(absl::StrCat("the file has ", truncated.size(), " bytes")), std::string::npos)
      << m;
  // Missing required property.
  std::string no_opacity = good;
  no_opacity.replace(no_opacity.find("property float opacity"), 22, "property float opacitx");
  EXPECT_NE(message(no_opacity).find("vertex property 'opacity' is missing"), std::string::npos);
  // An f_rest count that is no SH degree.
  std::string bad_rest = good;
  bad_rest.replace(bad_rest.find("property float f_rest_8"), 23, "property float f_rest_X");
  EXPECT_NE(message(bad_rest).find("8 f_rest_* properties is no SH degree"), std::string::npos);
  // A hostile vertex count is refused before allocating.
  EXPECT_NE(message("ply\nformat binary_little_endian 1.0\nelement vertex 99999999999999\n"
                    "property float x\nend_header\n1234")
                .find("declares 99999999999999 items"),
            std::string::npos);
  EXPECT_EQ(ImportPly("/nonexistent/x.ply").status().code(), absl::StatusCode::kNotFound);
}

// Found by ply_fuzzer: a list length of float type beyond uint64_t (or NaN)
// was converted to an integer, which is undefined behaviour.
TEST(PlyImport, HugeOrNanFloatListLengthIsAnError) {
  for (float count : {1e30f, std::numeric_limits<float>::quiet_NaN()}) {
    std::string ply =
        "ply\nformat binary_little_endian 1.0\nelement face 1\n"
        "property list float int vertex_indices\nelement vertex 1\n";
    for (const char* name : {"x", "y", "z", "opacity", "scale_0", "scale_1", "scale_2", "rot_0",
                             "rot_1", "rot_2", "rot_3"}) {
      absl::StrAppend(&ply, "property float ", name, "\n");
    }
    ply += "end_header\n";
    char bytes[4];
    std::memcpy(bytes, &count, 4);
    ply.append(bytes, 4);
    ply.append(11 * 4, '\0');  // The vertex.
    const absl::Status status = DecodePly(ply, "f.ply").status();
    EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument) << count;
    EXPECT_NE(std::string(status.message()).find("element 'face' item 0: list length"),
              std::string::npos)
        << status;
    EXPECT_NE(std::string(status.message()).find("exceeds the 44 bytes left"), std::string::npos)
        << status;
  }
}

}  // namespace
}  // namespace pf
