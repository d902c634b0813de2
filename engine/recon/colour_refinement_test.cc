// Tests of the least-squares colour refinement: hand-solved one-pixel
// problems, uncovered pixels left out, and recovery of known colours on a
// scene whose context image was rendered from them.
#include "engine/recon/colour_refinement.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "common/memory_info.h"
#include "engine/recon/gaussian_decoder.h"
#include "engine/render/compositing_weights.h"
#include "engine/render/rasterizer.h"

namespace pf {
namespace {

// Adds a round Gaussian of std-dev `scale` with colour `rgb` (grey if one
// value) to a kReconChannels scene.
void AddGaussian(GaussianScene* scene, const Vec3& mean, double scale, double opacity,
                 const Vec3& rgb) {
  const size_t i = scene->size();
  scene->Resize(i + 1);
  for (int c = 0; c < 3; ++c) {
    scene->means[3 * i + c] = static_cast<float>(mean[c]);
    scene->log_scales[3 * i + c] = static_cast<float>(std::log(scale));
    scene->features[i * kReconChannels + c] = static_cast<float>(rgb[c]);
  }
  scene->features[i * kReconChannels + 6] = 0.25f;  // Not a colour: must stay.
  scene->opacity_logits[i] = LogitOfOpacity(opacity);
}

GaussianScene EmptyScene() {
  GaussianScene scene;
  scene.num_channels = kReconChannels;
  return scene;
}

ContextView UniformView(int width, int height, double f, float value) {
  ContextView view;
  view.camera = CameraModel(width, height, f, f, width / 2.0, height / 2.0);
  view.rgb = ImageF(width, height, 3);
  for (float& v : view.rgb.pixels) v = value;
  return view;
}

TEST(ColourRefinement, HiddenGaussiansKeepTheirColour) {
  // The one-pixel problem below, with the back Gaussian marked hidden
  // (agreement 0): it keeps its decoded colour and the front one alone is
  // fitted, c0 + a0 (I - a . c0) / (a0^2 + l0) per channel. Without
  // keep_hidden it moves like any other.
  for (const bool keep : {true, false}) {
    GaussianScene scene = EmptyScene();
    AddGaussian(&scene, {0, 0, 2}, 0.001, 0.6, {0.2, 0.5, 0.9});
    AddGaussian(&scene, {0, 0, 3}, 0.001, 0.5, {0.4, 0.5, 0.1});
    scene.features[kReconChannels + kAgreementChannel] = 0.f;
    RefinementOptions options;
    options.iterations = 4;
    options.min_colour = -10;
    options.max_colour = 10;
    options.keep_hidden = keep;
    ASSERT_TRUE(RefineColours({UniformView(1, 1, 1, 0.7f)}, options, &scene).ok());
    const double a0 = 0.6, a1 = 0.5 * 0.4, l0 = 0.05 * (a0 * a0 + 0.001);
    const double back[3] = {0.4, 0.5, 0.1}, front[3] = {0.2, 0.5, 0.9};
    for (int c = 0; c < 3; ++c) {
      const double residual = 0.7 - a0 * front[c] - a1 * back[c];
      if (keep) {
        EXPECT_NEAR(scene.features[kReconChannels + c], back[c], 1e-3) << "channel " << c;
        EXPECT_NEAR(scene.features[c], front[c] + a0 * residual / (a0 * a0 + l0), 1e-3)
            << "channel " << c;
      } else {
        EXPECT_GT(std::abs(scene.features[kReconChannels + c] - back[c]), 0.05) << "channel " << c;
      }
    }
  }
}

TEST(ColourRefinement, OnePixelTwoGaussiansMatchesTheClosedForm) {
  // A 1x1 view; two Gaussians on its centre ray, opacity 0.6 (front) and 0.5,
  // so the pixel is a . c with a = (0.6, 0.5 x 0.4). One equation, two
  // unknowns, the prior sum_k l_k (c_k - c0_k)^2 with l_k = 0.05 (s_k +
  // 0.001): the minimiser is
  //   c = c0 + L^-1 a (I - a . c0) / (1 + a^T L^-1 a)
  // (the normal equations' single-row form), which CG reaches in 2 steps.
  // s_k is a_k^2 for the front Gaussian. For the back one it is a_1^2
  // without prior_from_unoccluded and sqrt(a_1^2 x 0.5^2) with it, 0.5 being
  // its alpha with nothing in front (a_1 / the transmittance 0.4): the view
  // sees it only through the front one, and its prior is 2.5 times stronger.
  for (const bool unoccluded : {true, false}) {
    GaussianScene scene = EmptyScene();
    AddGaussian(&scene, {0, 0, 2}, 0.001, 0.6, {0.2, 0.5, 0.9});
    AddGaussian(&scene, {0, 0, 3}, 0.001, 0.5, {0.4, 0.5, 0.1});
    const ContextView view = UniformView(1, 1, 1, 0.7f);
    RefinementOptions options;
    options.iterations = 2;
    options.prior_weight = 0.05;
    options.min_colour = -10;
    options.max_colour = 10;
    options.prior_from_unoccluded = unoccluded;
    absl::StatusOr<RefinementStats> stats = RefineColours({view}, options, &scene);
    ASSERT_TRUE(stats.ok()) << stats.status();
    const double a0 = 0.6, a1 = 0.5 * 0.4;
    const double s1 = unoccluded ? std::sqrt(a1 * a1 * 0.5 * 0.5) : a1 * a1;
    const double l0 = 0.05 * (a0 * a0 + 0.001), l1 = 0.05 * (s1 + 0.001);
    const double gain = a0 * a0 / l0 + a1 * a1 / l1;  // a^T L^-1 a.
    const double c0[2][3] = {{0.2, 0.5, 0.9}, {0.4, 0.5, 0.1}};
    for (int c = 0; c < 3; ++c) {
      const double rendered = a0 * c0[0][c] + a1 * c0[1][c];
      const double k = (0.7 - rendered) / (1 + gain);
      EXPECT_NEAR(scene.features[c], c0[0][c] + a0 / l0 * k, 1e-4)
          << "channel " << c << ", unoccluded " << unoccluded;
      EXPECT_NEAR(scene.features[kReconChannels + c], c0[1][c] + a1 / l1 * k, 1e-4)
          << "channel " << c << ", unoccluded " << unoccluded;
    }
    EXPECT_FLOAT_EQ(scene.features[6], 0.25f);
    EXPECT_EQ(stats->pixels, 1);
    EXPECT_EQ(stats->pairs, 2);
    // Before: mean over channels of (0.7 - rendered)^2.
    double before = 0;
    for (int c = 0; c < 3; ++c) before += std::pow(0.7 - (a0 * c0[0][c] + a1 * c0[1][c]), 2) / 3;
    EXPECT_NEAR(stats->rmse_before, std::sqrt(before), 1e-6);
    // After: every channel's residual shrinks by 1 / (1 + a^T L^-1 a).
    EXPECT_NEAR(stats->rmse_after, std::sqrt(before) / (1 + gain), 1e-5);
  }
}

TEST(ColourRefinement, PixelsUnderMinAlphaAreLeftOut) {
  // A faint Gaussian (opacity 0.3: alpha < 0.5 everywhere) far from a
  // strong one: the faint one has no fitted pixel and keeps its colour; the
  // strong one moves to the image.
  GaussianScene scene = EmptyScene();
  AddGaussian(&scene, {-0.4375, 0, 1}, 0.001, 0.3, {0.1, 0.1, 0.1});  // Pixel 4.
  AddGaussian(&scene, {0.5625, 0, 1}, 0.001, 0.95, {0.1, 0.1, 0.1});  // Pixel 12.
  const ContextView view = UniformView(16, 1, 8, 0.9f);
  RefinementOptions options;
  options.iterations = 4;
  options.prior_weight = 1e-3;
  absl::StatusOr<RefinementStats> stats = RefineColours({view}, options, &scene);
  ASSERT_TRUE(stats.ok()) << stats.status();
  EXPECT_FLOAT_EQ(scene.features[0], 0.1f);
  // The strong one's single fitted pixel is its centre (weight 0.95): its
  // colour becomes about 0.9 / 0.95.
  EXPECT_NEAR(scene.features[kReconChannels], 0.9 / 0.95, 0.01);
  EXPECT_EQ(stats->pixels, 1);
}

TEST(ColourRefinement, EgoBodyPixelsAreLeftOut) {
  // The problem above with two strong Gaussians; the pixel of the second is
  // on the ego vehicle's body (ContextView::ego): it keeps its colour and
  // only the first is fitted.
  GaussianScene scene = EmptyScene();
  AddGaussian(&scene, {-0.4375, 0, 1}, 0.001, 0.95, {0.1, 0.1, 0.1});  // Pixel 4.
  AddGaussian(&scene, {0.5625, 0, 1}, 0.001, 0.95, {0.1, 0.1, 0.1});   // Pixel 12.
  ContextView view = UniformView(16, 1, 8, 0.9f);
  view.ego.assign(16, 0);
  view.ego[12] = 1;
  RefinementOptions options;
  options.iterations = 4;
  options.prior_weight = 1e-3;
  absl::StatusOr<RefinementStats> stats = RefineColours({view}, options, &scene);
  ASSERT_TRUE(stats.ok()) << stats.status();
  EXPECT_NEAR(scene.features[0], 0.9 / 0.95, 0.01);
  EXPECT_FLOAT_EQ(scene.features[kReconChannels], 0.1f);
  EXPECT_EQ(stats->pixels, 1);
}

// Returns `geometry` with the render of `scene` through it as its image
// (empty pixels, with a failure recorded, if the render fails).
ContextView ViewRenderedFrom(const GaussianScene& scene, const ContextView& geometry) {
  RenderOptions render_options;
  render_options.features = false;
  absl::StatusOr<RenderBuffers> render =
      Render(scene, {geometry.camera, geometry.world_from_camera}, 0, {}, render_options);
  EXPECT_TRUE(render.ok()) << render.status();
  ContextView view = geometry;
  view.rgb.pixels = render.ok() ? render->rgb : std::vector<float>{};
  return view;
}

// Overlapping discs (std-dev 0.3 m, opacity 0.9) every 2 pixels of a w x h
// view of focal length 40, on a wall 10 m away; random colours.
GaussianScene WallOfDiscs(int w, int h) {
  GaussianScene wall = EmptyScene();
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> u(0.1, 0.9);
  for (int y = 0; y < h; y += 2) {
    for (int x = 0; x < w; x += 2) {
      const Vec3 at{(x + 1 - w / 2.0) / 40 * 10, (y + 1 - h / 2.0) / 40 * 10, 10};
      AddGaussian(&wall, at, 0.3, 0.9, {u(rng), u(rng), u(rng)});
    }
  }
  return wall;
}

// The largest difference of any colour channel of `a` and `b`.
double MaxColourDifference(const GaussianScene& a, const GaussianScene& b) {
  double max_error = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    for (int c = 0; c < 3; ++c) {
      const size_t k = i * kReconChannels + c;
      max_error = std::max(max_error, double(std::abs(a.features[k] - b.features[k])));
    }
  }
  return max_error;
}

// Flat colours, many iterations and a weak prior: the fit alone decides.
RefinementOptions ExactFlatFit() {
  RefinementOptions options;
  options.iterations = 40;
  options.prior_weight = 1e-4;
  options.min_alpha = 0;
  options.colour_gradients = false;
  return options;
}

TEST(ColourRefinement, RecoversTheColoursAContextImageWasRenderedFrom) {
  // A wall of overlapping discs 10 m away, random colours; the context image
  // is their render. Starting from grey, the fit must find the colours the
  // image came from (the render is blurry, so the per-pixel residual alone
  // would not).
  const int w = 40, h = 30;
  const ContextView geometry = UniformView(w, h, 40, 0.f);
  GaussianScene truth = WallOfDiscs(w, h);
  const ContextView view = ViewRenderedFrom(truth, geometry);
  ASSERT_FALSE(view.rgb.pixels.empty());

  GaussianScene scene = truth;
  for (size_t i = 0; i < scene.size(); ++i)
    for (int c = 0; c < 3; ++c) scene.features[i * kReconChannels + c] = 0.5f;
  absl::StatusOr<RefinementStats> stats = RefineColours({view}, ExactFlatFit(), &scene);
  ASSERT_TRUE(stats.ok()) << stats.status();
  EXPECT_LT(MaxColourDifference(scene, truth), 0.02);
  EXPECT_GT(stats->rmse_before, 0.1);
  EXPECT_LT(stats->rmse_after, 0.002);
  EXPECT_FALSE(scene.has_colour_gradients());
  // The stage line's split of the fit's time: both parts ran.
  EXPECT_GT(stats->record_seconds, 0);
  EXPECT_GT(stats->solve_seconds, 0);
}

TEST(ColourRefinement, EntriesUnderMinWeightAreHeldAtTheirDecodedColours) {
  // The wall of the test above behind a veil of faint bright Gaussians
  // (opacity 0.03, colour 1.5): every weight of the veil is under
  // min_weight, so it is not fitted, but it adds about 0.1 to the image. The
  // fit holds it at its decoded colour and finds the wall's colours from
  // decoded ones 0.05 off (the wall's own weights under min_weight stay
  // with those), where fitting the image without the veil would brighten
  // the wall by about as much as the veil adds.
  const int w = 40, h = 30;
  const ContextView geometry = UniformView(w, h, 40, 0.f);
  GaussianScene truth = WallOfDiscs(w, h);
  const size_t wall = truth.size();
  for (int y = -4; y < h + 4; y += 4) {
    for (int x = -4; x < w + 4; x += 4) {
      const Vec3 at{(x + 1 - w / 2.0) / 40 * 8, (y + 1 - h / 2.0) / 40 * 8, 8};
      AddGaussian(&truth, at, 0.5, 0.03, {1.5, 1.5, 1.5});
    }
  }
  const ContextView view = ViewRenderedFrom(truth, geometry);
  ASSERT_FALSE(view.rgb.pixels.empty());

  GaussianScene scene = truth;
  for (size_t i = 0; i < wall; ++i)
    for (int c = 0; c < 3; ++c)
      scene.features[i * kReconChannels + c] += (i + c) % 2 ? 0.05f : -0.05f;
  RefinementOptions options = ExactFlatFit();
  options.min_weight = 0.035f;
  absl::StatusOr<RefinementStats> stats = RefineColours({view}, options, &scene);
  ASSERT_TRUE(stats.ok()) << stats.status();
  EXPECT_LT(MaxColourDifference(scene, truth), 0.02);
  for (size_t i = wall; i < scene.size(); ++i)  // No entries: as decoded.
    for (int c = 0; c < 3; ++c) ASSERT_EQ(scene.features[i * kReconChannels + c], 1.5f);
  EXPECT_LT(stats->rmse_after, 0.002);
}

TEST(ColourRefinement, FitsColourGradientsAFlatFitCannot) {
  // Discs 4 px apart with a colour ramp across each (random gradients); the
  // context image is their render. From grey, the fit with gradients finds
  // colours and gradients close to the truth and explains the image; flat
  // colours cannot (each disc shows one colour where the image ramps).
  const int w = 40, h = 30;
  const ContextView geometry = UniformView(w, h, 40, 0.f);
  GaussianScene truth = EmptyScene();
  truth.low_pass = 0.1f;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0.3, 0.7), g(-0.15, 0.15);
  for (int y = 0; y < h; y += 4) {
    for (int x = 0; x < w; x += 4) {
      const Vec3 at{(x + 2 - w / 2.0) / 40 * 10, (y + 2 - h / 2.0) / 40 * 10, 10};
      AddGaussian(&truth, at, 0.5, 0.95, {u(rng), u(rng), u(rng)});
      const size_t i = truth.size() - 1;
      truth.log_scales[3 * i + 2] = std::log(0.01f);  // Flat discs facing the camera.
    }
  }
  truth.colour_gradients.resize(6 * truth.size());
  for (float& v : truth.colour_gradients) v = static_cast<float>(g(rng));
  const ContextView view = ViewRenderedFrom(truth, geometry);
  ASSERT_FALSE(view.rgb.pixels.empty());

