// IP-Basic depth completion on a working grid, and its error at held-out
// points.
#include "engine/recon/depth_completion.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <vector>

#include "common/thread_pool.h"

namespace pf {
namespace {

// The density of measured pixels the paper's kernels were tuned for (the
// KITTI depth-completion benchmark's projected LiDAR).
constexpr double kIpBasicDensity = 0.05;
constexpr int kMaxIpBasicScale = 16;
// Kernel radii in cells (the paper's 5x5 diamond, 5x5 closing, 7x7 fill,
// 31x31 large fill, 5x5 median and bilateral filters).
constexpr int kDiamondRadius = 2, kCloseRadius = 2, kFillRadius = 3, kLargeFillRadius = 15;
constexpr int kBlurRadius = 2;
constexpr double kBilateralSigmaSpace = 2.0, kBilateralSigmaRange = 1.5;
// Upsampling: neighbouring cells within this ratio of depth are one surface.
constexpr double kSameSurfaceRatio = 1.05;

bool Known(float depth) { return depth > 0.f && std::isfinite(depth); }

// A [h, w] grid of inverted depths; 0 empty.
struct Grid {
  int w = 0, h = 0;
  std::vector<float> v;
  float at(int x, int y) const { return v[static_cast<size_t>(y) * w + x]; }
  float& at(int x, int y) { return v[static_cast<size_t>(y) * w + x]; }
};

void ForRows(int h, const std::function<void(int)>& row) {
  DefaultThreadPool().ParallelFor(0, h, 8, [&](int64_t y0, int64_t y1) {
    for (int64_t y = y0; y < y1; ++y) row(static_cast<int>(y));
  });
}

// Maximum (dilate) or minimum (erode) over the (2r + 1)^2 square around each
// cell, cells outside the grid left out; separable.
Grid SquareFilter(const Grid& in, int r, bool maximum) {
  auto pick = [maximum](float a, float b) { return maximum ? std::max(a, b) : std::min(a, b); };
  Grid rows = in;
  ForRows(in.h, [&](int y) {
    for (int x = 0; x < in.w; ++x) {
      float best = in.at(x, y);
      for (int dx = std::max(0, x - r); dx <= std::min(in.w - 1, x + r); ++dx) {
        best = pick(best, in.at(dx, y));
      }
      rows.at(x, y) = best;
    }
  });
  Grid out = rows;
  ForRows(in.h, [&](int y) {
    for (int x = 0; x < in.w; ++x) {
      float best = rows.at(x, y);
      for (int dy = std::max(0, y - r); dy <= std::min(in.h - 1, y + r); ++dy) {
        best = pick(best, rows.at(x, dy));
      }
      out.at(x, y) = best;
    }
  });
  return out;
}

// Maximum over the diamond |dx| + |dy| <= r.
Grid DiamondDilate(const Grid& in, int r) {
  Grid out = in;
  ForRows(in.h, [&](int y) {
    for (int x = 0; x < in.w; ++x) {
      float best = 0.f;
      for (int dy = -r; dy <= r; ++dy) {
        const int yy = y + dy;
        if (yy < 0 || yy >= in.h) continue;
        const int span = r - std::abs(dy);
        for (int xx = std::max(0, x - span); xx <= std::min(in.w - 1, x + span); ++xx) {
          best = std::max(best, in.at(xx, yy));
        }
      }
      out.at(x, y) = best;
    }
  });
  return out;
}

// Sets the empty cells of `grid` from `filled` (a dilation of it).
void FillEmpty(const Grid& filled, Grid* grid) {
  for (size_t i = 0; i < grid->v.size(); ++i) {
    if (grid->v[i] <= 0.f) grid->v[i] = filled.v[i];
  }
}

// The median of the non-empty cells of the (2r + 1)^2 window around each
// non-empty cell.
Grid MedianOfKnown(const Grid& in, int r) {
  Grid out = in;
  ForRows(in.h, [&](int y) {
    std::vector<float> window;
    window.reserve(static_cast<size_t>(2 * r + 1) * (2 * r + 1));
    for (int x = 0; x < in.w; ++x) {
      if (in.at(x, y) <= 0.f) continue;
      window.clear();
      for (int yy = std::max(0, y - r); yy <= std::min(in.h - 1, y + r); ++yy)
        for (int xx = std::max(0, x - r); xx <= std::min(in.w - 1, x + r); ++xx)
          if (in.at(xx, yy) > 0.f) window.push_back(in.at(xx, yy));
      auto middle = window.begin() + window.size() / 2;
      std::nth_element(window.begin(), middle, window.end());
      out.at(x, y) = *middle;
    }
  });
  return out;
}

// The bilateral filter over the non-empty cells of the (2r + 1)^2 window
// around each non-empty cell.
Grid BilateralOfKnown(const Grid& in, int r, double sigma_space, double sigma_range) {
  Grid out = in;
  std::vector<double> spatial(static_cast<size_t>(2 * r + 1) * (2 * r + 1));
  for (int dy = -r; dy <= r; ++dy)
    for (int dx = -r; dx <= r; ++dx)
      spatial[(dy + r) * (2 * r + 1) + dx + r] =
          std::exp(-(dx * dx + dy * dy) / (2 * sigma_space * sigma_space));
  const double range_scale = -1.0 / (2 * sigma_range * sigma_range);
  ForRows(in.h, [&](int y) {
    for (int x = 0; x < in.w; ++x) {
      const float centre = in.at(x, y);
      if (centre <= 0.f) continue;
      double sum = 0, weights = 0;
      for (int yy = std::max(0, y - r); yy <= std::min(in.h - 1, y + r); ++yy)
        for (int xx = std::max(0, x - r); xx <= std::min(in.w - 1, x + r); ++xx) {
          const float v = in.at(xx, yy);
          if (v <= 0.f) continue;
          const double diff = v - centre;
          const double weight = spatial[(yy - y + r) * (2 * r + 1) + xx - x + r] *
                                std::exp(diff * diff * range_scale);
          sum += weight * v;
          weights += weight;
        }
      out.at(x, y) = static_cast<float>(sum / weights);
    }
  });
  return out;
}

// Extends each column's topmost non-empty value up to row 0.
void ExtendTopValuesUp(Grid* grid) {
  for (int x = 0; x < grid->w; ++x) {
    int top = 0;
    while (top < grid->h && grid->at(x, top) <= 0.f) ++top;
    if (top == grid->h) continue;
    for (int y = 0; y < top; ++y) grid->at(x, y) = grid->at(x, top);
  }
}

// Returns the depth at pixel (x, y) of the dense grid `depth` (cells of
// `scale` pixels, 0 unknown): bilinear between the four nearest cell centres
// when the known ones lie within kSameSurfaceRatio of each other, else the
// pixel's own cell.
float Upsample(const Grid& depth, int scale, int x, int y) {
  const double gx = (x + 0.5) / scale - 0.5, gy = (y + 0.5) / scale - 0.5;
  const int x0 = std::clamp(static_cast<int>(std::floor(gx)), 0, depth.w - 1);
  const int y0 = std::clamp(static_cast<int>(std::floor(gy)), 0, depth.h - 1);
  const int x1 = std::min(x0 + 1, depth.w - 1), y1 = std::min(y0 + 1, depth.h - 1);
  const double fx = std::clamp(gx - x0, 0.0, 1.0), fy = std::clamp(gy - y0, 0.0, 1.0);
  const std::array<float, 4> v = {depth.at(x0, y0), depth.at(x1, y0), depth.at(x0, y1),
                                  depth.at(x1, y1)};
  const std::array<double, 4> w = {(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy};
  float lo = 0.f, hi = 0.f;
  double sum = 0, weights = 0;
  for (int k = 0; k < 4; ++k) {
    if (v[k] <= 0.f) continue;
    lo = lo == 0.f ? v[k] : std::min(lo, v[k]);
    hi = std::max(hi, v[k]);
    sum += w[k] * v[k];
    weights += w[k];
  }
  if (hi > 0.f && hi <= kSameSurfaceRatio * lo && weights > 0) {
    return static_cast<float>(sum / weights);
  }
  return depth.at(std::min(x / scale, depth.w - 1), std::min(y / scale, depth.h - 1));
}

}  // namespace

int IpBasicScale(const ImageF& sparse) {
  int64_t measured = 0;
  int top = sparse.height, bottom = -1;
  for (int y = 0; y < sparse.height; ++y)
    for (int x = 0; x < sparse.width; ++x)
      if (Known(sparse.at(x, y))) {
        ++measured;
        top = std::min(top, y);
        bottom = y;
      }
  if (measured == 0) return 1;
  const double density = double(measured) / (double(bottom - top + 1) * sparse.width);
  const long scale = std::lround(std::sqrt(kIpBasicDensity / density));
  return static_cast<int>(std::clamp<long>(scale, 1, kMaxIpBasicScale));
}

ImageF CompleteDepthIpBasic(const ImageF& sparse, const IpBasicOptions& options) {
  const int width = sparse.width, height = sparse.height;
  ImageF dense(width, height, 1);
  float deepest = 0.f;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
      if (Known(sparse.at(x, y))) deepest = std::max(deepest, sparse.at(x, y));
  if (deepest == 0.f) return dense;
  const int scale = options.scale > 0 ? options.scale : IpBasicScale(sparse);
  const float inverted_max = deepest + 1.f;

  // 1. The working grid of inverted depths: each cell its nearest measurement.
  Grid grid;
  grid.w = (width + scale - 1) / scale;
  grid.h = (height + scale - 1) / scale;
  grid.v.assign(static_cast<size_t>(grid.w) * grid.h, 0.f);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const float d = sparse.at(x, y);
      if (!Known(d)) continue;
      float& cell = grid.at(x / scale, y / scale);
      cell = std::max(cell, inverted_max - d);
    }

