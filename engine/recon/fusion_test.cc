// Tests of analytic fusion: the consistent view wins, masks and occlusion
// exclude views, lifespans, instances re-posed to each view's time.
#include "engine/recon/fusion.h"

#include <gtest/gtest.h>

#include <cmath>

#include "engine/recon/fusion_test_util.h"

namespace pf {
namespace {

constexpr int kW = 16, kH = 12;

// A view from the origin along +z with a constant colour and depth.
struct FlatView {
  ContextView view;
  ViewDepth depth;
  std::vector<uint8_t> mask;

  FlatView(float r, float g, float b, float d, int64_t t = 0) {
    view.camera = CameraModel(kW, kH, 10, 10, 8, 6);
    view.timestamp_us = t;
    view.rgb = ImageF(kW, kH, 3);
    for (int y = 0; y < kH; ++y)
      for (int x = 0; x < kW; ++x) {
        view.rgb.at(x, y, 0) = r;
        view.rgb.at(x, y, 1) = g;
        view.rgb.at(x, y, 2) = b;
      }
    depth.width = kW;
    depth.height = kH;
    depth.depth.assign(kW * kH, d);
    depth.source.assign(kW * kH, 0);
    mask.assign(kW * kH, 0);
  }
  FusionView fusion() const { return {&view, &depth, &mask}; }
};

// One static query at (0, 0, 10) seen from view 0 (pixel (8, 6)).
QuerySet OneQuery(uint32_t owner = 0) { return testing::OneQueryTenMetresAhead(owner); }

TEST(Fusion, WeightsPreferTheConsistentView) {
  const FlatView source(1, 0, 0, 10);     // d = 0
  const FlatView close(0, 1, 0, 10.05f);  // |d| = 0.005
  const FlatView off(0, 0, 1, 10.25f);    // |d| = 0.025, still within tolerance
  const FlatView occluder(1, 1, 1, 5);    // Something in front: not an observation.
  const std::vector<FusionView> views = {source.fusion(), close.fusion(), off.fusion(),
                                         occluder.fusion()};
  FusionOptions options;  // tau = 0.01
  const FusedQueries f = FuseQueries(OneQuery(), views, {}, options);
  // Relative d is (z - D) / z with z = 10.
  const double w1 = std::exp(-0.005 / 0.01), w2 = std::exp(-0.025 / 0.01);
  const double sum = 1 + w1 + w2;
  EXPECT_NEAR(f.rgb[0], 1 / sum, 1e-5);
  EXPECT_NEAR(f.rgb[1], w1 / sum, 1e-5);
  EXPECT_NEAR(f.rgb[2], w2 / sum, 1e-5);
  EXPECT_GT(f.rgb[1], f.rgb[2]);  // The more consistent view weighs more.
  EXPECT_EQ(f.observations[0], 3);
  EXPECT_FLOAT_EQ(f.agreement[0], 1.f);
  EXPECT_TRUE(std::isinf(f.lifespans[0]));  // Nothing contradicts it.

  options.weights = FusionWeights::kPlainAverage;
  const FusedQueries plain = FuseQueries(OneQuery(), views, {}, options);
  EXPECT_NEAR(plain.rgb[0], 1.0 / 3, 1e-5);
  EXPECT_NEAR(plain.rgb[2], 1.0 / 3, 1e-5);

  options.weights = FusionWeights::kNoDepth;  // The occluder's white leaks in.
  const FusedQueries blind = FuseQueries(OneQuery(), views, {}, options);
  EXPECT_NEAR(blind.rgb[0], 2.0 / 4, 1e-5);
  EXPECT_NEAR(blind.rgb[1], 2.0 / 4, 1e-5);
}

TEST(Fusion, AViewWhoseCameraPlaneHoldsTheQueryDoesNotSeeIt) {
  // View 1 looks along +z from 1 km to the side, 2e-6 m behind the query's
  // depth: the query projects to u = 10 * 1000 / 2e-6 = 5e9 px, beyond int's
  // range. It sees nothing (no cast: the sanitizer tree would abort on one);
  // view 2, from the side 1 m away, still observes it.
  const FlatView source(1, 0, 0, 10);
  FlatView grazing(0, 1, 0, 10);
  grazing.view.world_from_camera.translation = {-1000, 0, 10 - 2e-6};
  FlatView beside(0, 0, 1, 10);
  beside.view.world_from_camera.translation = {-0.1, 0, 0};
  const FusedQueries f = FuseQueries(
      OneQuery(), {source.fusion(), grazing.fusion(), beside.fusion()}, {}, FusionOptions{});
  EXPECT_EQ(f.observations[0], 2);
  EXPECT_GT(f.rgb[0], 0.1f);
  EXPECT_FLOAT_EQ(f.rgb[1], 0.f);
  EXPECT_GT(f.rgb[2], 0.1f);
}

TEST(Fusion, StaticQueriesIgnoreMaskedPixels) {
  const FlatView source(1, 0, 0, 10);
  FlatView masked(0, 1, 0, 10);
  masked.mask.assign(kW * kH, 1);
  const FusedQueries f = FuseQueries(OneQuery(), {source.fusion(), masked.fusion()}, {}, {});
  EXPECT_NEAR(f.rgb[0], 1.f, 1e-6);
  EXPECT_NEAR(f.rgb[1], 0.f, 1e-6);
  EXPECT_EQ(f.observations[0], 1);
}

// The ego vehicle's body hides every query, static or on an instance,
// under every weighting (ContextView::ego).
TEST(Fusion, NoQueryIsSeenThroughTheEgoBody) {
  const FlatView source(1, 0, 0, 10);
  FlatView hood(0, 1, 0, 10);
  hood.view.ego.assign(kW * kH, 0);
  hood.view.ego[6 * kW + 8] = 1;  // The pixel the query projects to.
  InstanceTrack car;              // Standing still.
  car.boxes = {{0, {0, 0, 10}, {2, 2, 2}, Quat{}}};
  for (FusionWeights weights :
       {FusionWeights::kDepthSoftmax, FusionWeights::kPlainAverage, FusionWeights::kNoDepth}) {
    FusionOptions options;
    options.weights = weights;
    const FusedQueries f =
        FuseQueries(OneQuery(/*owner=*/1), {source.fusion(), hood.fusion()}, {car}, options);
    EXPECT_NEAR(f.rgb[0], 1.f, 1e-6) << int(weights);
    EXPECT_NEAR(f.rgb[1], 0.f, 1e-6) << int(weights);
    EXPECT_EQ(f.observations[0], 1) << int(weights);
  }
  // The neighbouring pixel is not the body: the view observes again.
  hood.view.ego.assign(kW * kH, 0);
  hood.view.ego[6 * kW + 9] = 1;
  EXPECT_EQ(FuseQueries(OneQuery(), {source.fusion(), hood.fusion()}, {}, {}).observations[0], 2);
}

// The colour is sampled bilinearly: the query lands at pixel (8.0, 6.0),
// between pixels 7 and 8 in x and 5 and 6 in y. Column 7 of the second view
// is the ego body, painted magenta: it gets no weight, and the view gives
// the colour of column 8 (green), not a blend.
TEST(Fusion, TheEgoBodyGivesNoColourToABilinearSample) {
  const FlatView source(1, 0, 0, 10);
  FlatView hood(0, 1, 0, 10);
  hood.view.ego.assign(kW * kH, 0);
  for (int y = 0; y < kH; ++y) {
    hood.view.ego[y * kW + 7] = 1;
    hood.view.rgb.at(7, y, 0) = hood.view.rgb.at(7, y, 2) = 1;
    hood.view.rgb.at(7, y, 1) = 0;
  }
  FusionOptions options;
  options.weights = FusionWeights::kPlainAverage;
  const FusedQueries f = FuseQueries(OneQuery(), {source.fusion(), hood.fusion()}, {}, options);
  EXPECT_EQ(f.observations[0], 2);
  EXPECT_NEAR(f.rgb[0], 0.5, 1e-6);  // Red from the source, green from the hood view.
  EXPECT_NEAR(f.rgb[1], 0.5, 1e-6);
  EXPECT_NEAR(f.rgb[2], 0.0, 1e-6);  // No magenta.
}

// A view that sees 10 m past the query contradicts it, unless the ego body
// is in the 3x3 neighbourhood of its pixel: the body hides what is beyond.
TEST(Fusion, TheEgoBodyNextToThePixelSeesNothingPast) {
  const FlatView source(1, 0, 0, 10);
  FlatView through(0, 0, 1, 20);
  EXPECT_NEAR(FuseQueries(OneQuery(), {source.fusion(), through.fusion()}, {}, {}).agreement[0],
              0.5f, 1e-6);
  through.view.ego.assign(kW * kH, 0);
  through.view.ego[7 * kW + 9] = 1;  // Diagonal neighbour of pixel (8, 6).
  EXPECT_NEAR(FuseQueries(OneQuery(), {source.fusion(), through.fusion()}, {}, {}).agreement[0],
              1.f, 1e-6);
}

TEST(Fusion, SeeingPastAPointShortensItsLifespan) {
  const FlatView source(1, 0, 0, 10, 0);
  const FlatView later_same(1, 0, 0, 10, 300000);
  const FlatView through(0, 0, 1, 20, 1000000);  // At 1 s the view sees 10 m further.
  const std::vector<FusionView> views = {source.fusion(), later_same.fusion(), through.fusion()};
  FusionOptions lifespan;
  lifespan.lifespan = true;
  const FusedQueries f = FuseQueries(OneQuery(), views, {}, lifespan);
  EXPECT_NEAR(f.lifespans[0], 0.3f, 1e-6);  // Seen 0.3 s away from its own time.
  EXPECT_NEAR(f.agreement[0], 2.f / 3, 1e-6);
  // Off by default: the same contradiction, no fading.
  const FusedQueries by_default = FuseQueries(OneQuery(), views, {}, {});
  EXPECT_TRUE(std::isinf(by_default.lifespans[0]));
  EXPECT_NEAR(by_default.agreement[0], 2.f / 3, 1e-6);
}

TEST(Fusion, InstanceQueriesAreReposedToEachViewsTime) {
  // The car's box moves 1 m along +x between t = 0 and t = 1 s. A canonical
  // point at (0, 0, 10) is at (1, 0, 10) at t = 1 s: pixel u = 8 + 10 * 0.1
  // = 9, where the later view is green; its pixels x < 8 are blue (had the
  // point not moved, u = 8 would mix blue and green).
  InstanceTrack car;
  car.boxes = {{0, {0, 0, 10}, {2, 2, 2}, Quat{}}, {1000000, {1, 0, 10}, {2, 2, 2}, Quat{}}};
  const FlatView source(1, 0, 0, 10, 0);
  FlatView later(0, 1, 0, 10, 1000000);
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < 8; ++x) {
      later.view.rgb.at(x, y, 1) = 0;
      later.view.rgb.at(x, y, 2) = 1;
    }
  later.mask.assign(kW * kH, 1);  // Masks do not apply to instance queries.
  const FusedQueries f =
      FuseQueries(OneQuery(/*owner=*/1), {source.fusion(), later.fusion()}, {car}, {});
  EXPECT_EQ(f.observations[0], 2);
  EXPECT_NEAR(f.rgb[0], 0.5, 1e-5);
  EXPECT_NEAR(f.rgb[1], 0.5, 1e-5);
  EXPECT_NEAR(f.rgb[2], 0.0, 1e-5);
  EXPECT_TRUE(std::isinf(f.lifespans[0]));
}

TEST(Fusion, UnfusedKeepsOwnColour) {
  QuerySet q = OneQuery();
  q.rgb = {0.25f, 0.5f, 0.75f};
  const FusedQueries f = UnfusedQueries(q);
  EXPECT_EQ(f.rgb, q.rgb);
  EXPECT_EQ(f.observations, std::vector<uint16_t>{1});
  EXPECT_FLOAT_EQ(f.agreement[0], 1.f);
  EXPECT_TRUE(std::isinf(f.lifespans[0]));
}

}  // namespace
}  // namespace pf
