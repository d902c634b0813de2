// Tests of the facade extension above the LiDAR's top beam.
#include "engine/recon/facade_depth.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>

#include "engine/recon/street_test_util.h"

namespace pf {
namespace {

// A street seen from the side: the road z = 0, a building front x = 12 up
// to 6 m, the sky above. The front's bricks are 0.3 m cells of random
// colours, so two views agree only where the right depth is used.
constexpr double kWallX = 12, kWallTop = 6;

Vec3 Shade(const Vec3& o, const Vec3& d) {
  if (d.x > 0) {
    const double s = (kWallX - o.x) / d.x;
    const Vec3 p = o + s * d;
    if (p.z >= 0 && p.z <= kWallTop) {
      const int a = static_cast<int>(std::floor(p.y / 0.3)),
                b = static_cast<int>(std::floor(p.z / 0.3));
      return {testing::HashedCell(a, b, 0), testing::HashedCell(a, b, 1),
              testing::HashedCell(a, b, 2)};
    }
  }
  if (d.z < 0) return {0.3, 0.3, 0.32};  // Road.
  const double up = d.z / Norm(d);
  return {0.55 + 0.2 * up, 0.65 + 0.2 * up, 0.9};  // Sky: smooth.
}

ContextView StreetView(const Vec3& position, int64_t timestamp_us) {
  ContextView view;
  view.camera_id = "cam_left";
  view.timestamp_us = timestamp_us;
  view.camera = CameraModel(160, 120, 100, 100, 80, 60);
  view.world_from_camera.rotation = Mat3::FromColumns({0, -1, 0}, {0, 0, -1}, {1, 0, 0});
  view.world_from_camera.translation = position;
  view.rgb = ImageF(160, 120, 3);
  for (int y = 0; y < 120; ++y) {
    for (int x = 0; x < 160; ++x) {
      Vec3 ray;
      view.camera.Unproject(x + 0.5, y + 0.5, &ray);
      const Vec3 c = Shade(position, view.world_from_camera.rotation * ray);
      for (int k = 0; k < 3; ++k) view.rgb.at(x, y, k) = static_cast<float>(c[k]);
    }
  }
  return view;
}

// The z depth of pixel (x, y) of `view`: the wall's or the road's, 0 for sky.
double TrueDepth(const ContextView& view, int x, int y) {
  Vec3 ray;
  view.camera.Unproject(x + 0.5, y + 0.5, &ray);
  const Vec3 d = view.world_from_camera.rotation * ray;
  const Vec3& o = view.world_from_camera.translation;
  if (d.x > 0) {
    const double s = (kWallX - o.x) / d.x;
    const double z = o.z + s * d.z;
    if (z >= 0 && z <= kWallTop) return s;
  }
  if (d.z < 0) return -o.z / d.z;
  return 0;
}

// Two views 2 m apart along the street, and the first one's "LiDAR" depth
// from row `first_row` down (a spinning LiDAR's top beam is a few degrees
// above the horizontal); the road is the ground plane of both.
struct Street {
  std::vector<ContextView> views;
  std::vector<ImageF> measured;
  std::vector<GroundPlane> grounds;
};

Street StreetWithLidarFrom(int first_row) {
  Street street;
  street.views = {StreetView({0, 0, 1.5}, 0), StreetView({0, 2, 1.5}, 500000)};
  street.measured.resize(2);
  street.measured[0] = ImageF(160, 120, 1);
  for (int y = first_row; y < 120; ++y) {
    for (int x = 0; x < 160; ++x)
      street.measured[0].at(x, y) = static_cast<float>(TrueDepth(street.views[0], x, y));
  }
  GroundPlane ground;
  ground.valid = true;
  ground.normal = {0, 0, 1};
  ground.offset = 0;
  ground.reach = 50;
  street.grounds = {ground, ground};
  return street;
}

TEST(FacadeDepth, ContinuesTheFrontUpToTheRoofAndLeavesTheSky) {
  // Depth below row 50: about 2.7 m up the front.
  const Street street = StreetWithLidarFrom(50);
  const ImageF& measured = street.measured[0];
  std::vector<ImageF> extended = street.measured;
  const int64_t set = ExtendFacades(street.views, {true, false}, street.grounds, &extended);
  // The roof line is at row 60 - 100 * 4.5 / 12 = 22.5. The second view,
  // 2 m to the first one's left, sees the front 16.7 px further right: in
  // the last 17 columns the plane's points leave its image, nothing checks
  // them and they stay unknown.
  int64_t counted = 0;
  for (int y = 0; y < 50; ++y) {
    for (int x = 2; x < 140; ++x) {
      const float d = extended[0].at(x, y);
      counted += d > 0.f;
      if (y >= 25) EXPECT_NEAR(d, TrueDepth(street.views[0], x, y), 0.05) << x << "," << y;
      if (y <= 20) EXPECT_EQ(d, 0.f) << x << "," << y;  // Sky: stays on the far layer.
    }
  }
  EXPECT_GE(counted, 138 * 25);
  // What ExtendFacades counts is what it changed (the second view was not
  // asked to).
  int64_t changed = 0;
  for (int y = 0; y < measured.height; ++y)
    for (int x = 0; x < measured.width; ++x) changed += extended[0].at(x, y) != measured.at(x, y);
  EXPECT_EQ(set, changed);
  EXPECT_EQ(extended[1].pixels, street.measured[1].pixels);
  // Measured pixels are kept.
  for (int y = 50; y < 120; ++y)
    for (int x = 0; x < 160; ++x) EXPECT_EQ(extended[0].at(x, y), measured.at(x, y));

  // Without a second view to check against, or when turned off for the view,
  // nothing is set.
  std::vector<ImageF> alone = {measured};
  EXPECT_EQ(ExtendFacades({street.views[0]}, {true}, {street.grounds[0]}, &alone), 0);
  std::vector<ImageF> off = street.measured;
  EXPECT_EQ(ExtendFacades(street.views, {false, false}, street.grounds, &off), 0);
  EXPECT_EQ(off[0].pixels, measured.pixels);
}

TEST(FacadeDepth, AFlatSkylineWithoutAWallIsLeftAlone) {
  // Depth below row 80 only (the front's foot is at row 72.5): every
  // column's top measured points are on the road, so there is no vertical
  // plane to continue.
  Street street = StreetWithLidarFrom(80);
  EXPECT_EQ(ExtendFacades(street.views, {true, false}, street.grounds, &street.measured), 0);
}

TEST(FacadeDepth, APartnersEgoBodyIsNoEvidence) {
  // The second view's right half is its ego body (say a glossy hood that
  // mirrors the front): columns of the first view whose plane points land
  // there have no other view to check them and stay unknown; the others
  // are continued as without a mask.
  Street street = StreetWithLidarFrom(50);
  ContextView& partner = street.views[1];
  partner.ego.assign(static_cast<size_t>(partner.width()) * partner.height(), 0);
  for (int y = 0; y < partner.height(); ++y)
    for (int x = 80; x < partner.width(); ++x) partner.ego[y * partner.width() + x] = 1;
  std::vector<ImageF> extended = street.measured;
  ExtendFacades(street.views, {true, false}, street.grounds, &extended);
  for (int y = 25; y < 50; ++y) {
    // Partner columns x + 16.7 +- 1 (the patch) reach the body from x = 62.
    for (int x = 2; x < 55; ++x)
      EXPECT_NEAR(extended[0].at(x, y), TrueDepth(street.views[0], x, y), 0.05) << x << "," << y;
    for (int x = 66; x < 160; ++x) EXPECT_EQ(extended[0].at(x, y), 0.f) << x << "," << y;
  }
}

TEST(UpwardDepth, ContinuesTheDepthBelowUpTheFrontAndLeavesTheSky) {
  // Depth below row 50: the front's depth (12 m) continued up its columns
  // to the roof line (row 22.5) where the other view matches it there
  // clearly better than at the far point (a few bricks that it happens to
  // match as well at the far point stay unknown); the sky above matches the
  // far point as well and stays unknown.
  const Street street = StreetWithLidarFrom(50);
  std::vector<ImageF> extended = street.measured;
  const int64_t set = ExtendUpward(street.views, {true, false}, &extended);
  int64_t on_front = 0, changed = 0;
  for (int y = 0; y < 120; ++y) {
    for (int x = 0; x < 160; ++x) {
      const float d = extended[0].at(x, y);
      if (d == street.measured[0].at(x, y)) continue;
      ++changed;
      // The 3x3 patches of the sky's first rows above the roof line hold
      // bricks: the front may fatten up by them, no further.
      if (y >= 24) EXPECT_NEAR(d, TrueDepth(street.views[0], x, y), 0.05) << x << "," << y;
      EXPECT_GE(y, 20) << x;
      on_front += x >= 2 && x < 140 && y >= 25 && y < 50;
    }
  }
  EXPECT_EQ(set, changed);
  EXPECT_GE(on_front, int64_t(0.95 * 138 * 25));
  EXPECT_EQ(extended[1].pixels, street.measured[1].pixels);
  // Without a second view to check against, nothing is set.
  std::vector<ImageF> alone = {street.measured[0]};
  EXPECT_EQ(ExtendUpward({street.views[0]}, {true}, &alone), 0);
}

TEST(UpwardDepth, ADepthThatTheOtherViewsDoNotMatchIsNotTaken) {
  // Depth below row 80 only: the road's (about 7.3 m at row 80). Continued
  // up, it puts the front's bricks (12 m) where the other view sees other
  // bricks or the sky: a few pixels pass by chance (random bricks), under
  // 4 % of the 80 rows above, where the right depth gives 95 %.
  Street street = StreetWithLidarFrom(80);
  std::vector<ImageF> extended = street.measured;
  const int64_t set = ExtendUpward(street.views, {true, false}, &extended);
  EXPECT_LE(set, int64_t(0.04 * 160 * 80));
}

}  // namespace
}  // namespace pf