  GaussianScene start = truth;
  start.colour_gradients.clear();
  for (size_t i = 0; i < start.size(); ++i)
    for (int c = 0; c < 3; ++c) start.features[i * kReconChannels + c] = 0.5f;
  RefinementOptions options;
  options.iterations = 60;
  options.prior_weight = 1e-4;
  options.gradient_prior_weight = 1e-4;
  options.min_alpha = 0;
  GaussianScene textured = start;
  absl::StatusOr<RefinementStats> with = RefineColours({view}, options, &textured);
  ASSERT_TRUE(with.ok()) << with.status();
  options.colour_gradients = false;
  GaussianScene flat = start;
  absl::StatusOr<RefinementStats> without = RefineColours({view}, options, &flat);
  ASSERT_TRUE(without.ok()) << without.status();

  ASSERT_TRUE(textured.has_colour_gradients());
  double max_gradient_error = 0;
  for (size_t k = 0; k < truth.colour_gradients.size(); ++k) {
    max_gradient_error =
        std::max(max_gradient_error,
                 double(std::abs(textured.colour_gradients[k] - truth.colour_gradients[k])));
  }
  EXPECT_LT(max_gradient_error, 0.02);
  EXPECT_LT(with->rmse_after, 0.002);
  EXPECT_GT(without->rmse_after, 5 * with->rmse_after);
  EXPECT_FALSE(flat.has_colour_gradients());
}

