// Tests of the plane sweep over the context views' unknown pixels.
#include "engine/recon/stereo_depth.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "engine/recon/street_test_util.h"

namespace pf {
namespace {

// A street seen from the side: a building front x = 20 up to 8 m, a round
// pillar of radius 1 m at (10, 0) up to 10 m in front of it, the road
// z = 0 and a smooth sky. Front and pillar are 0.25 m cells of random
// grey, so views agree only at the right depth.
constexpr double kFrontX = 20, kFrontTop = 8, kPillarX = 10, kPillarR = 1, kPillarTop = 10;

double SweptCellGrey(int a, int b, int c) { return 0.1 + 0.8 * testing::HashedCell(a, b, c); }

enum Surface { kSky, kPillar, kWall, kRoad };

// Distance along `d` from `o` to the scene, its grey and what it hit; < 0:
// the sky.
double Trace(const Vec3& o, const Vec3& d, double* grey, Surface* surface = nullptr) {
  Surface hit = kSky;
  double best = -1;
  // The pillar: |(p.x, p.y) - (kPillarX, 0)| = kPillarR.
  const double ox = o.x - kPillarX, oy = o.y;
  const double a = d.x * d.x + d.y * d.y, b = 2 * (ox * d.x + oy * d.y),
               c = ox * ox + oy * oy - kPillarR * kPillarR;
  const double disc = b * b - 4 * a * c;
  if (a > 0 && disc >= 0) {
    const double s = (-b - std::sqrt(disc)) / (2 * a);
    const Vec3 p = o + s * d;
    if (s > 0 && p.z >= 0 && p.z <= kPillarTop) {
      best = s;
      hit = kPillar;
      const double angle = std::atan2(p.y, p.x - kPillarX);
      *grey = SweptCellGrey(static_cast<int>(std::floor(angle * kPillarR / 0.25)),
                            static_cast<int>(std::floor(p.z / 0.25)), 1);
    }
  }
  if (d.x > 0) {
    const double s = (kFrontX - o.x) / d.x;
    const Vec3 p = o + s * d;
    if (p.z >= 0 && p.z <= kFrontTop && (best < 0 || s < best)) {
      best = s;
      hit = kWall;
      *grey = SweptCellGrey(static_cast<int>(std::floor(p.y / 0.25)),
                            static_cast<int>(std::floor(p.z / 0.25)), 2);
    }
  }
  if (d.z < 0) {
    const double s = -o.z / d.z;
    if (best < 0 || s < best) {
      best = s;
      hit = kRoad;
      *grey = 0.3;  // Flat: nothing to match.
    }
  }
  if (best < 0) *grey = 0.6 + 0.2 * d.z / Norm(d);  // Sky: smooth.
  if (surface != nullptr) *surface = hit;
  return best;
}

constexpr int kSweptWidth = 320, kSweptHeight = 240;

// A camera at `position` looking along +x.
ContextView SweptStreetView(const std::string& camera_id, const Vec3& position) {
  ContextView view;
  view.camera_id = camera_id;
  view.camera = CameraModel(kSweptWidth, kSweptHeight, 200, 200, 160, 120);
  view.world_from_camera.rotation = Mat3::FromColumns({0, -1, 0}, {0, 0, -1}, {1, 0, 0});
  view.world_from_camera.translation = position;
  view.rgb = ImageF(kSweptWidth, kSweptHeight, 3);
  for (int y = 0; y < kSweptHeight; ++y) {
    for (int x = 0; x < kSweptWidth; ++x) {
      Vec3 ray;
      view.camera.Unproject(x + 0.5, y + 0.5, &ray);
      double grey = 0;
      Trace(position, view.world_from_camera.rotation * ray, &grey);
      for (int k = 0; k < 3; ++k) view.rgb.at(x, y, k) = static_cast<float>(grey);
    }
  }
  return view;
}

// The z depth of pixel (x, y) of `view` (0 for the sky) and its surface.
double SweptTrueDepth(const ContextView& view, int x, int y, Surface* surface = nullptr) {
  Vec3 ray;
  view.camera.Unproject(x + 0.5, y + 0.5, &ray);  // z = 1: distance along it is z depth.
  double grey;
  const double s = Trace(view.world_from_camera.translation, view.world_from_camera.rotation * ray,
                         &grey, surface);
  return s > 0 ? s : 0;
}

// Whether a pixel within `radius` of (x, y) is on the pillar or the front.
bool NearTexture(const ContextView& view, int x, int y, int radius) {
  for (int dy = -radius; dy <= radius; ++dy) {
    for (int dx = -radius; dx <= radius; ++dx) {
      Surface surface;
      SweptTrueDepth(view, std::clamp(x + dx, 0, kSweptWidth - 1),
                     std::clamp(y + dy, 0, kSweptHeight - 1), &surface);
      if (surface == kPillar || surface == kWall) return true;
    }
  }
  return false;
}

// Three views 1 m apart along the street; the middle one is swept.
std::vector<ContextView> SweptStreet() {
  return {SweptStreetView("cam", {0, 1, 1.5}), SweptStreetView("cam", {0, 0, 1.5}),
          SweptStreetView("cam", {0, -1, 1.5})};
}

std::vector<ImageF> UnknownDepths(size_t count) {
  return std::vector<ImageF>(count, ImageF(kSweptWidth, kSweptHeight, 1));
}

TEST(StereoDepth, FindsThePillarAndTheFrontAndLeavesTheSky) {
  const std::vector<ContextView> views = SweptStreet();
  std::vector<ImageF> measured = UnknownDepths(3);
  // The road below row 160 is measured (as a LiDAR would) and must be kept.
  for (int y = 160; y < kSweptHeight; ++y)
    for (int x = 0; x < kSweptWidth; ++x)
      measured[1].at(x, y) = static_cast<float>(SweptTrueDepth(views[1], x, y));
  const ImageF before = measured[1];

  const StereoStats stats = ExtendByStereo(views, {false, true, false}, &measured);
  int64_t count[4] = {0, 0, 0, 0}, found[4] = {0, 0, 0, 0}, set = 0;
  std::vector<double> errors;
  for (int y = 0; y < 160; ++y) {
    for (int x = 0; x < kSweptWidth; ++x) {
      Surface surface;
      const double truth = SweptTrueDepth(views[1], x, y, &surface);
      const float d = measured[1].at(x, y);
      ++count[surface];
      if (d <= 0.f) continue;
      ++set;
      ++found[surface];
      if (surface == kSky || surface == kRoad) {
        // Window stereo fattens the textured side of an edge: a flat pixel
        // whose patch holds the edge takes its depth; no flat pixel further
        // away gets one.
        EXPECT_TRUE(NearTexture(views[1], x, y, StereoOptions().window_radius)) << x << "," << y;
      } else {
        errors.push_back(std::abs(d - truth) / truth);
      }
    }
  }
  EXPECT_EQ(stats.pixels, set);
  EXPECT_EQ(stats.views, 1);
  EXPECT_GT(stats.mean_ncc, 0.7);
  // Most of the textured surfaces get a depth, and the right one.
  EXPECT_GT(found[kPillar], 0.8 * count[kPillar]) << found[kPillar] << " of " << count[kPillar];
  EXPECT_GT(found[kWall], 0.8 * count[kWall]) << found[kWall] << " of " << count[kWall];
  std::sort(errors.begin(), errors.end());
  ASSERT_FALSE(errors.empty());
  EXPECT_LT(errors[errors.size() / 2], 0.02);       // Median relative error.
  EXPECT_LT(errors[errors.size() * 9 / 10], 0.06);  // 90th percentile (patch edges).
  // The smooth sky has no texture to match: most of it stays for the far
  // layer.
  EXPECT_LT(found[kSky], count[kSky] / 10) << found[kSky] << " of " << count[kSky];
  // Measured pixels are kept; views not asked are untouched.
  for (int y = 160; y < kSweptHeight; ++y)
    for (int x = 0; x < kSweptWidth; ++x) EXPECT_EQ(measured[1].at(x, y), before.at(x, y));
  for (size_t v : {0u, 2u})
    EXPECT_TRUE(std::all_of(measured[v].pixels.begin(), measured[v].pixels.end(),
                            [](float d) { return d == 0.f; }));
}

TEST(StereoDepth, NeedsAViewFarEnoughAwayToCheck) {
  // The same camera 0.1 m away: under min_baseline, nothing to check with.
  const std::vector<ContextView> views = {SweptStreetView("cam", {0, 0.1, 1.5}),
                                          SweptStreetView("cam", {0, 0, 1.5})};
  std::vector<ImageF> measured = UnknownDepths(2);
  const StereoStats stats = ExtendByStereo(views, {false, true}, &measured);
  EXPECT_EQ(stats.pixels, 0);
  EXPECT_EQ(stats.views, 0);
}

TEST(StereoDepth, EgoPixelsAreNeitherSetNorEvidence) {
  std::vector<ContextView> views = SweptStreet();
  // The swept view's left third is its ego body.
  auto mask = [](ContextView* view, int x0, int x1) {
    view->ego.assign(static_cast<size_t>(kSweptWidth) * kSweptHeight, 0);
    for (int y = 0; y < kSweptHeight; ++y)
      for (int x = x0; x < x1; ++x) view->ego[static_cast<size_t>(y) * kSweptWidth + x] = 1;
  };
  mask(&views[1], 0, kSweptWidth / 3);
  std::vector<ImageF> measured = UnknownDepths(3);
  ExtendByStereo(views, {false, true, false}, &measured);
  int64_t right_set = 0;
  for (int y = 0; y < kSweptHeight; ++y) {
    for (int x = 0; x < kSweptWidth; ++x) {
      if (x < kSweptWidth / 3) EXPECT_EQ(measured[1].at(x, y), 0.f) << x << "," << y;
      right_set += measured[1].at(x, y) > 0.f;
    }
  }
  EXPECT_GT(right_set, 0);

  // Both partners masked entirely: no evidence anywhere.
  mask(&views[0], 0, kSweptWidth);
  mask(&views[2], 0, kSweptWidth);
  std::vector<ImageF> none = UnknownDepths(3);
  EXPECT_EQ(ExtendByStereo(views, {false, true, false}, &none).pixels, 0);
}

}  // namespace
}  // namespace pf
