// Blurring a render (render_blur.h).
#include "engine/render/render_blur.h"

#include <algorithm>
#include <cmath>

#include "common/thread_pool.h"

namespace pf {

void BlurImage(float sigma, int width, int height, int channels, std::vector<float>* image) {
  if (!(sigma > 0.f) || width <= 0 || height <= 0 || channels <= 0) return;
  const int radius = std::max(1, static_cast<int>(std::ceil(3.f * sigma)));
  std::vector<float> kernel(2 * radius + 1);
  for (int k = -radius; k <= radius; ++k) {
    kernel[k + radius] = std::exp(-0.5f * float(k * k) / (sigma * sigma));
  }
  std::vector<float>& px = *image;
  std::vector<float> pass(px.size());
  // out[i] = sum_k w_k in[i + k] / sum_k w_k over the k that stay inside.
  auto blur_line = [&](const float* in, float* out, int length, size_t step) {
    for (int i = 0; i < length; ++i) {
      const int k0 = std::max(-radius, -i), k1 = std::min(radius, length - 1 - i);
      float weight = 0.f;
      for (int k = k0; k <= k1; ++k) weight += kernel[k + radius];
      for (int c = 0; c < channels; ++c) {
        float sum = 0.f;
        for (int k = k0; k <= k1; ++k) sum += kernel[k + radius] * in[(i + k) * step + c];
        out[i * step + c] = sum / weight;
      }
    }
  };
  const size_t row = size_t(width) * channels;
  DefaultThreadPool().ParallelFor(0, height, 16, [&](int64_t y0, int64_t y1) {
    for (int64_t y = y0; y < y1; ++y) {
      blur_line(&px[y * row], &pass[y * row], width, size_t(channels));
    }
  });
  // Columns: a block of columns at a time, rows in memory order.
  DefaultThreadPool().ParallelFor(0, width, 32, [&](int64_t x0, int64_t x1) {
    std::vector<float> column(size_t(height) * channels), blurred(column.size());
    for (int64_t x = x0; x < x1; ++x) {
      for (int y = 0; y < height; ++y) {
        for (int c = 0; c < channels; ++c)
          column[size_t(y) * channels + c] = pass[y * row + x * channels + c];
      }
      blur_line(column.data(), blurred.data(), height, size_t(channels));
      for (int y = 0; y < height; ++y) {
        for (int c = 0; c < channels; ++c)
          px[y * row + x * channels + c] = blurred[size_t(y) * channels + c];
      }
    }
  });
}

void BlurRender(float sigma, RenderBuffers* buffers) {
  if (!(sigma > 0.f)) return;
  const int w = buffers->width, h = buffers->height;
  if (!buffers->rgb.empty()) BlurImage(sigma, w, h, 3, &buffers->rgb);
  if (!buffers->features.empty()) BlurImage(sigma, w, h, buffers->channels, &buffers->features);
  if (!buffers->alpha.empty()) BlurImage(sigma, w, h, 1, &buffers->alpha);
}

}  // namespace pf
