// L1 + D-SSIM and its gradient (photometric_loss.h).
//
// SSIM of a window p is a function of the window's moments of the render x
// and the truth y: m = sum g x, e = sum g x^2, f = sum g x y (g the window's
// weights), with sigma_x^2 = e - m^2 and sigma_xy = f - m mu_y. So
//   dSSIM_p / dx_q = g_{q-p} (dS/dm + 2 x_q dS/de + y_q dS/df),
// and the gradient of the mean is the three per-window maps dS/dm, dS/de,
// dS/df spread back over each window's footprint (the blur's transpose),
// combined per pixel.
#include "engine/recon/photometric_loss.h"

#include <cmath>

#include "common/thread_pool.h"

namespace pf {
namespace {

constexpr int kSsimRadius = 5;  // 11 x 11 window.
constexpr int kSsimTaps = 2 * kSsimRadius + 1;
constexpr double kSsimSigma = 1.5, kSsimC1 = 0.01 * 0.01, kSsimC2 = 0.03 * 0.03;

struct SsimKernel {
  double w[kSsimTaps];
  SsimKernel() {
    double total = 0;
    for (int k = -kSsimRadius; k <= kSsimRadius; ++k) {
      w[k + kSsimRadius] = std::exp(-0.5 * k * k / (kSsimSigma * kSsimSigma));
      total += w[k + kSsimRadius];
    }
    for (double& v : w) v /= total;
  }
};

}  // namespace

PhotometricLoss PhotometricLossAndGradient(const float* render, const ImageF& truth,
                                           const std::vector<uint8_t>& counted, double ssim_weight,
                                           std::vector<float>* gradient) {
  const int w = truth.width, h = truth.height;
  const size_t pixels = static_cast<size_t>(w) * h;
  auto is_counted = [&](size_t p) { return counted.empty() || counted[p] != 0; };
  PhotometricLoss loss;
  if (gradient != nullptr) gradient->assign(3 * pixels, 0.f);

  // L1 and MSE.
  int64_t n = 0;
  double l1 = 0, se = 0;
  for (size_t p = 0; p < pixels; ++p) {
    if (!is_counted(p)) continue;
    ++n;
    for (int c = 0; c < 3; ++c) {
      const double d = double(render[3 * p + c]) - truth.pixels[3 * p + c];
      l1 += std::abs(d);
      se += d * d;
    }
  }
  if (n == 0) return loss;
  loss.l1 = l1 / (3.0 * n);
  loss.mse = se / (3.0 * n);
  if (gradient != nullptr) {
    const float unit = static_cast<float>((1 - ssim_weight) / (3.0 * n));
    for (size_t p = 0; p < pixels; ++p) {
      if (!is_counted(p)) continue;
      for (int c = 0; c < 3; ++c) {
        const float d = render[3 * p + c] - truth.pixels[3 * p + c];
        (*gradient)[3 * p + c] = d > 0 ? unit : (d < 0 ? -unit : 0.f);
      }
    }
  }

  // SSIM over the full windows centred on counted pixels.
  loss.ssim = 1;
  const int out_w = w - 2 * kSsimRadius, out_h = h - 2 * kSsimRadius;
  int64_t windows = 0;
  if (out_w > 0 && out_h > 0) {
    for (int y = 0; y < out_h; ++y) {
      for (int x = 0; x < out_w; ++x) {
        windows += is_counted(static_cast<size_t>(y + kSsimRadius) * w + x + kSsimRadius);
      }
    }
  }
  loss.ssim_windows = windows;
  if (windows == 0) {
    loss.value = (1 - ssim_weight) * loss.l1;
    return loss;
  }
  static const SsimKernel kernel;
  const size_t out = static_cast<size_t>(out_w) * out_h;
  ThreadPool& pool = DefaultThreadPool();
  double ssim_sum = 0;
  // Per channel: moments (5 blurred maps), the SSIM map and its three
  // derivative maps, then their transposed blurs.
  std::vector<double> row(static_cast<size_t>(out_w) * h * 5);
  std::vector<double> dmaps(out * 3);
  std::vector<double> per_row(out_h);
  const bool ssim_gradient = gradient != nullptr && ssim_weight != 0;
  std::vector<double> spread(ssim_gradient ? pixels * 3 : 0);
  for (int c = 0; c < 3; ++c) {
    auto x_at = [&](int px, int py) { return double(render[3 * (size_t(py) * w + px) + c]); };
    auto y_at = [&](int px, int py) { return double(truth.pixels[3 * (size_t(py) * w + px) + c]); };
    pool.ParallelFor(0, h, 16, [&](int64_t y0, int64_t y1) {
      for (int64_t y = y0; y < y1; ++y) {
        for (int x = 0; x < out_w; ++x) {
          double acc[5] = {0, 0, 0, 0, 0};
          for (int k = 0; k < kSsimTaps; ++k) {
            const double a = x_at(x + k, int(y)), b = y_at(x + k, int(y)), g = kernel.w[k];
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
    pool.ParallelFor(0, out_h, 16, [&](int64_t y0, int64_t y1) {
      for (int64_t y = y0; y < y1; ++y) {
        double sum = 0;
        for (int x = 0; x < out_w; ++x) {
          const size_t o = static_cast<size_t>(y) * out_w + x;
          double* d = &dmaps[3 * o];
          d[0] = d[1] = d[2] = 0;
          if (!is_counted(static_cast<size_t>(y + kSsimRadius) * w + x + kSsimRadius)) continue;
          double acc[5] = {0, 0, 0, 0, 0};
          for (int k = 0; k < kSsimTaps; ++k) {
            for (int m = 0; m < 5; ++m) {
              acc[m] += kernel.w[k] * row[(static_cast<size_t>(y + k) * out_w + x) * 5 + m];
            }
          }
          const double mx = acc[0], my = acc[1];
          const double vx = acc[2] - mx * mx, vy = acc[3] - my * my, cxy = acc[4] - mx * my;
          const double n1 = 2 * mx * my + kSsimC1, n2 = 2 * cxy + kSsimC2;
          const double d1 = mx * mx + my * my + kSsimC1, d2 = vx + vy + kSsimC2;
          const double s = n1 * n2 / (d1 * d2);
          sum += s;
          // dS/d sigma_x^2, dS/d sigma_xy, dS/d mu_x (direct).
          const double ds_dv = -s / d2;
          const double ds_dc = 2 * n1 / (d1 * d2);
          const double ds_dmu = (2 * my / d1 - 2 * mx * n1 / (d1 * d1)) * n2 / d2;
          d[0] = ds_dmu - 2 * mx * ds_dv - my * ds_dc;  // d/dm
          d[1] = ds_dv;                                 // d/de
          d[2] = ds_dc;                                 // d/df
        }
        per_row[y] = sum;
      }
    });
    for (double s : per_row) ssim_sum += s;
    if (!ssim_gradient) continue;
    // Spread the maps back: vertically into rows of window columns, then
    // horizontally into pixels (every entry of `spread` written).
    pool.ParallelFor(0, h, 16, [&](int64_t y0, int64_t y1) {
      for (int64_t y = y0; y < y1; ++y) {
        // Windows whose rows reach pixel row y: centre rows y - kSsimRadius ..
        // y + kSsimRadius, window index wy = centre - kSsimRadius.
        for (int x = 0; x < out_w; ++x) {
          double acc[3] = {0, 0, 0};
          for (int k = 0; k < kSsimTaps; ++k) {
            const int wy = int(y) - k;  // Window wy covers rows wy .. wy + 2 kSsimRadius.
            if (wy < 0 || wy >= out_h) continue;
            const double* d = &dmaps[3 * (static_cast<size_t>(wy) * out_w + x)];
            for (int m = 0; m < 3; ++m) acc[m] += kernel.w[k] * d[m];
          }
          for (int m = 0; m < 3; ++m) row[(static_cast<size_t>(y) * out_w + x) * 5 + m] = acc[m];
        }
        for (int px = 0; px < w; ++px) {
          double acc[3] = {0, 0, 0};
          for (int k = 0; k < kSsimTaps; ++k) {
            const int wx = px - k;
            if (wx < 0 || wx >= out_w) continue;
            const double* r = &row[(static_cast<size_t>(y) * out_w + wx) * 5];
            for (int m = 0; m < 3; ++m) acc[m] += kernel.w[k] * r[m];
          }
          for (int m = 0; m < 3; ++m) spread[(static_cast<size_t>(y) * w + px) * 3 + m] = acc[m];
        }
      }
    });
    const double scale = -ssim_weight / (3.0 * double(windows));
    for (size_t p = 0; p < pixels; ++p) {
      const double* s = &spread[3 * p];
      const int px = static_cast<int>(p % w), py = static_cast<int>(p / w);
      const double g = s[0] + 2 * x_at(px, py) * s[1] + y_at(px, py) * s[2];
      (*gradient)[3 * p + c] += static_cast<float>(scale * g);
    }
  }
  loss.ssim = ssim_sum / (3.0 * double(windows));
  loss.value = (1 - ssim_weight) * loss.l1 + ssim_weight * (1 - loss.ssim);
  return loss;
}

}  // namespace pf
