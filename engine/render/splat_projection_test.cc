// Tests of ProjectSplat's early rejections: with and without them, every
// Gaussian projects to the same bits or is rejected by both.
#include "engine/render/splat_projection.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <random>
#include <vector>

#include "engine/camera/camera_model.h"

namespace pf::raster {
namespace {

struct RandomGaussians {
  std::vector<float> means, rotations, log_scales, opacity_logits, times, lifespans;
  SplatArrays Arrays(float low_pass) const {
    return {means.data(), rotations.data(), log_scales.data(), opacity_logits.data(),
            times.data(), lifespans.data(), low_pass};
  }
};

// `count` Gaussians in the camera frame, their means spread to about three
// times the field of view across and from behind the camera to 60 m;
// scales from millimetres to tens of metres, all opacities, a third of them
// fading with time.
RandomGaussians MakeGaussians(size_t count, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> unit(0.f, 1.f);
  std::normal_distribution<float> normal(0.f, 1.f);
  RandomGaussians g;
  for (size_t i = 0; i < count; ++i) {
    const float z = -2.f + 62.f * unit(rng) * unit(rng);
    const float spread = std::max(std::abs(z), 0.5f);
    g.means.insert(g.means.end(),
                   {(4.f * unit(rng) - 2.f) * spread, (3.f * unit(rng) - 1.5f) * spread, z});
    g.rotations.insert(g.rotations.end(), {normal(rng), normal(rng), normal(rng), normal(rng)});
    for (int k = 0; k < 3; ++k) g.log_scales.push_back(-7.f + 10.f * unit(rng));
    g.opacity_logits.push_back(-8.f + 20.f * unit(rng));
    g.times.push_back(-10.f + 24.f * unit(rng));  // Fades from none to far past 1/255.
    g.lifespans.push_back(unit(rng) < 0.33f ? 0.05f + 0.5f * unit(rng)
                                            : std::numeric_limits<float>::infinity());
  }
  return g;
}

TEST(SplatProjection, EarlyRejectionsChangeNoResult) {
  constexpr size_t kCount = 200000;
  const RandomGaussians g = MakeGaussians(kCount, 5);
  CameraModel pinhole(640, 480, 500, 510, 322, 238);
  CameraModel opencv = pinhole;
  opencv.SetOpenCv(-0.2, 0.05, 0.001, -0.002, 0.0);
  CameraModel fisheye(640, 480, 300, 300, 320, 240);
  fisheye.SetFisheye(0.05, -0.01, 0.002, 0.0);
  CameraModel ftheta(640, 480, 300, 300, 320, 240);
  ftheta.SetFTheta({0, 300, 0, -8, 0, 0});
  // A rotated, shifted camera frame (the projection takes r and t).
  const float c = std::cos(0.4f), s = std::sin(0.4f);
  const float r[9] = {c, 0, s, 0, 1, 0, -s, 0, c};
  const float t[3] = {0.3f, -0.2f, 1.5f};
  for (const CameraModel* model : {&pinhole, &opencv, &fisheye, &ftheta}) {
    for (float low_pass : {0.1f, 0.3f}) {
      ProjectionCamera camera;
      SetUpProjectionCamera(*model, 0.01f, 2.f, &camera);
      const SplatArrays arrays = g.Arrays(low_pass);
      size_t visible = 0;
      for (size_t i = 0; i < kCount; ++i) {
        SplatGeometry early{}, exact{};
        const bool seen = ProjectSplat<true>(arrays, i, camera, r, t, &early);
        ASSERT_EQ(seen, ProjectSplat<false>(arrays, i, camera, r, t, &exact))
            << "lens " << static_cast<int>(model->kind()) << ", Gaussian " << i;
        if (!seen) continue;
        ++visible;
        ASSERT_EQ(std::memcmp(&early, &exact, sizeof(early)), 0)
            << "lens " << static_cast<int>(model->kind()) << ", Gaussian " << i;
      }
      // Both outcomes well represented, so the early tests were exercised
      // on either side of their bounds.
      EXPECT_GT(visible, kCount / 50) << "lens " << static_cast<int>(model->kind());
      EXPECT_LT(visible, kCount * 9 / 10) << "lens " << static_cast<int>(model->kind());
    }
  }
}

// Fixed outcomes at the image's left edge, whichever test decides them (the
// test above shows only that the two paths agree): a Gaussian whose ellipse
// ends left of the image is not seen, one that reaches into it is.
TEST(SplatProjection, OffTheEdgeByItsExtentIsRejected) {
  RandomGaussians g;
  // A round Gaussian, sigma 0.1 m, opaque, 10 m ahead at 500 px focal
  // length: its extent about 20 px (3.33 sigma, sigma 6 px across the ray
  // so far off the axis).
  for (float x_px : {-40.f, -30.f, -10.f, 0.f}) {
    const float z = 10.f;
    g.means.insert(g.means.end(), {(x_px - 320.f) / 500.f * z, 0.f, z});
    g.rotations.insert(g.rotations.end(), {1, 0, 0, 0});
    g.log_scales.insert(g.log_scales.end(), 3, std::log(0.1f));
    g.opacity_logits.push_back(10.f);
    g.times.push_back(0.f);
    g.lifespans.push_back(std::numeric_limits<float>::infinity());
  }
  ProjectionCamera camera;
  SetUpProjectionCamera(CameraModel(640, 480, 500, 500, 320, 240), 0.01f, 0.f, &camera);
  const float r[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  const float t[3] = {0, 0, 0};
  const SplatArrays arrays = g.Arrays(0.1f);
  std::vector<bool> seen;
  for (size_t i = 0; i < 4; ++i) {
    SplatGeometry out;
    seen.push_back(ProjectSplat(arrays, i, camera, r, t, &out));
    SplatGeometry exact;
    EXPECT_EQ(seen.back(), ProjectSplat<false>(arrays, i, camera, r, t, &exact));
  }
  EXPECT_EQ(seen, (std::vector<bool>{false, false, true, true}));
}

}  // namespace
}  // namespace pf::raster
