// Tests of PSNR, SSIM, depth RMSE and the contact sheet against values
// computed by hand.
#include "engine/recon/image_metrics.h"

#include <gtest/gtest.h>

#include <cmath>

namespace pf {
namespace {

ImageF Constant(int w, int h, float value) {
  ImageF image(w, h, 3);
  for (float& v : image.pixels) v = value;
  return image;
}

TEST(ImageMetrics, PsnrOfAKnownError) {
  const ImageF truth = Constant(20, 10, 0.5f);
  const ImageF test = Constant(20, 10, 0.6f);  // MSE 0.01 -> 20 dB.
  EXPECT_NEAR(*Psnr(truth, test), 20.0, 1e-4);
  EXPECT_DOUBLE_EQ(*Psnr(truth, truth), kMaxPsnr);
  // Only masked pixels count: one pixel off by 0.5 (MSE 0.25 -> 6.02 dB).
  ImageF one = truth;
  for (int c = 0; c < 3; ++c) one.at(3, 4, c) = 1.0f;
  std::vector<uint8_t> mask(200, 0);
  mask[4 * 20 + 3] = 1;
  EXPECT_NEAR(*Psnr(truth, one, mask), 10 * std::log10(4.0), 1e-4);
  EXPECT_FALSE(Psnr(truth, one, std::vector<uint8_t>(200, 0)).has_value());
}

TEST(ImageMetrics, SsimOfConstantImagesMatchesTheFormula) {
  const ImageF a = Constant(32, 32, 0.5f);
  const ImageF b = Constant(32, 32, 0.6f);
  // No variance: SSIM = (2 mu_a mu_b + C1) / (mu_a^2 + mu_b^2 + C1).
  const double c1 = 1e-4;
  EXPECT_NEAR(*Ssim(a, b), (2 * 0.5 * 0.6 + c1) / (0.25 + 0.36 + c1), 1e-5);
  EXPECT_NEAR(*Ssim(a, a), 1.0, 1e-9);
  EXPECT_FALSE(Ssim(Constant(8, 8, 0), Constant(8, 8, 0)).has_value());
}

// With a mask, only the windows centred on selected pixels count: the left
// half of `b` is a's 0.5 and the right half 0.6, and a mask of the left
// half's columns 0-9 keeps only windows (11 wide) that lie within the
// left half, which match exactly.
TEST(ImageMetrics, SsimOverTheWindowsCentredOnMaskedPixels) {
  const ImageF a = Constant(32, 32, 0.5f);
  ImageF b = a;
  for (int y = 0; y < 32; ++y)
    for (int x = 16; x < 32; ++x)
      for (int c = 0; c < 3; ++c) b.at(x, y, c) = 0.6f;
  std::vector<uint8_t> left(32 * 32, 0);
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 10; ++x) left[y * 32 + x] = 1;
  EXPECT_NEAR(*Ssim(a, b, left), 1.0, 1e-9);
  EXPECT_LT(*Ssim(a, b), 0.999);
  // Centres within 5 pixels of the border have no window.
  std::vector<uint8_t> border(32 * 32, 0);
  border[0] = 1;
  EXPECT_FALSE(Ssim(a, b, border).has_value());
}

TEST(ImageMetrics, SsimDropsWithNoiseButNotWithIdenticalStructure) {
  ImageF a(40, 40, 3), noisy(40, 40, 3);
  for (int y = 0; y < 40; ++y)
    for (int x = 0; x < 40; ++x)
      for (int c = 0; c < 3; ++c) {
        a.at(x, y, c) = ((x / 4 + y / 4) % 2) ? 0.8f : 0.2f;
        noisy.at(x, y, c) = a.at(x, y, c) + (((x * 7 + y * 13) % 5) - 2) * 0.05f;
      }
  const double s = *Ssim(a, noisy);
  EXPECT_LT(s, 0.99);
  EXPECT_GT(s, 0.5);
  // The same checkerboard a little brighter: only the luminance term moves
  // (0.55 / 0.5525 at the cells' mean of 0.5).
  ImageF brighter = a;
  for (float& v : brighter.pixels) v += 0.05f;
  EXPECT_GT(*Ssim(a, brighter), 0.99);
  EXPECT_LT(*Ssim(a, brighter), 1.0);
}

TEST(ImageMetrics, DepthRmseOnlyWhereTruthHasDepth) {
  ImageF truth(2, 2, 1), test(2, 2, 1);
  truth.pixels = {10, 0, 20, std::nanf("")};
  test.pixels = {13, 99, 16, 5};
  int64_t pixels = 0;
  EXPECT_NEAR(*DepthRmse(truth, test, &pixels), std::sqrt((9.0 + 16.0) / 2), 1e-9);
  EXPECT_EQ(pixels, 2);
  EXPECT_FALSE(DepthRmse(ImageF(2, 2, 1), test).has_value());
}

TEST(ImageMetrics, ContactSheetPlacesTruthRenderAndHeat) {
  const ImageF truth = Constant(4, 2, 0.2f);
  ImageF test = Constant(4, 2, 0.2f);
  for (int c = 0; c < 3; ++c) test.at(1, 1, c) = 0.45f;  // Error 0.25 = max: white.
  const ImageF sheet = ContactSheet(truth, test, 0.25);
  ASSERT_EQ(sheet.width, 12);
  EXPECT_FLOAT_EQ(sheet.at(0, 0, 0), 0.2f);
  EXPECT_FLOAT_EQ(sheet.at(5, 1, 0), 0.45f);
  EXPECT_FLOAT_EQ(sheet.at(8, 0, 0), 0.f);  // No error: black.
  EXPECT_NEAR(sheet.at(9, 1, 2), 1.f, 1e-5);
}

}  // namespace
}  // namespace pf
