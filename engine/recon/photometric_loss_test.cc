// Tests of the optimisation's loss: its SSIM is image_metrics.h's, and its
// gradient matches central differences.
#include "engine/recon/photometric_loss.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "engine/recon/image_metrics.h"

namespace pf {
namespace {

struct Pair {
  ImageF truth;
  std::vector<float> render;
  std::vector<uint8_t> counted;
};

// A smooth truth with texture, a render off from it by at least 0.01 per
// value (so L1's kink is never within a difference step), a mask with holes.
Pair RandomPair(int w, int h, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.f, 1.f);
  Pair pair;
  pair.truth = ImageF(w, h, 3);
  pair.render.resize(static_cast<size_t>(w) * h * 3);
  pair.counted.assign(static_cast<size_t>(w) * h, 1);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      for (int c = 0; c < 3; ++c) {
        const float t =
            0.5f + 0.3f * std::sin(0.3f * x + 0.7f * c) * std::cos(0.2f * y) + 0.1f * u(rng);
        pair.truth.at(x, y, c) = t;
        const float off = (0.01f + 0.1f * u(rng)) * (u(rng) < 0.5f ? -1.f : 1.f);
        pair.render[3 * (static_cast<size_t>(y) * w + x) + c] = t + off;
      }
      if (u(rng) < 0.15f) pair.counted[static_cast<size_t>(y) * w + x] = 0;
    }
  }
  return pair;
}

// SSIM window by window, straight from its definition.
double BruteForceSsim(const ImageF& truth, const std::vector<float>& render,
                      const std::vector<uint8_t>& counted) {
  const int w = truth.width, h = truth.height;
  double g1[11], total = 0;
  for (int k = -5; k <= 5; ++k) total += g1[k + 5] = std::exp(-0.5 * k * k / (1.5 * 1.5));
  double sum = 0;
  int64_t windows = 0;
  for (int c = 0; c < 3; ++c) {
    for (int cy = 5; cy < h - 5; ++cy) {
      for (int cx = 5; cx < w - 5; ++cx) {
        if (!counted[static_cast<size_t>(cy) * w + cx]) continue;
        double mx = 0, my = 0, xx = 0, yy = 0, xy = 0;
        for (int dy = -5; dy <= 5; ++dy) {
          for (int dx = -5; dx <= 5; ++dx) {
            const double g = g1[dx + 5] * g1[dy + 5] / (total * total);
            const double x = render[3 * (static_cast<size_t>(cy + dy) * w + cx + dx) + c];
            const double y = truth.at(cx + dx, cy + dy, c);
            mx += g * x, my += g * y, xx += g * x * x, yy += g * y * y, xy += g * x * y;
          }
        }
        const double c1 = 1e-4, c2 = 9e-4;
        sum += (2 * mx * my + c1) * (2 * (xy - mx * my) + c2) /
               ((mx * mx + my * my + c1) * (xx - mx * mx + yy - my * my + c2));
        ++windows;
      }
    }
  }
  return sum / windows;
}

TEST(PhotometricLoss, SsimIsTheDefinitionsAndTheEvaluations) {
  const Pair pair = RandomPair(40, 30, 1);
  ImageF test(40, 30, 3);
  test.pixels = pair.render;
  const PhotometricLoss loss =
      PhotometricLossAndGradient(pair.render.data(), pair.truth, pair.counted, 0.2, nullptr);
  EXPECT_NEAR(loss.ssim, BruteForceSsim(pair.truth, pair.render, pair.counted), 1e-12);
  const std::optional<double> ssim = Ssim(pair.truth, test, pair.counted);  // pf eval's.
  ASSERT_TRUE(ssim.has_value());
  EXPECT_NEAR(loss.ssim, *ssim, 1e-12);
  EXPECT_LT(loss.ssim, 0.95);
  EXPECT_NEAR(loss.value, 0.8 * loss.l1 + 0.2 * (1 - loss.ssim), 1e-12);
  const std::optional<double> psnr = Psnr(pair.truth, test, pair.counted);
  EXPECT_NEAR(-10 * std::log10(loss.mse), *psnr, 1e-9);
}

TEST(PhotometricLoss, GradientMatchesCentralDifferences) {
  for (double lambda : {0.0, 0.2, 1.0}) {
    SCOPED_TRACE(lambda);
    Pair pair = RandomPair(24, 20, 2);
    std::vector<float> gradient;
    PhotometricLossAndGradient(pair.render.data(), pair.truth, pair.counted, lambda, &gradient);
    double worst = 0, scale = 0;
    int nonzero = 0;
    for (size_t k = 0; k < pair.render.size(); k += 7) {
      const float keep = pair.render[k];
      constexpr float h = 2e-3f;
      pair.render[k] = keep + h;
      const double up =
          PhotometricLossAndGradient(pair.render.data(), pair.truth, pair.counted, lambda, nullptr)
              .value;
      pair.render[k] = keep - h;
      const double down =
          PhotometricLossAndGradient(pair.render.data(), pair.truth, pair.counted, lambda, nullptr)
              .value;
      pair.render[k] = keep;
      const double numeric = (up - down) / (2.0 * h);
      worst = std::max(worst, std::abs(numeric - gradient[k]));
      scale = std::max(scale, std::abs(numeric));
      nonzero += numeric != 0;
    }
    EXPECT_GT(nonzero, 50);
    EXPECT_LT(worst, 1e-3 * scale) << "largest gradient " << scale;
  }
}

TEST(PhotometricLoss, NoCountedPixelIsAZeroLoss) {
  Pair pair = RandomPair(16, 16, 3);
  std::fill(pair.counted.begin(), pair.counted.end(), 0);
  std::vector<float> gradient;
  const PhotometricLoss loss =
      PhotometricLossAndGradient(pair.render.data(), pair.truth, pair.counted, 0.2, &gradient);
  EXPECT_EQ(loss.value, 0);
  for (float g : gradient) EXPECT_EQ(g, 0.f);
}

}  // namespace
}  // namespace pf
