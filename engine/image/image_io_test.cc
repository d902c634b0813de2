// Tests for image and depth-map reading and writing.
#include "engine/image/image_io.h"

#include <gtest/gtest.h>

#include <cmath>

namespace pf {
namespace {

TEST(ImageIo, PngRoundTripKeepsSizeAndEightBitValues) {
  ImageF image(5, 3, 3);
  for (int y = 0; y < 3; ++y)
    for (int x = 0; x < 5; ++x)
      for (int c = 0; c < 3; ++c) image.at(x, y, c) = ((x * 3 + y * 5 + c * 7) % 256) / 255.f;
  const std::string path = ::testing::TempDir() + "/rt.png";
  ASSERT_TRUE(WritePng(path, image).ok());
  auto info = ReadImageInfo(path);
  ASSERT_TRUE(info.ok()) << info.status();
  EXPECT_EQ(info->width, 5);
  EXPECT_EQ(info->height, 3);
  EXPECT_EQ(info->format, "png");
  auto back = ReadImage(path, 3);
  ASSERT_TRUE(back.ok()) << back.status();
  for (size_t i = 0; i < image.pixels.size(); ++i) {
    ASSERT_NEAR(back->pixels[i], image.pixels[i], 0.5f / 255.f) << i;
  }
}

// Halving and thirding average each output pixel's 2x2 / 3x3 block of input
// pixels (area filter), not a neighbourhood reaching beyond it.
TEST(ImageIo, ResizeAveragesEachOutputPixelsFootprint) {
  ImageF image(6, 6, 3);
  for (int y = 0; y < 6; ++y)
    for (int x = 0; x < 6; ++x)
      for (int c = 0; c < 3; ++c) image.at(x, y, c) = ((x * 37 + y * 91 + c * 53) % 256) / 255.f;
  const std::string src = ::testing::TempDir() + "/resize_src.png";
  ASSERT_TRUE(WritePng(src, image).ok());
  for (int factor : {2, 3}) {
    const std::string dst = ::testing::TempDir() + "/resize_" + std::to_string(factor) + ".png";
    const int n = 6 / factor;
    ASSERT_TRUE(ResizeImageFile(src, dst, n, n).ok());
    auto small = ReadImage(dst, 3);
    ASSERT_TRUE(small.ok()) << small.status();
    ASSERT_EQ(small->width, n);
    ASSERT_EQ(small->height, n);
    for (int y = 0; y < n; ++y) {
      for (int x = 0; x < n; ++x) {
        for (int c = 0; c < 3; ++c) {
          double mean = 0;
          for (int j = 0; j < factor; ++j)
            for (int i = 0; i < factor; ++i) mean += image.at(x * factor + i, y * factor + j, c);
          mean /= factor * factor;
          EXPECT_NEAR(small->at(x, y, c), mean, 0.6 / 255) << factor << " " << x << "," << y;
        }
      }
    }
  }
  EXPECT_EQ(ResizeImageFile(src, src + ".png", 0, 3).code(), absl::StatusCode::kInvalidArgument);
}

TEST(ImageIo, ColourImagesDecodeToTheAskedEncoding) {
  const std::string dir = ::testing::TempDir();
  ImageF ramp(256, 1, 3);
  for (int x = 0; x < 256; ++x)
    for (int c = 0; c < 3; ++c) ramp.at(x, 0, c) = x / 255.f;
  const std::string png = dir + "/ramp.png";
  ASSERT_TRUE(WritePng(png, ramp).ok());
  // An 8-bit PNG holds sRGB-encoded values unless its camera says otherwise.
  absl::StatusOr<ImageF> linear = ReadColourImage(png, 3, std::nullopt, ColourEncoding::kLinear);
  absl::StatusOr<ImageF> kept = ReadColourImage(png, 3, std::nullopt, ColourEncoding::kSrgb);
  absl::StatusOr<ImageF> declared =
      ReadColourImage(png, 3, ColourEncoding::kLinear, ColourEncoding::kLinear);
  ASSERT_TRUE(linear.ok() && kept.ok() && declared.ok());
  for (int x = 0; x < 256; ++x) {
    EXPECT_NEAR(linear->at(x, 0, 1), SrgbToLinear(x / 255.f), 1e-6) << x;
    EXPECT_NEAR(kept->at(x, 0, 1), x / 255.f, 1e-6) << x;
    EXPECT_NEAR(declared->at(x, 0, 1), x / 255.f, 1e-6) << x;
  }
  // A float EXR holds linear light: it reads back unchanged as linear, and
  // encoded as sRGB when asked.
  ImageF light(3, 1, 1);
  light.pixels = {0.0f, 0.18f, 4.0f};
  const std::string exr = dir + "/light.exr";
  ASSERT_TRUE(WriteDepthExr(exr, light).ok());
  absl::StatusOr<ImageF> same = ReadColourImage(exr, 3, std::nullopt, ColourEncoding::kLinear);
  absl::StatusOr<ImageF> encoded = ReadColourImage(exr, 3, std::nullopt, ColourEncoding::kSrgb);
  ASSERT_TRUE(same.ok() && encoded.ok());
  for (int x = 0; x < 3; ++x) {
    EXPECT_EQ(same->at(x, 0, 0), light.pixels[x]);
    EXPECT_FLOAT_EQ(encoded->at(x, 0, 2), LinearToSrgb(light.pixels[x]));
  }
}

TEST(ImageIo, DepthExrAndPng16RoundTrip) {
  ImageF depth(4, 2, 1);
  for (int i = 0; i < 8; ++i) depth.pixels[i] = i == 3 ? 0.f : 1.5f + 10.25f * i;
  const std::string exr = ::testing::TempDir() + "/d.exr";
  const std::string png = ::testing::TempDir() + "/d.png";
  ASSERT_TRUE(WriteDepthExr(exr, depth).ok());
  ASSERT_TRUE(WriteDepthPng16(png, depth).ok());
  auto from_exr = ReadDepth(exr);
  auto from_png = ReadDepth(png);
  ASSERT_TRUE(from_exr.ok()) << from_exr.status();
  ASSERT_TRUE(from_png.ok()) << from_png.status();
  for (int i = 0; i < 8; ++i) {
    EXPECT_FLOAT_EQ(from_exr->pixels[i], depth.pixels[i]);
    EXPECT_NEAR(from_png->pixels[i], depth.pixels[i], 0.5f / 256.f);
  }
}

TEST(ImageIo, EightBitPngIsNotADepthMapAndMissingFileIsNotFound) {
  ImageF grey(2, 2, 1);
  const std::string path = ::testing::TempDir() + "/grey.png";
  ASSERT_TRUE(WritePng(path, grey).ok());
  auto depth = ReadDepth(path);
  ASSERT_FALSE(depth.ok());
  EXPECT_NE(depth.status().message().find("16-bit PNG"), std::string::npos);
  EXPECT_EQ(ReadImageInfo(path + ".nope").status().code(), absl::StatusCode::kNotFound);
}

}  // namespace
}  // namespace pf
