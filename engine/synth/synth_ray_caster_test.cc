// Tests of the ground-truth ray caster against hand-computed geometry.
#include "engine/synth/synth_ray_caster.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace pf {
namespace {

SynthScene SmallScene(uint64_t seed = 1, int width = 192, int height = 144) {
  SynthOptions options;
  options.seed = seed;
  options.width = width;
  options.height = height;
  auto scene = GenerateSynthScene(options);
  EXPECT_TRUE(scene.ok()) << scene.status();
  return *scene;
}

RenderedView Render(const SynthScene& scene, int camera, double t, int antialias = 2,
                    const VehicleEdits& edits = {}) {
  const SceneSnapshot snapshot = SnapshotAt(scene, t, edits);
  return RenderView(snapshot, scene.cameras[camera].model, scene.WorldFromCamera(camera, t),
                    antialias);
}

// World direction (not normalised, camera z component 1) through pixel
// centre (x, y).
Vec3 PixelRay(const SynthScene& scene, int camera, double t, int x, int y) {
  Vec3 ray;
  EXPECT_TRUE(scene.cameras[camera].model.Unproject(x + 0.5, y + 0.5, &ray));
  return scene.WorldFromCamera(camera, t).rotation * ray;
}

TEST(SynthRayCaster, RoadPixelDepthIsTheRayPlaneIntersection) {
  const SynthScene scene = SmallScene();
  const int cam = 1, w = 192, h = 144;
  const RenderedView view = Render(scene, cam, 0.0);
  const Vec3 origin = scene.WorldFromCamera(cam, 0.0).translation;
  for (const auto& [x, y] : std::vector<std::pair<int, int>>{{96, 143}, {20, 140}, {170, 130}}) {
    // The camera-space ray has z = 1, so the ray parameter at the ground is
    // the depth along the optical axis.
    const Vec3 dir = PixelRay(scene, cam, 0.0, x, y);
    ASSERT_LT(dir.z, 0);
    const double s = -origin.z / dir.z;
    const Vec3 ground = origin + dir * s;
    ASSERT_LT(std::abs(ground.y), scene.road.half_width) << "pixel not on the road";
    EXPECT_NEAR(view.depth.at(x, y), s, 1e-4 * s) << x << "," << y;
    EXPECT_EQ(view.instance[y * w + x], 0);
  }
  EXPECT_EQ(view.depth.width, w);
  EXPECT_EQ(view.depth.height, h);
}

// Every pixel of a scene reduced to the ground and one building matches the
// analytic nearest intersection with the ground plane, the building's facade
// (y = 12) and its end wall (x = 5).
TEST(SynthRayCaster, FacadeDepthMatchesAnalyticScene) {
  SynthScene scene = SmallScene();
  StaticBox building;
  building.lo = {5, 12, 0};
  building.hi = {40, 25, 15};
  building.kind = StaticKind::kBuilding;
  scene.boxes = {building};
  scene.vehicles.clear();
  const int cam = 0;  // Looks forward-left at the building.
  const RenderedView view = Render(scene, cam, 0.0);
  const Vec3 o = scene.WorldFromCamera(cam, 0.0).translation;
  int facade_pixels = 0, ground_pixels = 0, sky_pixels = 0;
  for (int y = 0; y < 144; ++y) {
    for (int x = 0; x < 192; ++x) {
      const Vec3 d = PixelRay(scene, cam, 0.0, x, y);
      double expected = std::numeric_limits<double>::infinity();
      bool on_facade = false;
      if (d.z < 0) expected = -o.z / d.z;
      if (d.y > 0) {
        const double s = (12 - o.y) / d.y;
        const Vec3 p = o + d * s;
        if (p.x >= 5 && p.x <= 40 && p.z >= 0 && p.z <= 15 && s < expected) {
          expected = s;
          on_facade = true;
        }
      }
      if (d.x > 0) {
        const double s = (5 - o.x) / d.x;
        const Vec3 p = o + d * s;
        if (p.y >= 12 && p.y <= 25 && p.z >= 0 && p.z <= 15 && s < expected) {
          expected = s;
          on_facade = true;
        }
      }
      const float depth = view.depth.at(x, y);
      if (std::isinf(expected)) {
        EXPECT_EQ(depth, 0.f) << x << "," << y;
        ++sky_pixels;
        continue;
      }
      ASSERT_NEAR(depth, expected, 1e-4 * expected) << x << "," << y;
      (on_facade ? facade_pixels : ground_pixels)++;
    }
  }
  EXPECT_GT(facade_pixels, 1000);
  EXPECT_GT(ground_pixels, 1000);
  EXPECT_GT(sky_pixels, 100);
}

TEST(SynthRayCaster, ImagesAreDeterministicAndDependOnTheSeed) {
  const SynthScene a = SmallScene(4), b = SmallScene(4), c = SmallScene(5);
  const RenderedView va = Render(a, 1, 0.5), vb = Render(b, 1, 0.5), vc = Render(c, 1, 0.5);
  EXPECT_EQ(va.rgb.pixels, vb.rgb.pixels);
  EXPECT_EQ(va.depth.pixels, vb.depth.pixels);
  EXPECT_EQ(va.instance, vb.instance);
  double diff = 0;
  for (size_t i = 0; i < va.rgb.pixels.size(); ++i)
    diff += std::abs(va.rgb.pixels[i] - vc.rgb.pixels[i]);
  EXPECT_GT(diff / va.rgb.pixels.size(), 0.02);
}

TEST(SynthRayCaster, ImagesCarryHighFrequencyDetail) {
  const SynthScene scene = SmallScene(2, 384, 288);
  const RenderedView view = Render(scene, 0, 0.0);
  // Mean absolute horizontal gradient of luminance: a blurred image would
  // lose most of it.
  double gradient = 0;
  int count = 0;
  for (int y = 0; y < 288; ++y) {
    for (int x = 1; x < 384; ++x) {
      const float a = view.rgb.at(x, y, 1), b = view.rgb.at(x - 1, y, 1);
      gradient += std::abs(a - b);
      ++count;
    }
  }
  EXPECT_GT(gradient / count, 0.02);
  float lo = 1, hi = 0;
  for (float v : view.rgb.pixels) {
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  EXPECT_LT(lo, 0.1f);
  EXPECT_GT(hi, 0.85f);
}

// Tile culling must not change anything: compare with casting every pixel
// centre against all primitives, through pinhole lenses and through f-theta
// ones (120 degrees across, whose frustum edges bend).
TEST(SynthRayCaster, CulledRenderMatchesBruteForce) {
  SynthScene scene = SmallScene(3, 80, 60);
  for (int cam = 0; cam < 6; ++cam) {
    if (cam == 3) {
      for (RigCamera& rig : scene.cameras) rig.model.SetFTheta(SynthFThetaPolynomial(80));
    }
    SCOPED_TRACE(cam < 3 ? "pinhole" : "f-theta");
    const double t = 1.2;
    const SceneSnapshot snapshot = SnapshotAt(scene, t);
    const Rigid pose = scene.WorldFromCamera(cam % 3, t);
    const RenderedView view = RenderView(snapshot, scene.cameras[cam % 3].model, pose, 1);
    for (int y = 0; y < 60; ++y) {
      for (int x = 0; x < 80; ++x) {
        const Vec3 dir = Normalized(PixelRay(scene, cam % 3, t, x, y));
        const RayHit hit = CastRay(snapshot, pose.translation, dir);
        const double depth = hit.hit ? Dot(hit.point - pose.translation, pose.rotation.Col(2)) : 0;
        ASSERT_NEAR(view.depth.at(x, y), depth, 1e-4 * (1 + depth)) << cam << ":" << x << "," << y;
        ASSERT_EQ(view.instance[y * 80 + x], hit.instance);
        const Vec3 colour = RayColour(hit, dir);
        ASSERT_NEAR(view.rgb.at(x, y, 0), colour.x, 1e-6);
      }
    }
  }
}

// Colour is the mean of a regular n x n grid of sub-pixel rays; depth and
// instance come from the pixel-centre ray.
TEST(SynthRayCaster, ColourIsTheMeanOfStratifiedSubsamples) {
  const SynthScene scene = SmallScene(6, 64, 48);
  const double t = 0.3;
  const SceneSnapshot snapshot = SnapshotAt(scene, t);
  const Rigid pose = scene.WorldFromCamera(1, t);
  const CameraModel& camera = scene.cameras[1].model;
  for (int n : {2, 3}) {
    const RenderedView view = RenderView(snapshot, camera, pose, n);
    for (const auto& [x, y] :
         std::vector<std::pair<int, int>>{{5, 5}, {32, 20}, {60, 40}, {10, 30}}) {
      Vec3 sum;
      for (int j = 0; j < n; ++j) {
        for (int i = 0; i < n; ++i) {
          Vec3 ray;
          ASSERT_TRUE(camera.Unproject(x + (i + 0.5) / n, y + (j + 0.5) / n, &ray));
          const Vec3 dir = Normalized(pose.rotation * ray);
          sum = sum + RayColour(CastRay(snapshot, pose.translation, dir), dir);
        }
      }
      for (int c = 0; c < 3; ++c) {
        EXPECT_NEAR(view.rgb.at(x, y, c), sum[c] / (n * n), 1e-6) << n << ": " << x << "," << y;
      }
    }
  }
}

// Every pixel of vehicle k lies in the bounding rectangle of vehicle k's box
// corners projected into the image, and every vehicle shows up somewhere.
TEST(SynthRayCaster, VehiclePixelsLieInsideTheirProjectedBoxes) {
  const SynthScene scene = SmallScene(1);
  const int w = 192, h = 144;
  std::vector<int> seen(scene.vehicles.size() + 1, 0);
  for (int64_t t_us : scene.FrameTimestampsUs()) {
    const double t = t_us * 1e-6;
    for (int cam = 0; cam < 3; ++cam) {
      const RenderedView view = Render(scene, cam, t, 1);
      const Rigid camera_from_world = scene.WorldFromCamera(cam, t).Inverse();
      for (const Vehicle& v : scene.vehicles) {
        const Rigid box = v.BoxToWorldAt(t);
        double u_lo = 1e30, u_hi = -1e30, v_lo = 1e30, v_hi = -1e30;
        bool all_in_front = true;
        for (int corner = 0; corner < 8; ++corner) {
          const Vec3 local{(corner & 1 ? 0.5 : -0.5) * v.size.x,
                           (corner & 2 ? 0.5 : -0.5) * v.size.y,
                           (corner & 4 ? 0.5 : -0.5) * v.size.z};
          double u, vv;
          if (!scene.cameras[cam].model.Project(camera_from_world * (box * local), &u, &vv)) {
            all_in_front = false;
            break;
          }
          u_lo = std::min(u_lo, u);
          u_hi = std::max(u_hi, u);
          v_lo = std::min(v_lo, vv);
          v_hi = std::max(v_hi, vv);
        }
        int pixels = 0;
        for (int y = 0; y < h; ++y) {
          for (int x = 0; x < w; ++x) {
            if (view.instance[y * w + x] != v.instance_id) continue;
            ++pixels;
            if (!all_in_front) continue;
            ASSERT_GE(x + 0.5, u_lo - 1) << v.id << " cam " << cam << " t " << t;
            ASSERT_LE(x + 0.5, u_hi + 1) << v.id << " cam " << cam << " t " << t;
            ASSERT_GE(y + 0.5, v_lo - 1) << v.id << " cam " << cam << " t " << t;
            ASSERT_LE(y + 0.5, v_hi + 1) << v.id << " cam " << cam << " t " << t;
          }
        }
        seen[v.instance_id] += pixels;
      }
    }
  }
  for (const Vehicle& v : scene.vehicles) EXPECT_GT(seen[v.instance_id], 20) << v.id;
}

TEST(SynthRayCaster, RemovedVehicleDoesNotAppear) {
  const SynthScene scene = SmallScene(1);
  const RenderedView before = Render(scene, 1, 0.0);
  const int ahead = scene.vehicles[0].instance_id;
  const auto count = [&](const RenderedView& view) {
    return std::count(view.instance.begin(), view.instance.end(), ahead);
  };
  ASSERT_GT(count(before), 50);
  VehicleEdits edits;
  edits.removed.insert(ahead);
  const RenderedView after = Render(scene, 1, 0.0, 2, edits);
  EXPECT_EQ(count(after), 0);
  // What was behind the vehicle is farther away.
  for (size_t i = 0; i < before.instance.size(); ++i) {
    if (before.instance[i] != ahead) continue;
    const float d = after.depth.pixels[i];
    EXPECT_TRUE(d == 0.f || d > before.depth.pixels[i]);
  }
}

TEST(SynthRayCaster, TrajectoryEditMovesTheVehicle) {
  const SynthScene scene = SmallScene(1);
  const Vehicle& vehicle = scene.vehicles[0];
  VehicleEdits edits;
  // Parked across the left lanes, 25 m ahead, turned by 90 degrees.
  const Vec3 centre{25, 3.5, vehicle.size.z / 2};
  const Quat turned{std::cos(0.785398), 0, 0, std::sin(0.785398)};
  edits.trajectories[vehicle.instance_id] = {{0.0, centre, turned}, {2.0, centre, turned}};
  const SceneSnapshot snapshot = SnapshotAt(scene, 0.5, edits);
  ASSERT_EQ(snapshot.vehicles.size(), scene.vehicles.size());
  EXPECT_NEAR(snapshot.vehicles[0].box_to_world.translation.x, 25, 1e-12);
  EXPECT_NEAR(snapshot.vehicles[0].box_to_world.rotation.Col(0).y, 1, 1e-5);
  // A ray from above straight down at the new centre lands on its roof.
  const RayHit hit = CastRay(snapshot, {25, 3.5, 20}, {0, 0, -1});
  EXPECT_EQ(hit.instance, vehicle.instance_id);
  EXPECT_NEAR(hit.point.z, vehicle.size.z, 1e-9);
}

TEST(SynthRayCaster, InterpolatesTracksLinearlyAndBySlerp) {
  const Quat a{1, 0, 0, 0};
  const Quat b{std::cos(0.5), 0, 0, std::sin(0.5)};  // 1 rad about z.
  const std::vector<TrackPose> track = {{1.0, {0, 0, 1}, a}, {3.0, {10, 0, 1}, b}};
  const Rigid mid = InterpolateTrack(track, 2.0);
  EXPECT_NEAR(mid.translation.x, 5, 1e-12);
  EXPECT_NEAR(std::atan2(mid.rotation.m[1][0], mid.rotation.m[0][0]), 0.5, 1e-9);
  EXPECT_NEAR(InterpolateTrack(track, 0.0).translation.x, 0, 1e-12);
  EXPECT_NEAR(InterpolateTrack(track, 9.0).translation.x, 10, 1e-12);
}

TEST(SynthRayCaster, SkyHasNoDepth) {
  const SynthScene scene = SmallScene(1);
  const SceneSnapshot snapshot = SnapshotAt(scene, 0);
  const RayHit hit = CastRay(snapshot, {0, -1.75, 1.5}, Normalized(Vec3{0.2, 0, 1}));
  EXPECT_FALSE(hit.hit);
  EXPECT_EQ(hit.instance, 0);
  const Vec3 sky = RayColour(hit, Normalized(Vec3{0.2, 0, 1}));
  EXPECT_GT(sky.z, sky.x);  // Blue.
}

}  // namespace
}  // namespace pf