TEST(ColourRefinement, ADiscWithAGradientIsFittedInOneIteration) {
  // One disc with a colour ramp, cut by the image's left edge, so the
  // pixels that see it are not centred on it: its colour and gradients are
  // coupled (the off-diagonal terms of its 3x3 block of A^T A). The
  // preconditioner is that block's inverse, so from grey and flat, the
  // first conjugate-gradient step lands on the least-squares solution: the
  // truth. A diagonal preconditioner would leave it well off after one
  // step.
  const int w = 24, h = 24;
  const ContextView geometry = UniformView(w, h, 24, 0.f);
  GaussianScene truth = EmptyScene();
  truth.low_pass = 0.1f;
  // 3 px from the left edge, 2 px above the centre row; std-dev 4 px.
  AddGaussian(&truth, {(3 - w / 2.0) / 24 * 10, (10 - h / 2.0) / 24 * 10, 10}, 1.6, 0.9,
              {0.3, 0.6, 0.45});
  truth.log_scales[2] = std::log(0.01f);  // A flat disc facing the camera.
  truth.colour_gradients = {0.2f, -0.1f, -0.15f, 0.1f, 0.05f, 0.2f};
  const ContextView view = ViewRenderedFrom(truth, geometry);
  ASSERT_FALSE(view.rgb.pixels.empty());

  GaussianScene fitted = truth;
  fitted.colour_gradients.clear();
  for (int c = 0; c < 3; ++c) fitted.features[c] = 0.5f;
  RefinementOptions options;
  options.iterations = 1;
  options.prior_weight = 1e-6;
  options.gradient_prior_weight = 1e-6;
  options.min_alpha = 0;
  options.min_weight = 0;
  ASSERT_TRUE(RefineColours({view}, options, &fitted).ok());
  ASSERT_TRUE(fitted.has_colour_gradients());
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(fitted.features[c], truth.features[c], 2e-3) << "channel " << c;
    EXPECT_NEAR(fitted.colour_gradients[2 * c], truth.colour_gradients[2 * c], 2e-3)
        << "channel " << c;
    EXPECT_NEAR(fitted.colour_gradients[2 * c + 1], truth.colour_gradients[2 * c + 1], 2e-3)
        << "channel " << c;
  }
}

