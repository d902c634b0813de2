// PSNR, SSIM, depth RMSE and the contact sheet.
#include "engine/recon/image_metrics.h"

#include <algorithm>
#include <cmath>

#include "engine/recon/photometric_loss.h"

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
  const PhotometricLoss loss =
      PhotometricLossAndGradient(test.pixels.data(), truth, mask, 1.0, nullptr);
  if (loss.ssim_windows == 0) return std::nullopt;
  return loss.ssim;
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

ImageF LineChart(const std::vector<float>& values, int window, int width, int height) {
  ImageF chart(width, height, 3);
  std::fill(chart.pixels.begin(), chart.pixels.end(), 1.f);
  constexpr int kMargin = 8;
  const int x0 = kMargin, x1 = width - 1 - kMargin, y0 = kMargin, y1 = height - 1 - kMargin;
  auto put = [&](int x, int y, float r, float g, float b) {
    if (x < 0 || y < 0 || x >= width || y >= height) return;
    chart.at(x, y, 0) = r;
    chart.at(x, y, 1) = g;
    chart.at(x, y, 2) = b;
  };
  for (int x = x0; x <= x1; ++x) put(x, y0, 0.6f, 0.6f, 0.6f), put(x, y1, 0.6f, 0.6f, 0.6f);
  for (int y = y0; y <= y1; ++y) put(x0, y, 0.6f, 0.6f, 0.6f), put(x1, y, 0.6f, 0.6f, 0.6f);
  double lo = INFINITY, hi = -INFINITY;
  for (float v : values) {
    if (!std::isfinite(v)) continue;
    lo = std::min(lo, double{v});
    hi = std::max(hi, double{v});
  }
  if (values.empty() || !(lo <= hi)) return chart;
  if (hi == lo) hi = lo + 1;
  const size_t span = static_cast<size_t>(std::max(window, 1));
  auto finite = [](float v) { return std::isfinite(v) ? double{v} : 0.0; };
  std::vector<double> mean(values.size());
  double sum = 0;
  for (size_t k = 0; k < values.size(); ++k) {
    sum += finite(values[k]);
    if (k >= span) sum -= finite(values[k - span]);
    mean[k] = sum / double(std::min(k + 1, span));
  }
  auto to_x = [&](size_t k) {
    return values.size() == 1 ? double(x0) : x0 + (x1 - x0) * double(k) / double(values.size() - 1);
  };
  auto to_y = [&](double v) { return y1 - (y1 - y0) * (v - lo) / (hi - lo); };
  // Lines from step to step, drawn as dense dots.
  auto line = [&](const auto& value_at, float r, float g, float b) {
    for (size_t k = 0; k + 1 < values.size(); ++k) {
      const double ax = to_x(k), ay = to_y(value_at(k)), bx = to_x(k + 1),
                   by = to_y(value_at(k + 1));
      const int n = 1 + static_cast<int>(std::max(std::abs(bx - ax), std::abs(by - ay)));
      for (int s = 0; s <= n; ++s) {
        const double t = double(s) / n;
        put(static_cast<int>(std::lround(ax + t * (bx - ax))),
            static_cast<int>(std::lround(ay + t * (by - ay))), r, g, b);
      }
    }
  };
  line([&](size_t k) { return std::isfinite(values[k]) ? double{values[k]} : lo; }, 0.55f, 0.7f,
       0.95f);
  line([&](size_t k) { return mean[k]; }, 0.6f, 0.f, 0.f);
  return chart;
}

}  // namespace pf
