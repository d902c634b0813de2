// Tests of the push-pull fill of uncovered render pixels.
#include "engine/render/hole_fill.h"

#include <gtest/gtest.h>

#include <vector>

namespace pf {
namespace {

// A w x h premultiplied render of one colour, fully covered.
struct Render {
  int w, h;
  std::vector<float> rgb, alpha;
  Render(int width, int height, float r, float g, float b)
      : w(width), h(height), rgb(size_t(width) * height * 3), alpha(size_t(width) * height, 1.f) {
    for (size_t p = 0; p < alpha.size(); ++p) {
      rgb[3 * p] = r;
      rgb[3 * p + 1] = g;
      rgb[3 * p + 2] = b;
    }
  }
  void Uncover(int x, int y, float a = 0.f) {
    const size_t p = size_t(y) * w + x;
    for (int c = 0; c < 3; ++c) rgb[3 * p + c] *= a;  // Premultiplied.
    alpha[p] = a;
  }
  const float* At(const std::vector<float>& image, int x, int y) const {
    return &image[3 * (size_t(y) * w + x)];
  }
};

TEST(FillUncovered, CoveredPixelsAreUnchanged) {
  Render r(13, 7, 0.2f, 0.5f, 0.7f);
  r.rgb[3 * 10] = 0.9f;  // Some variation.
  EXPECT_EQ(FillUncovered(r.rgb, r.alpha, r.w, r.h), r.rgb);
}

TEST(FillUncovered, AHoleInsideOneSurfaceTakesItsColour) {
  Render r(32, 24, 0.3f, 0.6f, 0.1f);
  for (int y = 8; y < 14; ++y) {
    for (int x = 5; x < 17; ++x) r.Uncover(x, y);
  }
  r.Uncover(30, 2, 0.4f);  // Under half covered: its uncovered part too.
  const std::vector<float> out = FillUncovered(r.rgb, r.alpha, r.w, r.h);
  for (int y = 0; y < r.h; ++y) {
    for (int x = 0; x < r.w; ++x) {
      const float* p = r.At(out, x, y);
      ASSERT_NEAR(p[0], 0.3f, 1e-5) << x << "," << y;
      ASSERT_NEAR(p[1], 0.6f, 1e-5) << x << "," << y;
      ASSERT_NEAR(p[2], 0.1f, 1e-5) << x << "," << y;
    }
  }
}

TEST(FillUncovered, PixelsAtLeastHalfCoveredAreKeptAsTheColourFitLeftThem) {
  // The colour fit matches rgb over black where alpha >= 0.5, so those
  // pixels are final; under the threshold they are composited over the fill.
  Render r(8, 8, 0.5f, 0.5f, 0.5f);
  r.Uncover(3, 3, 0.7f);
  r.Uncover(5, 5, 0.3f);
  const std::vector<float> out = FillUncovered(r.rgb, r.alpha, r.w, r.h);
  EXPECT_FLOAT_EQ(r.At(out, 3, 3)[0], 0.35f);
  EXPECT_NEAR(r.At(out, 5, 5)[0], 0.5f, 1e-4);  // (3, 3), darker, is far up the pyramid.
  // With a threshold above 0.7 that pixel is filled too.
  const std::vector<float> strict = FillUncovered(r.rgb, r.alpha, r.w, r.h, 0.99f);
  EXPECT_NEAR(r.At(strict, 3, 3)[0], 0.5f, 1e-6);
}

TEST(FillUncovered, AGapBetweenTwoSurfacesTakesTheNearerOneMostly) {
  // Left half red, right half blue, a 4-pixel-wide gap of nothing between.
  const int w = 40, h = 16;
  Render r(w, h, 1.f, 0.f, 0.f);
  for (int y = 0; y < h; ++y) {
    for (int x = 20; x < w; ++x) {
      const size_t p = size_t(y) * w + x;
      r.rgb[3 * p] = 0.f;
      r.rgb[3 * p + 2] = 1.f;
    }
    for (int x = 18; x < 22; ++x) r.Uncover(x, y);
  }
  const std::vector<float> out = FillUncovered(r.rgb, r.alpha, w, h);
  for (int y = 0; y < h; ++y) {
    for (int x = 18; x < 22; ++x) {
      const float* p = r.At(out, x, y);
      // Only red and blue around: the fill is a blend of the two, opaque.
      EXPECT_NEAR(p[0] + p[2], 1.f, 1e-5) << x << "," << y;
      EXPECT_NEAR(p[1], 0.f, 1e-6);
    }
    // Each side of the gap leans to its own neighbour.
    EXPECT_GT(r.At(out, 18, y)[0], r.At(out, 18, y)[2]) << y;
    EXPECT_GT(r.At(out, 21, y)[2], r.At(out, 21, y)[0]) << y;
  }
  // Outside the gap nothing moved.
  EXPECT_EQ(r.At(out, 17, 3)[0], 1.f);
  EXPECT_EQ(r.At(out, 22, 3)[2], 1.f);
}

TEST(FillUncovered, NothingCoveredStaysBlackAndBadSizesAreReturnedAsIs) {
  Render r(9, 5, 0.f, 0.f, 0.f);
  for (float& a : r.alpha) a = 0.f;
  const std::vector<float> out = FillUncovered(r.rgb, r.alpha, r.w, r.h);
  for (float v : out) EXPECT_EQ(v, 0.f);
  const std::vector<float> rgb = {0.5f, 0.5f, 0.5f};
  EXPECT_EQ(FillUncovered(rgb, {}, 1, 1), rgb);  // No alpha: nothing to do.
  EXPECT_TRUE(FillUncovered({}, {}, 0, 0).empty());
}

}  // namespace
}  // namespace pf