  // 2-5. Dilation, closing, small and large fills.
  grid = DiamondDilate(grid, kDiamondRadius);
  grid = SquareFilter(SquareFilter(grid, kCloseRadius, true), kCloseRadius, false);
  FillEmpty(SquareFilter(grid, kFillRadius, true), &grid);
  if (options.extrapolate) {
    ExtendTopValuesUp(&grid);
    FillEmpty(SquareFilter(grid, kLargeFillRadius, true), &grid);
  }
  // 6-7. Smoothing.
  grid = MedianOfKnown(grid, kBlurRadius);
  grid = BilateralOfKnown(grid, kBlurRadius, kBilateralSigmaSpace, kBilateralSigmaRange);

  // 8. Invert back and upsample.
  for (float& v : grid.v) v = v > 0.f ? std::max(inverted_max - v, 1e-3f) : 0.f;
  if (scale == 1) {
    dense.pixels = std::move(grid.v);
    return dense;
  }
  ForRows(height, [&](int y) {
    for (int x = 0; x < width; ++x) dense.at(x, y) = Upsample(grid, scale, x, y);
  });
  return dense;
}

bool IsSparseDepth(const ImageF& depth) {
  const int w = depth.width, h = depth.height;
  int64_t known = 0, solid = 0;
  auto known_at = [&](int x, int y) {
    return x < 0 || y < 0 || x >= w || y >= h || Known(depth.at(x, y));
  };
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      if (!Known(depth.at(x, y))) continue;
      ++known;
      solid += known_at(x - 1, y) && known_at(x + 1, y) && known_at(x, y - 1) && known_at(x, y + 1);
    }
  return known > 0 && 2 * solid < known;
}

DepthErrors MeasureDepthCompletion(const ImageF& dense, const ImageF& held_out) {
  DepthErrors e;
  double abs_rel = 0, squared = 0;
  int64_t within = 0;
  const size_t n = std::min(dense.pixels.size(), held_out.pixels.size());
  for (size_t i = 0; i < n; ++i) {
    const float truth = held_out.pixels[i];
    if (!Known(truth)) continue;
    const float d = dense.pixels[i];
    if (!Known(d)) {
      ++e.missing;
      continue;
    }
    const double error = std::abs(double(d) - truth);
    abs_rel += error / truth;
    squared += error * error;
    within += error < 0.05 * truth;
    ++e.points;
  }
  if (e.points > 0) {
    e.abs_rel = abs_rel / e.points;
    e.rmse = std::sqrt(squared / e.points);
    e.within_5pct = double(within) / e.points;
  }
  return e;
}

}  // namespace pf
