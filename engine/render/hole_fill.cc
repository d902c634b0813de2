// Push-pull filling of uncovered render pixels.
#include "engine/render/hole_fill.h"

#include <algorithm>
#include <cstddef>

namespace pf {
namespace {

// Fills `rgb` (premultiplied, [h, w, 3]) and `alpha` ([h, w]) in place so
// that every alpha is 1: each pixel's uncovered part (1 - alpha) takes the
// colour of its 2x2 parent in the next coarser level, filled the same way.
void PushPull(std::vector<float>& rgb, std::vector<float>& alpha, int w, int h) {
  if (w == 1 && h == 1) {
    // The coarsest level: the mean colour of whatever was covered.
    if (alpha[0] > 0 && alpha[0] < 1) {
      for (int c = 0; c < 3; ++c) rgb[c] /= alpha[0];
    }
    alpha[0] = 1;
    return;
  }
  const int cw = (w + 1) / 2, ch = (h + 1) / 2;
  std::vector<float> coarse_rgb(size_t(cw) * ch * 3, 0.f), coarse_alpha(size_t(cw) * ch, 0.f);
  std::vector<int> count(size_t(cw) * ch, 0);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const size_t p = size_t(y) * w + x, q = size_t(y / 2) * cw + x / 2;
      for (int c = 0; c < 3; ++c) coarse_rgb[3 * q + c] += rgb[3 * p + c];
      coarse_alpha[q] += alpha[p];
      ++count[q];
    }
  }
  for (size_t q = 0; q < count.size(); ++q) {
    for (int c = 0; c < 3; ++c) coarse_rgb[3 * q + c] /= float(count[q]);
    coarse_alpha[q] /= float(count[q]);
  }
  PushPull(coarse_rgb, coarse_alpha, cw, ch);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const size_t p = size_t(y) * w + x, q = size_t(y / 2) * cw + x / 2;
      const float uncovered = 1.f - alpha[p];
      for (int c = 0; c < 3; ++c) rgb[3 * p + c] += uncovered * coarse_rgb[3 * q + c];
      alpha[p] = 1.f;
    }
  }
}

}  // namespace

std::vector<float> FillUncovered(const std::vector<float>& rgb, const std::vector<float>& alpha,
                                 int width, int height, float covered_alpha) {
  const size_t pixels = size_t(std::max(width, 0)) * size_t(std::max(height, 0));
  if (pixels == 0 || rgb.size() < 3 * pixels || alpha.size() < pixels) return rgb;
  std::vector<float> out(rgb.begin(), rgb.begin() + 3 * pixels);
  std::vector<float> coverage(pixels);
  for (size_t p = 0; p < pixels; ++p) {
    coverage[p] = alpha[p] >= covered_alpha ? 1.f : std::clamp(alpha[p], 0.f, 1.f);
  }
  PushPull(out, coverage, width, height);
  return out;
}

}  // namespace pf
