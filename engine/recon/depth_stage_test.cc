// Tests of the depth stage's fill of gaps enclosed by known depth.
#include "engine/recon/depth_stage.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

namespace pf {
namespace {

constexpr int kW = 120, kH = 80;

ContextView BlankView() {
  ContextView view;
  view.camera = CameraModel(kW, kH, 100, 100, kW / 2.0, kH / 2.0);
  view.rgb = ImageF(kW, kH, 3);
  return view;
}

// A crown seen against the sky: rows 30-79 known (the crown's lower part at
// 10 m on the left half, 20 m on the right), rows 0-29 unknown (the sky
// above it), and inside the crown the gaps `gaps` (x0, y0, x1, y1,
// exclusive ends) unknown.
ImageF Crown(const std::vector<std::vector<int>>& gaps) {
  ImageF depth(kW, kH, 1);
  for (int y = 30; y < kH; ++y)
    for (int x = 0; x < kW; ++x) depth.at(x, y) = x < kW / 2 ? 10.f : 20.f;
  for (const std::vector<int>& g : gaps)
    for (int y = g[1]; y < g[3]; ++y)
      for (int x = g[0]; x < g[2]; ++x) depth.at(x, y) = 0.f;
  return depth;
}

TEST(EnclosedGaps, TakeTheDeepestDepthAroundThemAndLeaveTheOpenSky) {
  // A gap inside the left half (10 m all round), one across the halves'
  // edge (10 m on its left, 20 m on its right: the deeper), and one wider
  // than the reach (70 px across, 20 rows).
  std::vector<ImageF> measured = {Crown({{10, 40, 30, 50}, {50, 55, 70, 65}, {25, 68, 95, 78}})};
  const ImageF before = measured[0];
  const int64_t set = FillEnclosedGaps({BlankView()}, {true}, &measured, 32);
  int64_t changed = 0;
  for (int y = 0; y < kH; ++y) {
    for (int x = 0; x < kW; ++x) {
      const float d = measured[0].at(x, y);
      changed += d != before.at(x, y);
      if (y < 30) {
        EXPECT_EQ(d, 0.f) << x << "," << y;  // The sky: open above.
      } else if (x >= 10 && x < 30 && y >= 40 && y < 50) {
        EXPECT_EQ(d, 10.f) << x << "," << y;
      } else if (x >= 50 && x < 70 && y >= 55 && y < 65) {
        EXPECT_EQ(d, 20.f) << x << "," << y;
      } else if (x >= 25 && x < 95 && y >= 68 && y < 78) {
        // 70 px across: no pixel has known depth within 32 px both ways
        // along its row.
        EXPECT_EQ(d, 0.f) << x << "," << y;
      } else {
        EXPECT_EQ(d, before.at(x, y)) << x << "," << y;
      }
    }
  }
  EXPECT_EQ(set, changed);
  EXPECT_EQ(set, 20 * 10 + 20 * 10);
}

TEST(EnclosedGaps, LeaveTheEgoBodyAndViewsNotAskedFor) {
  ContextView view = BlankView();
  view.ego.assign(size_t(kW) * kH, 0);
  for (int y = 40; y < 50; ++y)
    for (int x = 10; x < 20; ++x) view.ego[size_t(y) * kW + x] = 1;
  std::vector<ImageF> measured = {Crown({{10, 40, 30, 50}}), Crown({{10, 40, 30, 50}})};
  const std::vector<ImageF> before = measured;
  EXPECT_EQ(FillEnclosedGaps({view, view}, {true, false}, &measured), 10 * 10);
  for (int y = 40; y < 50; ++y) {
    for (int x = 10; x < 30; ++x) EXPECT_EQ(measured[0].at(x, y), x < 20 ? 0.f : 10.f);
  }
  EXPECT_EQ(measured[1].pixels, before[1].pixels);
}

}  // namespace
}  // namespace pf