// A wall of grey discs 10 m away, one every 2 pixels of a w x h view with
// focal length 40.
GaussianScene GreyWall(int w, int h) {
  GaussianScene scene = EmptyScene();
  for (int y = 0; y < h; y += 2) {
    for (int x = 0; x < w; x += 2) {
      const Vec3 at{(x + 1 - w / 2.0) / 40 * 10, (y + 1 - h / 2.0) / 40 * 10, 10};
      AddGaussian(&scene, at, 0.3, 0.9, {0.5, 0.5, 0.5});
    }
  }
  return scene;
}

// The wall above seen by two identical 0.8-grey views, with flat colours
// (GradientsOverThePairBudget... has them) and every pixel fitted.
struct TwoViewWall {
  ContextView view = UniformView(40, 30, 40, 0.8f);
  GaussianScene scene = GreyWall(40, 30);
  std::vector<ContextView> views = {view, view};
  RefinementOptions options = [] {
    RefinementOptions o;
    o.min_alpha = 0;
    o.colour_gradients = false;
    return o;
  }();
};

// What the fit of one view records at a pixel stride, in units of
// kWeightUnitBytes: its pairs, its tables' slots and, with gradients,
// 6 units per Gaussian they reach (its screen frame).
struct StrideUnits {
  int64_t pairs = 0;
  int64_t table = 0;
  int64_t frames = 0;
  int64_t flat() const { return pairs + table; }
  int64_t textured() const { return pairs + table + frames; }
};
StrideUnits UnitsAtStride(const GaussianScene& scene, const ContextView& view,
                          const RefinementOptions& options, int stride) {
  WeightOptions recorded;
  recorded.min_weight = options.min_weight;
  recorded.pixel_stride = stride;
  absl::StatusOr<CompositingWeights> a = ComputeCompositingWeights(
      scene, {view.camera, view.world_from_camera}, view.timestamp_us, recorded);
  EXPECT_TRUE(a.ok()) << a.status();
  if (!a.ok()) return {};
  return {int64_t(a->entries()), int64_t(a->table.size()), 6 * int64_t(a->gaussians.size())};
}

