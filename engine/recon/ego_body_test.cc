#include "engine/recon/ego_body.h"

#include <algorithm>
#include <cmath>

#include "gtest/gtest.h"

namespace pf {
namespace {

constexpr int kRigW = 160, kRigH = 120;
constexpr int kBodyTop = 100;    // Rows from here down are the body in BodyRig views.
constexpr double kWallZ = 20.0;  // World z of the textured wall.

// The wall's colour at world (x, y).
void WallColour(double x, double y, float rgb[3]) {
  rgb[0] = float(0.5 + 0.35 * std::sin(3.1 * x) * std::cos(2.3 * y));
  rgb[1] = float(0.5 + 0.35 * std::cos(1.7 * x + 0.4 * y));
  rgb[2] = float(0.5 + 0.35 * std::sin(2.9 * y - 1.1 * x));
}

// The body's colour at pixel (x, y): a 4-pixel check, the same in every frame.
float BodyColour(int x, int y, int c) { return 0.15f + 0.1f * float(((x / 4) + (y / 4) + c) % 2); }

struct RigView {
  ContextView view;
  ViewDepth depth;
};

// A view from (0, 0, z) looking along +z at the wall, with the body over
// rows >= kBodyTop when `body`. The body's pixels have a depth of 3 m, as a
// completion from the road around it would give them.
RigView MakeView(const std::string& camera_id, double z, bool body) {
  RigView r;
  r.view.camera_id = camera_id;
  r.view.camera = CameraModel(kRigW, kRigH, 100, 100, kRigW / 2.0, kRigH / 2.0);
  r.view.world_from_camera.translation = {0, 0, z};
  r.view.rgb = ImageF(kRigW, kRigH, 3);
  r.depth.width = kRigW;
  r.depth.height = kRigH;
  r.depth.depth.assign(size_t(kRigW) * kRigH, float(kWallZ - z));
  if (body) std::fill(r.depth.depth.begin() + size_t(kRigW) * kBodyTop, r.depth.depth.end(), 3.f);
  r.depth.source.assign(size_t(kRigW) * kRigH, uint8_t(DepthSource::kCompleted));
  for (int y = 0; y < kRigH; ++y) {
    for (int x = 0; x < kRigW; ++x) {
      float rgb[3];
      const double d = kWallZ - z;
      WallColour((x + 0.5 - kRigW / 2.0) / 100 * d, (y + 0.5 - kRigH / 2.0) / 100 * d, rgb);
      for (int c = 0; c < 3; ++c) {
        r.view.rgb.at(x, y, c) = body && y >= kBodyTop ? BodyColour(x, y, c) : rgb[c];
      }
    }
  }
  return r;
}

struct Rig {
  std::vector<ContextView> views;
  std::vector<ViewDepth> depths;
  void Add(RigView v) {
    views.push_back(std::move(v.view));
    depths.push_back(std::move(v.depth));
  }
};

TEST(EgoBodyTest, FindsTheBodyThatStaysWhileTheWallMoves) {
  Rig rig;
  rig.Add(MakeView("front", 0.0, true));
  rig.Add(MakeView("front", 2.5, true));
  const std::vector<EgoLayer> layers = DetectEgoBodies(rig.views, rig.depths, {});
  ASSERT_EQ(layers.size(), 1u);
  const EgoLayer& layer = layers[0];
  EXPECT_EQ(layer.camera_id, "front");
  ASSERT_EQ(layer.width, kRigW);
  ASSERT_EQ(layer.height, kRigH);
  size_t body_found = 0, wall_taken = 0;
  for (int y = 0; y < kRigH; ++y) {
    for (int x = 0; x < kRigW; ++x) {
      const size_t i = size_t(y) * kRigW + x;
      if (y >= kBodyTop) {
        body_found += layer.on_body(i);
        if (layer.on_body(i)) {
          for (int c = 0; c < 3; ++c) EXPECT_NEAR(layer.rgb[i * 3 + c], BodyColour(x, y, c), 1e-6);
        }
      } else {
        wall_taken += layer.on_body(i);
      }
    }
  }
  EXPECT_GE(body_found, size_t(0.95 * kRigW * (kRigH - kBodyTop)));
  EXPECT_LE(wall_taken, size_t(0.02 * kRigW * kBodyTop));

  std::vector<ContextView> views = rig.views;
  SetEgoMasks(layers, &views);
  for (const ContextView& view : views) EXPECT_EQ(view.ego, layer.mask);
}

TEST(EgoBodyTest, NoBodyInViewsThatChangeEverywhere) {
  Rig rig;
  rig.Add(MakeView("front", 0.0, false));
  rig.Add(MakeView("front", 2.5, false));
  EXPECT_TRUE(DetectEgoBodies(rig.views, rig.depths, {}).empty());
}

TEST(EgoBodyTest, NoEvidenceWhenTheCameraHardlyMoves) {
  Rig rig;
  rig.Add(MakeView("front", 0.0, true));
  rig.Add(MakeView("front", 0.5, true));  // Under min_travel_m.
  EXPECT_TRUE(DetectEgoBodies(rig.views, rig.depths, {}).empty());
}

TEST(EgoBodyTest, TheFarLayerSaysNothing) {
  Rig rig;
  rig.Add(MakeView("front", 0.0, true));
  rig.Add(MakeView("front", 2.5, true));
  for (ViewDepth& depth : rig.depths)
    depth.source.assign(depth.source.size(), uint8_t(DepthSource::kFar));
  EXPECT_TRUE(DetectEgoBodies(rig.views, rig.depths, {}).empty());
}

TEST(EgoBodyTest, ACameraWithItsOwnMaskKeepsIt) {
  Rig rig;
  rig.Add(MakeView("front", 0.0, true));
  rig.Add(MakeView("front", 2.5, true));
  rig.Add(MakeView("side", 0.0, false));
  rig.Add(MakeView("side", 2.5, false));
  std::vector<uint8_t> own(size_t(kRigW) * kRigH, 0);
  for (size_t i = size_t(kRigW) * 110; i < own.size(); ++i) own[i] = 1;
  rig.views[0].ego = own;
  rig.views[1].ego = own;
  const std::vector<EgoLayer> layers = DetectEgoBodies(rig.views, rig.depths, {});
  ASSERT_EQ(layers.size(), 1u);  // "side" has no body.
  EXPECT_EQ(layers[0].camera_id, "front");
  EXPECT_EQ(layers[0].mask, own);
}

}  // namespace
}  // namespace pf
