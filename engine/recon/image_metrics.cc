// PSNR, SSIM, depth RMSE and the contact sheet.
#include "engine/recon/image_metrics.h"

#include <algorithm>
#include <cmath>

#include "common/thread_pool.h"

namespace pf {

std::optional<double> Psnr(const ImageF& truth, const ImageF& test,
                           const std::vector<uint8_t>& mask) {
  const size_t n = static_cast<size_t>(truth.width) * truth.height;
  double sum = 0;
  int64_t count = 0;
  for (size_t i = 0; i < n; ++i) {
    if (!mask.empty() && mask[i] == 0) continue;
    for (int c = 0; c < 3; ++c) {
      const double d = double(test.pixels[3 * i + c]) - truth.pixels[3 * i + c];
      sum += d * d;
    }
    count += 3;
  }
  if (count == 0) return std::nullopt;
  const double mse = sum / double(count);
  if (mse <= 0) return kMaxPsnr;
  return std::min(kMaxPsnr, 10.0 * std::log10(1.0 / mse));
}

std::optional<double> Ssim(const ImageF& truth, const ImageF& test,
                           const std::vector<uint8_t>& mask) {
  constexpr int kRadius = 5;  // 11 x 11 window.
  constexpr double kSigma = 1.5, kC1 = 0.01 * 0.01, kC2 = 0.03 * 0.03;
  const int w = truth.width, h = truth.height;
  if (w < 2 * kRadius + 1 || h < 2 * kRadius + 1) return std::nullopt;
  double kernel[2 * kRadius + 1];
  double total = 0;
  for (int k = -kRadius; k <= kRadius; ++k) {
    kernel[k + kRadius] = std::exp(-0.5 * k * k / (kSigma * kSigma));
    total += kernel[k + kRadius];
  }
  for (double& k : kernel) k /= total;
  const int out_w = w - 2 * kRadius, out_h = h - 2 * kRadius;
  // Window (x, y) is centred on pixel (x + kRadius, y + kRadius).
  auto counted = [&](int x, int y) {
    return mask.empty() || mask[static_cast<size_t>(y + kRadius) * w + x + kRadius] != 0;
  };
  int64_t windows = 0;
  for (int y = 0; y < out_h; ++y)
    for (int x = 0; x < out_w; ++x) windows += counted(x, y);
  if (windows == 0) return std::nullopt;
  double ssim_sum = 0;
  for (int c = 0; c < 3; ++c) {
    // Separable blur of x, y, x^2, y^2, xy: horizontal pass then vertical.
    std::vector<double> row(static_cast<size_t>(out_w) * h * 5);
    DefaultThreadPool().ParallelFor(0, h, 16, [&](int64_t y0, int64_t y1) {
      for (int64_t y = y0; y < y1; ++y) {
        for (int x = 0; x < out_w; ++x) {
          double acc[5] = {0, 0, 0, 0, 0};
          for (int k = 0; k <= 2 * kRadius; ++k) {
            const double a = truth.at(x + k, y, c), b = test.at(x + k, y, c);
            const double g = kernel[k];
            acc[0] += g * a;
            acc[1] += g * b;
            acc[2] += g * a * a;
            acc[3] += g * b * b;
            acc[4] += g * a * b;
          }
          for (int m = 0; m < 5; ++m) row[(static_cast<size_t>(y) * out_w + x) * 5 + m] = acc[m];
        }
      }
    });
    std::vector<double> per_row(out_h, 0.0);
    DefaultThreadPool().ParallelFor(0, out_h, 16, [&](int64_t y0, int64_t y1) {
      for (int64_t y = y0; y < y1; ++y) {
        double sum = 0;
        for (int x = 0; x < out_w; ++x) {
          if (!counted(x, int(y))) continue;
          double acc[5] = {0, 0, 0, 0, 0};
          for (int k = 0; k <= 2 * kRadius; ++k)
            for (int m = 0; m < 5; ++m)
              acc[m] += kernel[k] * row[(static_cast<size_t>(y + k) * out_w + x) * 5 + m];
          const double mu_a = acc[0], mu_b = acc[1];
          const double var_a = acc[2] - mu_a * mu_a, var_b = acc[3] - mu_b * mu_b;
          const double cov = acc[4] - mu_a * mu_b;
          sum += ((2 * mu_a * mu_b + kC1) * (2 * cov + kC2)) /
                 ((mu_a * mu_a + mu_b * mu_b + kC1) * (var_a + var_b + kC2));
        }
        per_row[y] = sum;
      }
    });
    double channel = 0;
    for (double s : per_row) channel += s;
    ssim_sum += channel / double(windows);
  }
  return ssim_sum / 3.0;
}

std::optional<double> DepthRmse(const ImageF& truth, const ImageF& test, int64_t* pixels) {
  double sum = 0;
  int64_t count = 0;
  for (size_t i = 0; i < truth.pixels.size(); ++i) {
    const float t = truth.pixels[i];
    if (!(t > 0.f) || !std::isfinite(t)) continue;
    const double d = double(test.pixels[i]) - t;
    sum += d * d;
    ++count;
  }
  if (pixels != nullptr) *pixels = count;
  if (count == 0) return std::nullopt;
  return std::sqrt(sum / double(count));
}

ImageF ContactSheet(const ImageF& truth, const ImageF& test, double max_error) {
  const int w = truth.width, h = truth.height;
  ImageF sheet(3 * w, h, 3);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      double err = 0;
      for (int c = 0; c < 3; ++c) {
        const float a = std::clamp(truth.at(x, y, c), 0.f, 1.f);
        const float b = std::clamp(test.at(x, y, c), 0.f, 1.f);
        sheet.at(x, y, c) = a;
        sheet.at(w + x, y, c) = b;
        err += std::abs(double(a) - b) / 3.0;
      }
      // Black -> red -> yellow -> white.
      const double s = std::clamp(err / max_error, 0.0, 1.0) * 3.0;
      sheet.at(2 * w + x, y, 0) = float(std::clamp(s, 0.0, 1.0));
      sheet.at(2 * w + x, y, 1) = float(std::clamp(s - 1.0, 0.0, 1.0));
      sheet.at(2 * w + x, y, 2) = float(std::clamp(s - 2.0, 0.0, 1.0));
    }
  }
  return sheet;
}

}  // namespace pf