// The units a fit's weights took (RefinementStats::weight_bytes).
int64_t Units(const RefinementStats& stats) { return stats.weight_bytes / kWeightUnitBytes; }

TEST(ColourRefinement, OverThePairBudgetTheColoursStayAsDecoded) {
  // The wall, seen by two views: the fit needs every pair of both. With
  // every pixel required (max_pixel_stride 1), one pair short of that
  // nothing is changed; at exactly that many, the fit runs.
  const TwoViewWall wall;
  const GaussianScene& scene = wall.scene;
  const std::vector<ContextView>& views = wall.views;
  RefinementOptions options = wall.options;
  options.max_pixel_stride = 1;
  GaussianScene unbounded = scene;
  absl::StatusOr<RefinementStats> full = RefineColours(views, options, &unbounded);
  ASSERT_TRUE(full.ok()) << full.status();
  ASSERT_FALSE(full->skipped_over_budget);
  ASSERT_GT(full->pairs, 0);
  EXPECT_EQ(full->pixel_stride, 1);
  // A unit per pair and per table slot (at most one per pair).
  EXPECT_GT(Units(*full), full->pairs);
  EXPECT_LE(Units(*full), 2 * full->pairs);

  GaussianScene over = scene;
  options.max_pairs = Units(*full) - 1;
  absl::StatusOr<RefinementStats> skipped = RefineColours(views, options, &over);
  ASSERT_TRUE(skipped.ok()) << skipped.status();
  EXPECT_TRUE(skipped->skipped_over_budget);
  EXPECT_EQ(over.features, scene.features);

  GaussianScene at_budget = scene;
  options.max_pairs = Units(*full);
  absl::StatusOr<RefinementStats> fitted = RefineColours(views, options, &at_budget);
  ASSERT_TRUE(fitted.ok()) << fitted.status();
  EXPECT_FALSE(fitted->skipped_over_budget);
  EXPECT_EQ(fitted->pairs, full->pairs);
  EXPECT_NE(at_budget.features, scene.features);      // Pulled towards the 0.8 grey image.
  EXPECT_EQ(at_budget.features, unbounded.features);  // The same fit as without a budget.
}

