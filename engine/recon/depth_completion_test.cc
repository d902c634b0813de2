// Tests of the IP-Basic depth completion and its error measure.
#include "engine/recon/depth_completion.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>

namespace pf {
namespace {

// Samples `truth(x, y)` like LiDAR rings: every `dx`-th pixel of every
// `dy`-th row from row `top` down.
ImageF SampleRings(int w, int h, int top, int dx, int dy,
                   const std::function<float(int, int)>& truth) {
  ImageF sparse(w, h, 1);
  for (int y = top; y < h; y += dy)
    for (int x = (y / dy) % dx; x < w; x += dx) sparse.at(x, y) = truth(x, y);
  return sparse;
}

// The largest |completed - truth| / truth over rows [y0, y1) and columns
// where `use(x)`.
double WorstRelativeError(
    const ImageF& dense, int y0, int y1, const std::function<float(int, int)>& truth,
    const std::function<bool(int)>& use = [](int) { return true; }) {
  double worst = 0;
  for (int y = y0; y < y1; ++y)
    for (int x = 0; x < dense.width; ++x) {
      if (!use(x)) continue;
      worst = std::max(worst, std::abs(double(dense.at(x, y)) - truth(x, y)) / truth(x, y));
    }
  return worst;
}

// A road-like plane: 8 m at the bottom row to 24 m at row 40.
float Road(int, int y) { return 8.f + 16.f * float(240 - y) / 200.f; }

TEST(DepthCompletion, FillsASparsePlaneWithASmallError) {
  // Rings 4 rows apart, every 5th pixel: 5 % of the pixels, KITTI's density.
  const ImageF sparse = SampleRings(320, 240, 40, 5, 4, Road);
  EXPECT_EQ(IpBasicScale(sparse), 1);
  const ImageF dense = CompleteDepthIpBasic(sparse);
  // Between the top and bottom rings: within 2 % of the plane (the nearer
  // surface wins a dilation, so the fill leans to the nearer ring).
  EXPECT_LT(WorstRelativeError(dense, 44, 236, Road), 0.02);
  // Above the top ring: the top values carried up.
  EXPECT_NEAR(dense.at(100, 0), Road(100, 40), 0.05 * Road(100, 40));
}

TEST(DepthCompletion, KeepsTheEdgeOfAStep) {
  // A near plane (5 m) on the left of x = 160, a far one (20 m) on the right.
  auto step = [](int x, int) { return x < 160 ? 5.f : 20.f; };
  const ImageF sparse = SampleRings(320, 240, 0, 5, 4, step);
  const ImageF dense = CompleteDepthIpBasic(sparse);
  // Each side keeps its depth up to a few pixels from the edge (the nearer
  // surface spreads by at most the 5x5 diamond and the sampling gap).
  EXPECT_LT(WorstRelativeError(dense, 4, 236, step, [](int x) { return x < 158; }), 0.01);
  EXPECT_LT(WorstRelativeError(dense, 4, 236, step, [](int x) { return x >= 168; }), 0.01);
  // No pixel takes a depth between the two surfaces (no smeared edge).
  int between = 0;
  for (float d : dense.pixels) between += d > 5.5f && d < 19.f;
  EXPECT_LT(between, 240 * 2);
}

TEST(DepthCompletion, WorksOnACoarseGridForSparseLidar) {
  // Rings 24 rows apart, every 12th pixel: 0.35 % of the pixels, as the
  // DGP LiDAR in a 1936x1216 image. Completed on 4x4-pixel cells.
  const ImageF sparse = SampleRings(640, 480, 80, 12, 24,
                                    [](int, int y) { return 8.f + 16.f * float(480 - y) / 400.f; });
  EXPECT_EQ(IpBasicScale(sparse), 4);
  const ImageF dense = CompleteDepthIpBasic(sparse);
  EXPECT_LT(WorstRelativeError(dense, 90, 460,
                               [](int, int y) { return 8.f + 16.f * float(480 - y) / 400.f; }),
            0.08);
  int unknown = 0;
  for (float d : dense.pixels) unknown += d == 0.f;
  EXPECT_EQ(unknown, 0);
}

TEST(DepthCompletion, WithoutExtrapolationTheTopStaysUnknown) {
  const ImageF sparse = SampleRings(320, 240, 120, 5, 4, Road);
  IpBasicOptions options;
  options.extrapolate = false;
  const ImageF dense = CompleteDepthIpBasic(sparse, options);
  EXPECT_EQ(dense.at(100, 10), 0.f);
  EXPECT_GT(dense.at(100, 200), 0.f);
  EXPECT_GT(CompleteDepthIpBasic(sparse).at(100, 10), 0.f);
}

TEST(DepthCompletion, AnEmptyMapStaysEmpty) {
  const ImageF dense = CompleteDepthIpBasic(ImageF(32, 24, 1));
  for (float d : dense.pixels) ASSERT_EQ(d, 0.f);
  EXPECT_EQ(IpBasicScale(ImageF(32, 24, 1)), 1);
}

TEST(DepthCompletion, TellsSparseMapsFromDenseOnes) {
  EXPECT_TRUE(IsSparseDepth(SampleRings(320, 240, 40, 5, 4, Road)));
  ImageF dense(320, 240, 1);
  for (int y = 80; y < 240; ++y)
    for (int x = 0; x < 320; ++x) dense.at(x, y) = Road(x, y);  // The sky above row 80 unknown.
  EXPECT_FALSE(IsSparseDepth(dense));
  EXPECT_FALSE(IsSparseDepth(ImageF(32, 24, 1)));
}

TEST(DepthCompletion, MeasuresAgainstHeldOutPoints) {
  ImageF dense(4, 1, 1), held_out(4, 1, 1);
  dense.pixels = {10.f, 10.f, 0.f, 7.f};
  held_out.pixels = {10.f, 8.f, 5.f, 0.f};
  const DepthErrors e = MeasureDepthCompletion(dense, held_out);
  EXPECT_EQ(e.points, 2);
  EXPECT_EQ(e.missing, 1);
  EXPECT_DOUBLE_EQ(e.abs_rel, 0.125);        // (0 + 2 / 8) / 2.
  EXPECT_DOUBLE_EQ(e.rmse, std::sqrt(2.0));  // sqrt((0 + 4) / 2).
  EXPECT_DOUBLE_EQ(e.within_5pct, 0.5);
}

}  // namespace
}  // namespace pf
