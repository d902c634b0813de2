#include "engine/recon/ego_body.h"

#include <algorithm>
#include <cmath>
#include <utility>

#include "engine/render/ego_layer.h"
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

// A low-contrast street: a wall nearly as flat as a road, and a body of about
// its colour whose top edge is a dark lip with two dark stripes below it (a
// trunk's lid and its reflections). Colour alone cannot tell them apart.
// The body covers columns [x_begin, x_end).
RigView MakeFlatView(const std::string& camera_id, double z, bool body, int x_begin = 0,
                     int x_end = kRigW) {
  RigView r = MakeView(camera_id, z, body);
  for (int y = 0; y < kRigH; ++y) {
    for (int x = 0; x < kRigW; ++x) {
      for (int c = 0; c < 3; ++c) {
        float colour = 0.35f + 0.01f * float(c);
        if (body && y >= kBodyTop && x >= x_begin && x < x_end) {
          const bool dark =
              y < kBodyTop + 2 || ((y == kBodyTop + 8 || y == kBodyTop + 14) && x % 40 >= 10);
          colour = dark ? 0.2f : 0.4f + 0.01f * float(c);
        }
        r.view.rgb.at(x, y, c) = colour;
      }
    }
  }
  return r;
}

// A street seen from a camera driving along it: two dark lines on a flat
// grey, running from the vanishing point (the image centre) to the bottom
// corners. Driving on moves every point along its line, so the lines stay
// where they are in the image, as a body's edges would; a frame further
// back sees the street smaller.
RigView MakeLaneView(double z) {
  RigView r = MakeView("front", z, false);
  for (int y = 0; y < kRigH; ++y) {
    for (int x = 0; x < kRigW; ++x) {
      const double dx = x + 0.5 - kRigW / 2.0, dy = y + 0.5 - kRigH / 2.0;
      bool line = false;
      for (double side : {-1.0, 1.0}) {
        // Angle from the ray to the bottom corner on `side`, in radians.
        const double off = std::atan2(dy, dx) - std::atan2(kRigH / 2.0, side * kRigW / 2.0);
        line |= dy > 0 && std::abs(off) < 0.03;
      }
      for (int c = 0; c < 3; ++c) r.view.rgb.at(x, y, c) = line ? 0.15f : 0.45f;
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

// The body pixels of `layer` in columns [x_begin, x_end): in rows >= y_begin
// (of the body's), and above the body (the wall).
std::pair<size_t, size_t> BodyAndWall(const EgoLayer& layer, int x_begin = 0, int x_end = kRigW,
                                      int y_begin = kBodyTop) {
  size_t body = 0, wall = 0;
  for (int y = 0; y < kRigH; ++y) {
    for (int x = x_begin; x < x_end; ++x) {
      const bool on = layer.on_body(size_t(y) * kRigW + x);
      if (y < kBodyTop) wall += on;
      if (y >= y_begin) body += on;
    }
  }
  return {body, wall};
}

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

TEST(EgoBodyTest, KeepsTheBodyAsEachContextTimeShowsIt) {
  // The camera's own mask (rows >= kBodyTop); the body 0.1 brighter at
  // 0.2 s, where two views (0.1 and 0.3 brighter) are averaged.
  Rig rig;
  const float brighter[3] = {0.f, 0.1f, 0.3f};
  const int64_t times[3] = {200'000, 0, 200'000};
  for (int k = 0; k < 3; ++k) {
    RigView v = MakeView("front", 0.5 * k, true);
    v.view.timestamp_us = times[k];
    v.view.ego.assign(size_t(kRigW) * kRigH, 0);
    for (int y = kBodyTop; y < kRigH; ++y) {
      for (int x = 0; x < kRigW; ++x) {
        v.view.ego[size_t(y) * kRigW + x] = 1;
        for (int c = 0; c < 3; ++c) v.view.rgb.at(x, y, c) += brighter[k];
      }
    }
    rig.Add(std::move(v));
  }
  const std::vector<EgoLayer> layers = DetectEgoBodies(rig.views, rig.depths, {});
  ASSERT_EQ(layers.size(), 1u);
  const EgoLayer& layer = layers[0];
  ASSERT_EQ(layer.frames.size(), 2u);
  EXPECT_EQ(layer.frames[0].timestamp_us, 0);
  EXPECT_EQ(layer.frames[1].timestamp_us, 200'000);
  const size_t body = size_t(kRigW) * (kRigH - kBodyTop);
  ASSERT_EQ(layer.frames[0].rgb.size(), body * 3);
  ASSERT_EQ(layer.frames[1].rgb.size(), body * 3);
  EXPECT_TRUE(CheckEgoLayer(layer, "ego").ok());
  size_t next = 0;
  for (int y = kBodyTop; y < kRigH; ++y) {
    for (int x = 0; x < kRigW; ++x, ++next) {
      const size_t i = size_t(y) * kRigW + x;
      for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(layer.frames[0].rgb[next * 3 + c], BodyColour(x, y, c) + 0.1f, 1e-6);
        EXPECT_NEAR(layer.frames[1].rgb[next * 3 + c], BodyColour(x, y, c) + 0.15f, 1e-6);
        EXPECT_NEAR(layer.rgb[i * 3 + c], BodyColour(x, y, c) + 0.4f / 3, 1e-6);
      }
    }
  }
}

TEST(EgoBodyTest, NoBodyInViewsThatChangeEverywhere) {
  Rig rig;
  rig.Add(MakeView("front", 0.0, false));
  rig.Add(MakeView("front", 2.5, false));
  EXPECT_TRUE(DetectEgoBodies(rig.views, rig.depths, {}).empty());
}

TEST(EgoBodyTest, FindsABodyLikeTheRoadByItsEdgesThatStay) {
  Rig rig;
  rig.Add(MakeFlatView("back", 0.0, true));
  rig.Add(MakeFlatView("back", 0.9, true));
  const std::vector<EgoLayer> layers = DetectEgoBodies(rig.views, rig.depths, {});
  ASSERT_EQ(layers.size(), 1u);
  const auto [body_found, wall_taken] = BodyAndWall(layers[0]);
  EXPECT_GE(body_found, size_t(0.95 * kRigW * (kRigH - kBodyTop)));
  EXPECT_LE(wall_taken, size_t(0.05 * kRigW * kBodyTop));

  Rig plain;  // The same street without the body: nothing stays put.
  plain.Add(MakeFlatView("back", 0.0, false));
  plain.Add(MakeFlatView("back", 0.9, false));
  EXPECT_TRUE(DetectEgoBodies(plain.views, plain.depths, {}).empty());
}

TEST(EgoBodyTest, AShortStillEdgeIsNoBody) {
  Rig rig;  // A fifth of the width: under the quarter a body's outline spans.
  rig.Add(MakeFlatView("back", 0.0, true, 64, 96));
  rig.Add(MakeFlatView("back", 0.9, true, 64, 96));
  EXPECT_TRUE(DetectEgoBodies(rig.views, rig.depths, {}).empty());
  Rig wide;  // The same body across half the width is found.
  wide.Add(MakeFlatView("back", 0.0, true, 40, 120));
  wide.Add(MakeFlatView("back", 0.9, true, 40, 120));
  EXPECT_EQ(DetectEgoBodies(wide.views, wide.depths, {}).size(), 1u);
}

TEST(EgoBodyTest, LinesTheDriveLeavesInPlaceAreNoBody) {
  Rig rig;
  rig.Add(MakeLaneView(0.0));
  rig.Add(MakeLaneView(9.0));  // The wall 20 m and 11 m away.
  EgoBodyOptions options;
  options.work_width = kRigW / 2;  // Blocks of 2x2 pixels, as on real images.
  EXPECT_TRUE(DetectEgoBodies(rig.views, rig.depths, {}, options).empty());
}

// A moving car's box between the camera and the wall, over the left
// columns of every row: the box takes the evidence away there, but the body
// goes on in front of it, still in both frames, and is found across the
// whole width; the wall above it, which moves, is not.
TEST(EgoBodyTest, TheBodyContinuesInFrontOfABoxedCar) {
  Rig rig;
  rig.Add(MakeView("front", 0.0, true));
  rig.Add(MakeView("front", 2.5, true));
  InstanceTrack car;
  car.boxes = {{0, {-16, 0, 10}, {29, 30, 2}, Quat{}}};  // x in [-30.5, -1.5] m at z = 10.
  const std::vector<EgoLayer> layers = DetectEgoBodies(rig.views, rig.depths, {car});
  ASSERT_EQ(layers.size(), 1u);
  EXPECT_EQ(BodyAndWall(layers[0], 0, 60).first, size_t(60 * (kRigH - kBodyTop)));
  const auto [body, wall] = BodyAndWall(layers[0]);
  EXPECT_GE(body, size_t(0.95 * kRigW * (kRigH - kBodyTop)));
  EXPECT_LE(wall, size_t(0.02 * kRigW * kBodyTop));
}

// The body's lower rows give no evidence (their depth is the far layer) but
// stay the same: below the body there is only body.
TEST(EgoBodyTest, BelowTheBodyThereIsOnlyBody) {
  Rig rig;
  rig.Add(MakeView("front", 0.0, true));
  rig.Add(MakeView("front", 2.5, true));
  for (ViewDepth& depth : rig.depths) {
    std::fill(depth.source.begin() + size_t(kRigW) * (kBodyTop + 8), depth.source.end(),
              uint8_t(DepthSource::kFar));
  }
  const std::vector<EgoLayer> layers = DetectEgoBodies(rig.views, rig.depths, {});
  ASSERT_EQ(layers.size(), 1u);
  constexpr int kSilent = kBodyTop + 8;
  const auto [body, wall] = BodyAndWall(layers[0], 0, kRigW, kSilent);
  EXPECT_EQ(body, size_t(kRigW * (kRigH - kSilent)));
  EXPECT_LE(wall, size_t(0.02 * kRigW * kBodyTop));
}

// The body's last 6 columns on the right mirror the street (they change
// between the frames): a body that stops within a twentieth of the image's
// width of its side reaches the side.
TEST(EgoBodyTest, ABodyThatStopsJustShortOfTheSideReachesIt) {
  Rig rig;
  rig.Add(MakeView("front", 0.0, true));
  rig.Add(MakeView("front", 2.5, true));
  for (size_t v = 0; v < rig.views.size(); ++v) {
    for (int y = kBodyTop; y < kRigH; ++y) {
      for (int x = kRigW - 6; x < kRigW; ++x) {
        for (int c = 0; c < 3; ++c) rig.views[v].rgb.at(x, y, c) = v == 0 ? 0.1f : 0.9f;
      }
    }
  }
  const std::vector<EgoLayer> layers = DetectEgoBodies(rig.views, rig.depths, {});
  ASSERT_EQ(layers.size(), 1u);
  // Below the top two rows (beside the wall the 5x5 mean is not still).
  EXPECT_EQ(BodyAndWall(layers[0], kRigW - 6, kRigW, kBodyTop + 2).first,
            size_t(6 * (kRigH - kBodyTop - 2)));
  EXPECT_LE(BodyAndWall(layers[0]).second, size_t(0.02 * kRigW * kBodyTop));
}

// Eight frames 0.9 m apart whose body's right half mirrors the street: it
// brightens by 0.008 a frame, still within a run of four frames (0.024 at
// most between a run's frames) but not over the whole drive (0.056). Searched
// in runs, the whole body is found as still; searched over every frame at
// once, its left half is, and its right half only below its outline, which
// the motion does not explain (BelowMovedOutline).
TEST(EgoBodyTest, ABodyThatChangesOverALongDriveIsFoundInRunsOfFrames) {
  Rig rig;
  for (int k = 0; k < 8; ++k) {
    RigView v = MakeView("back", 0.9 * k, true);
    for (int y = kBodyTop; y < kRigH; ++y) {
      for (int x = kRigW / 2; x < kRigW; ++x) {
        for (int c = 0; c < 3; ++c) v.view.rgb.at(x, y, c) += 0.008f * float(k);
      }
    }
    rig.Add(std::move(v));
  }
  const int half = kRigW / 2, rows = kRigH - kBodyTop;
  const std::vector<EgoLayer> layers = DetectEgoBodies(rig.views, rig.depths, {});
  ASSERT_EQ(layers.size(), 1u);
  EXPECT_GE(BodyAndWall(layers[0], 0, half).first, size_t(0.95 * half * rows));
  EXPECT_GE(BodyAndWall(layers[0], half, kRigW).first, size_t(0.95 * half * rows));
  EXPECT_LE(BodyAndWall(layers[0]).second, size_t(0.02 * kRigW * kBodyTop));

  EgoBodyOptions at_once;
  at_once.run_frames = 0;
  const std::vector<EgoLayer> once = DetectEgoBodies(rig.views, rig.depths, {}, at_once);
  ASSERT_EQ(once.size(), 1u);
  EXPECT_GE(BodyAndWall(once[0], 0, half).first, size_t(0.95 * half * rows));
  EXPECT_GE(BodyAndWall(once[0], half + 8, kRigW).first, size_t(0.8 * (half - 8) * rows));
  EXPECT_LE(BodyAndWall(once[0]).second, size_t(0.02 * kRigW * kBodyTop));
}

// A glossy body mirrors the street: what it shows moves between the frames
// (here the wall's pattern, darkened, shifted by the drive), so it is not
// still, and the motion explains none of its outline: found below it.
TEST(EgoBodyTest, ABodyThatMirrorsTheStreetIsFoundBelowItsOutline) {
  Rig rig;
  for (double z : {0.0, 2.5}) {
    RigView v = MakeView("side", z, true);
    for (int y = kBodyTop; y < kRigH; ++y) {
      for (int x = 0; x < kRigW; ++x) {
        float rgb[3];
        WallColour(0.04 * x - 0.8 * z, 0.04 * y, rgb);
        for (int c = 0; c < 3; ++c) v.view.rgb.at(x, y, c) = 0.4f * rgb[c];
      }
    }
    rig.Add(std::move(v));
  }
  const std::vector<EgoLayer> layers = DetectEgoBodies(rig.views, rig.depths, {});
  ASSERT_EQ(layers.size(), 1u);
  const auto [body, wall] = BodyAndWall(layers[0]);
  EXPECT_GE(body, size_t(0.85 * kRigW * (kRigH - kBodyTop)));
  EXPECT_LE(wall, size_t(0.02 * kRigW * kBodyTop));
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