TEST(ColourRefinement, OverThePairBudgetEveryOtherPixelIsFitted) {
  // The same two views with strides allowed: one pair short of every
  // pixel, the fit takes 1 pixel in 2 of each view (a checkerboard, half
  // the pairs) and still pulls every colour to the image's grey; a budget
  // under a quarter of the pairs (the largest stride allowed, 4) skips it.
  const TwoViewWall wall;
  const ContextView& view = wall.view;
  const GaussianScene& scene = wall.scene;
  const std::vector<ContextView>& views = wall.views;
  RefinementOptions options = wall.options;
  GaussianScene unbounded = scene;
  absl::StatusOr<RefinementStats> full = RefineColours(views, options, &unbounded);
  ASSERT_TRUE(full.ok()) << full.status();

  options.max_pairs = Units(*full) - 1;
  GaussianScene strided = scene;
  absl::StatusOr<RefinementStats> half = RefineColours(views, options, &strided);
  ASSERT_TRUE(half.ok()) << half.status();
  EXPECT_FALSE(half->skipped_over_budget);
  EXPECT_EQ(half->pixel_stride, 2);
  EXPECT_LE(Units(*half), options.max_pairs);
  EXPECT_NEAR(double(half->pairs) / double(full->pairs), 0.5, 0.02);
  EXPECT_EQ(half->pixels, full->pixels / 2);
  // The wall's discs start away from 0.8; both fits bring the visible ones
  // there: the render of the strided fit matches the full fit's.
  const RenderCamera camera{view.camera, view.world_from_camera};
  absl::StatusOr<RenderBuffers> a = Render(unbounded, camera, view.timestamp_us, {}, {});
  absl::StatusOr<RenderBuffers> b = Render(strided, camera, view.timestamp_us, {}, {});
  absl::StatusOr<RenderBuffers> before = Render(scene, camera, view.timestamp_us, {}, {});
  ASSERT_TRUE(a.ok() && b.ok() && before.ok());
  double diff = 0, moved = 0;
  for (size_t i = 0; i < a->rgb.size(); ++i) {
    diff = std::max(diff, double(std::abs(a->rgb[i] - b->rgb[i])));
    moved = std::max(moved, double(std::abs(a->rgb[i] - before->rgb[i])));
  }
  EXPECT_GT(moved, 0.05);
  EXPECT_LT(diff, 0.02);

  // Eight such views and a budget of 0.6 of their pairs: the estimate from
  // the views recorded before the bound is passed (or projected to be)
  // gives 1 pixel in 2, whichever of the two stops the recording.
  const std::vector<ContextView> eight(8, view);
  GaussianScene eight_scene = scene;
  RefinementOptions eight_options = options;
  eight_options.max_pairs = 4 * Units(*full) * 6 / 10;
  absl::StatusOr<RefinementStats> eight_stats = RefineColours(eight, eight_options, &eight_scene);
  ASSERT_TRUE(eight_stats.ok()) << eight_stats.status();
  EXPECT_EQ(eight_stats->pixel_stride, 2);
  EXPECT_EQ(eight_stats->pixels, 4 * half->pixels);

  options.max_pairs = Units(*full) / 4 - 1;
  GaussianScene none = scene;
  absl::StatusOr<RefinementStats> skipped = RefineColours(views, options, &none);
  ASSERT_TRUE(skipped.ok()) << skipped.status();
  EXPECT_TRUE(skipped->skipped_over_budget);
  EXPECT_EQ(none.features, scene.features);
}

TEST(ColourRefinement, GradientsOverThePairBudgetFallBackToAFlatFit) {
  // The wall again: with gradients each Gaussian in view costs 6 units more
  // (its screen frame), so at a budget of exactly the flat fit's units the
  // gradients do not fit and the colours are fitted flat, as a flat fit does
  // them.
  const ContextView view = UniformView(40, 30, 40, 0.8f);
  const GaussianScene scene = GreyWall(40, 30);
  RefinementOptions options;
  options.min_alpha = 0;
  options.colour_gradients = false;
  options.max_pixel_stride = 1;  // Every pixel or nothing, for the counts below.
  GaussianScene flat = scene;
  absl::StatusOr<RefinementStats> flat_stats = RefineColours({view}, options, &flat);
  ASSERT_TRUE(flat_stats.ok()) << flat_stats.status();
  options.colour_gradients = true;
  const StrideUnits every = UnitsAtStride(scene, view, options, 1);
  ASSERT_EQ(Units(*flat_stats), every.flat());
  options.max_pairs = every.flat();
  GaussianScene fallback = scene;
  absl::StatusOr<RefinementStats> stats = RefineColours({view}, options, &fallback);
  ASSERT_TRUE(stats.ok()) << stats.status();
  EXPECT_TRUE(stats->flat_fallback);
  EXPECT_FALSE(stats->skipped_over_budget);
  EXPECT_EQ(stats->pairs, flat_stats->pairs);
  EXPECT_FALSE(fallback.has_colour_gradients());
  EXPECT_EQ(fallback.features, flat.features);
  EXPECT_NE(fallback.features, scene.features);
  // The flat units and 6 per Gaussian in view: the gradients fit; one unit
  // less and they do not.
  ASSERT_GT(every.frames, 0);
  const int64_t with_frames = every.textured();
  options.max_pairs = with_frames - 1;
  GaussianScene short_one = scene;
  stats = RefineColours({view}, options, &short_one);
  ASSERT_TRUE(stats.ok()) << stats.status();
  EXPECT_TRUE(stats->flat_fallback);
  options.max_pairs = with_frames;
  GaussianScene textured = scene;
  stats = RefineColours({view}, options, &textured);
  ASSERT_TRUE(stats.ok()) << stats.status();
  EXPECT_FALSE(stats->flat_fallback);
  EXPECT_TRUE(textured.has_colour_gradients());
  // One unit less than the flat fit needs and even that is skipped.
  options.max_pairs = every.flat() - 1;
  GaussianScene none = scene;
  stats = RefineColours({view}, options, &none);
  ASSERT_TRUE(stats.ok()) << stats.status();
  EXPECT_TRUE(stats->flat_fallback);
  EXPECT_TRUE(stats->skipped_over_budget);
  EXPECT_EQ(none.features, scene.features);
  // With strides allowed, a budget of the flat fit's units keeps the
  // gradients, fitted on 1 pixel in 2: half the pairs, their tables and the
  // frames fit.
  options.max_pixel_stride = 4;
  options.max_pairs = every.flat();
  GaussianScene strided = scene;
  stats = RefineColours({view}, options, &strided);
  ASSERT_TRUE(stats.ok()) << stats.status();
  EXPECT_FALSE(stats->flat_fallback);
  EXPECT_FALSE(stats->skipped_over_budget);
  EXPECT_EQ(stats->pixel_stride, 2);
  EXPECT_TRUE(strided.has_colour_gradients());
  EXPECT_LE(Units(*stats), options.max_pairs);
  EXPECT_EQ(Units(*stats), UnitsAtStride(scene, view, options, 2).textured());
}

TEST(ColourRefinement, OneRecordingOnEveryPixelTellsTheStrideThatFits) {
  // One view of the wall with gradients: what each stride k needs (its
  // lattice's pairs, table slots and 6 units per Gaussian they reach) is counted from the
  // recording on every pixel, so a bound of exactly stride k's units is
  // fitted at k, and one unit less at the next stride.
  const ContextView view = UniformView(40, 30, 40, 0.8f);
  const GaussianScene scene = GreyWall(40, 30);
  RefinementOptions options;
  options.min_alpha = 0;
  std::vector<int64_t> units(5, 0);
  for (int k = 1; k <= 4; ++k) {
    const StrideUnits at = UnitsAtStride(scene, view, options, k);
    units[k] = at.textured();
  }
  ASSERT_GT(units[1], units[2]);
  ASSERT_GT(units[2], units[3]);
  ASSERT_GT(units[3], units[4]);
  for (int k = 2; k <= 4; ++k) {
    for (int64_t slack : {int64_t{0}, int64_t{-1}}) {
      options.max_pairs = units[k] + slack;
      GaussianScene fitted = scene;
      absl::StatusOr<RefinementStats> stats = RefineColours({view}, options, &fitted);
      ASSERT_TRUE(stats.ok()) << stats.status();
      SCOPED_TRACE(::testing::Message() << "stride " << k << ", bound " << options.max_pairs);
      EXPECT_EQ(stats->max_pairs, options.max_pairs);
      if (slack == 0) {
        EXPECT_EQ(stats->pixel_stride, k);
        EXPECT_FALSE(stats->flat_fallback);
        EXPECT_EQ(stats->weight_bytes, kWeightUnitBytes * units[k]);
      } else if (k < 4) {
        EXPECT_EQ(stats->pixel_stride, k + 1);
        EXPECT_EQ(stats->weight_bytes, kWeightUnitBytes * units[k + 1]);
      } else {
        EXPECT_TRUE(stats->flat_fallback);  // Flat colours on fewer units.
        EXPECT_FALSE(fitted.has_colour_gradients());
      }
    }
  }
}

TEST(ColourRefinement, FlatColoursOnEveryPixelWhereGradientsFitAtNoStride) {
  // Discs a pixel or so across, one every 2 pixels: their screen frames
  // (6 units each) outweigh the pairs, so with strides up to 2 the gradients
  // fit nowhere within the flat units of every pixel, and the flat fit takes
  // every pixel rather than 1 in 2.
  const ContextView view = UniformView(40, 30, 40, 0.8f);
  GaussianScene scene = EmptyScene();
  scene.low_pass = 0.05f;
  for (int y = 0; y < 30; y += 2) {
    for (int x = 0; x < 40; x += 2) {
      AddGaussian(&scene, {(x + 0.5 - 20) / 4, (y + 0.5 - 15) / 4, 10}, 0.05, 0.9, {0.5, 0.5, 0.5});
    }
  }
  RefinementOptions options;
  options.min_alpha = 0;
  options.max_pixel_stride = 2;
  const StrideUnits every = UnitsAtStride(scene, view, options, 1);
  const StrideUnits half = UnitsAtStride(scene, view, options, 2);
  ASSERT_GT(half.textured(), every.flat());
  options.max_pairs = every.flat();
  GaussianScene fitted = scene;
  absl::StatusOr<RefinementStats> stats = RefineColours({view}, options, &fitted);
  ASSERT_TRUE(stats.ok()) << stats.status();
  EXPECT_TRUE(stats->flat_fallback);
  EXPECT_FALSE(stats->skipped_over_budget);
  EXPECT_EQ(stats->pixel_stride, 1);
  EXPECT_EQ(stats->pairs, every.pairs);
  EXPECT_NE(fitted.features, scene.features);
}

TEST(ColourRefinement, AShareOfTheFreeMemoryRaisesTheBound) {
  // A bound of 100 pairs skips the wall's fit; half of the memory the
  // machine has free takes every pixel, and says so.
  const TwoViewWall wall;
  RefinementOptions options = wall.options;
  options.max_pairs = 100;
  GaussianScene bounded = wall.scene;
  absl::StatusOr<RefinementStats> skipped = RefineColours(wall.views, options, &bounded);
  ASSERT_TRUE(skipped.ok()) << skipped.status();
  EXPECT_TRUE(skipped->skipped_over_budget);
  EXPECT_EQ(skipped->max_pairs, 100);
  EXPECT_EQ(bounded.features, wall.scene.features);

  if (AvailableMemoryBytes() < (int64_t{1} << 28)) {
    GTEST_SKIP() << "under 256 MiB free: too little to tell a raised bound";
  }
  options.available_memory_share = 0.5;
  GaussianScene raised = wall.scene;
  absl::StatusOr<RefinementStats> fitted = RefineColours(wall.views, options, &raised);
  ASSERT_TRUE(fitted.ok()) << fitted.status();
  EXPECT_FALSE(fitted->skipped_over_budget);
  EXPECT_EQ(fitted->pixel_stride, 1);
  EXPECT_GT(fitted->max_pairs, (int64_t{1} << 28) / 2 / kWeightUnitBytes / 2);
  EXPECT_NE(raised.features, wall.scene.features);

  // Never lowered: a bound over what half of the machine could take stays.
  options.max_pairs = int64_t{1} << 50;
  absl::StatusOr<RefinementStats> kept = RefineColours(wall.views, options, &raised);
  ASSERT_TRUE(kept.ok()) << kept.status();
  EXPECT_EQ(kept->max_pairs, options.max_pairs);

  options.available_memory_share = 1.5;
  EXPECT_EQ(RefineColours(wall.views, options, &raised).status().code(),
            absl::StatusCode::kInvalidArgument);
}

TEST(ColourRefinement, RejectsBadOptionsAndScenes) {
  GaussianScene scene = EmptyScene();
  AddGaussian(&scene, {0, 0, 2}, 0.01, 0.6, {0.2, 0.5, 0.9});
  const ContextView view = UniformView(4, 4, 4, 0.5f);
  RefinementOptions options;
  options.prior_weight = 0;
  EXPECT_EQ(RefineColours({view}, options, &scene).status().code(),
            absl::StatusCode::kInvalidArgument);
  options = RefinementOptions();
  ContextView wrong = view;
  wrong.rgb = ImageF(3, 4, 3);
  EXPECT_EQ(RefineColours({wrong}, options, &scene).status().code(),
            absl::StatusCode::kInvalidArgument);
  options.gradient_prior_weight = 0;
  EXPECT_EQ(RefineColours({view}, options, &scene).status().code(),
            absl::StatusCode::kInvalidArgument);
  options = RefinementOptions();
  scene.sh_degree = 0;
  EXPECT_EQ(RefineColours({view}, options, &scene).status().code(),
            absl::StatusCode::kInvalidArgument);
}

}  // namespace
}  // namespace pf
