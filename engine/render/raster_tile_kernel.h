// The tile compositing kernel, written once over W float lanes with GCC/Clang
// vector extensions; raster_tile_baseline.cc, raster_tile_avx2.cc and
// raster_tile_avx512.cc instantiate it with W = 4, 8 and 16 under their own
// compiler flags; compositing_weights_tile.h records the colour fit's weights
// with its lanes, W = 4 at the baseline's flags and 8 at AVX2's
// (compositing_weights.cc, compositing_weights_avx2.cc). Include only from such files
// (no -ffp-contract other than off where FMA is enabled): everything here
// has internal linkage so the builds never mix.
//
// Per Gaussian and tile row, only the W-pixel groups that cover the
// ellipse's span are visited; lanes outside the span or whose pixel is done
// (transmittance < 1e-4) are masked. The lanes compute exactly what the
// scalar specification says, in the same order, so both builds give the same
// bits.
#ifndef POINTFORWARD_ENGINE_RENDER_RASTER_TILE_KERNEL_H_
#define POINTFORWARD_ENGINE_RENDER_RASTER_TILE_KERNEL_H_

#include <algorithm>
#include <cmath>
#include <cstring>

#if defined(__SSE2__)
#include <immintrin.h>
#endif

#include "engine/render/raster_tile.h"

namespace pf::raster {
namespace {

constexpr float kMinusHalfLog2e = -0.72134752044448170f;  // exp(-d2/2) = 2^(d2 * this).

template <int W>
struct Lanes {
  typedef float F __attribute__((vector_size(sizeof(float) * W)));
  typedef int32_t I __attribute__((vector_size(sizeof(int32_t) * W)));
};

template <typename V>
inline V Load(const void* p) {
  V v;
  std::memcpy(&v, p, sizeof(V));
  return v;
}
template <typename V>
inline void Store(void* p, const V& v) {
  std::memcpy(p, &v, sizeof(V));
}

// Returns a bit per lane of mask `m` (lanes 0 or -1).
template <int W>
inline unsigned MoveMask(typename Lanes<W>::I m) {
#if defined(__AVX512F__)
  if constexpr (W == 16) {
    return _mm512_cmpneq_epi32_mask(reinterpret_cast<__m512i>(m), _mm512_setzero_si512());
  }
#endif
#if defined(__AVX2__)
  if constexpr (W == 8) return _mm256_movemask_ps(reinterpret_cast<__m256>(m));
#endif
#if defined(__SSE2__)
  if constexpr (W == 4) return _mm_movemask_ps(reinterpret_cast<__m128>(m));
#endif
  unsigned bits = 0;
  for (int l = 0; l < W; ++l) bits |= (m[l] != 0 ? 1u : 0u) << l;
  return bits;
}

// Returns 2^x for x <= 0: round-to-nearest by the 1.5 * 2^23 trick, then a
// degree-6 Taylor polynomial of 2^f on [-0.5, 0.5] (relative error under
// 2e-7, about float's own).
template <int W>
inline typename Lanes<W>::F FastExp2(typename Lanes<W>::F x) {
  using F = typename Lanes<W>::F;
  using I = typename Lanes<W>::I;
  constexpr float kRound = 12582912.f;  // 1.5 * 2^23.
  x = x < -126.f ? F{} - 126.f : x;
  const F shifted = x + kRound;
  const F n = shifted - kRound;
  const F f = x - n;
  // 2^f = e^(f ln 2): coefficients ln2^k / k!, in Estrin's scheme (shorter
  // dependency chains than Horner's).
  const F f2 = f * f;
  const F f4 = f2 * f2;
  const F a = 6.9314718055994531e-1f * f + 1.f;
  const F b = 5.5504108664821580e-2f * f + 2.4022650695910071e-1f;
  const F c = 1.3333558146428443e-3f * f + 9.6181291076284772e-3f;
  const F d = 1.5403530393381606e-4f * f2 + c;
  const F p = (f2 * b + a) + f4 * d;
  // The integer n sits in the low mantissa bits of `shifted`.
  I bits;
  std::memcpy(&bits, &shifted, sizeof(F));
  const I scale = (bits - 0x4B400000 + 127) << 23;
  F two_n;
  std::memcpy(&two_n, &scale, sizeof(F));
  return p * two_n;
}

// Lane-wise square root.
template <int W>
inline typename Lanes<W>::F Sqrt(typename Lanes<W>::F x) {
  using F = typename Lanes<W>::F;
#if defined(__AVX512F__)
  if constexpr (W == 16) return reinterpret_cast<F>(_mm512_sqrt_ps(reinterpret_cast<__m512>(x)));
#endif
#if defined(__AVX2__)
  if constexpr (W == 8) return reinterpret_cast<F>(_mm256_sqrt_ps(reinterpret_cast<__m256>(x)));
#endif
#if defined(__SSE2__)
  if constexpr (W == 4) return reinterpret_cast<F>(_mm_sqrt_ps(reinterpret_cast<__m128>(x)));
#endif
  for (int l = 0; l < W; ++l) x[l] = std::sqrt(x[l]);
  return x;
}

// Lane-wise floor and ceiling to integers (|x| < 2^31).
template <int W>
inline typename Lanes<W>::I Floor(typename Lanes<W>::F x) {
  using F = typename Lanes<W>::F;
  using I = typename Lanes<W>::I;
  const I n = __builtin_convertvector(x, I);       // Truncates.
  return n + (__builtin_convertvector(n, F) > x);  // -1 where truncation rounded up.
}
template <int W>
inline typename Lanes<W>::I Ceil(typename Lanes<W>::F x) {
  using F = typename Lanes<W>::F;
  using I = typename Lanes<W>::I;
  const I n = __builtin_convertvector(x, I);
  return n - (__builtin_convertvector(n, F) < x);
}

template <int W, int kFixedCount, bool kGradients>
inline void CompositeTileLanes(TileJob* job) {
  using F = typename Lanes<W>::F;
  using I = typename Lanes<W>::I;
  const int count = kFixedCount > 0 ? kFixedCount : job->count;
  float* trans = job->transmittance;
  float* acc = job->acc;
  float* acc_rgb = job->acc_rgb;
  float* acc_depth = job->acc_depth;
  float* best_weight = job->best_weight;
  uint32_t* best_owner = job->best_owner;
  std::fill(trans, trans + kTilePixels, 1.f);
  std::fill(acc, acc + static_cast<size_t>(count) * kChannelStride, 0.f);
  if (job->sh_rgb) std::fill(acc_rgb, acc_rgb + 3 * kChannelStride, 0.f);
  std::fill(acc_depth, acc_depth + kTilePixels, 0.f);
  std::fill(best_weight, best_weight + kTilePixels, 0.f);
  std::fill(best_owner, best_owner + kTilePixels, 0u);

  F lane;
  for (int l = 0; l < W; ++l) lane[l] = static_cast<float>(l);
  const int x_begin = job->x_begin, y_begin = job->y_begin;
  const int x_end = job->x_end, y_end = job->y_end;
  int active = (x_end - x_begin) * (y_end - y_begin);
  int64_t tested = 0, contributing = 0;
  const bool sh_rgb = job->sh_rgb;
  I done{};  // Pixels that finished during the current Gaussian, negated.

  constexpr size_t kPrefetch = 8;  // Indices are in depth order: hide the misses.
  for (size_t k = 0; k < std::min(kPrefetch, job->num_indices); ++k) {
    __builtin_prefetch(job->projected + job->indices[k]);
  }
  for (size_t k = 0; k < job->num_indices && active > 0; ++k) {
    if (k + kPrefetch < job->num_indices) {
      const uint32_t ahead = job->indices[k + kPrefetch];
      __builtin_prefetch(job->projected + ahead);
      __builtin_prefetch(job->features + static_cast<size_t>(ahead) * job->stride);
    }
    const uint32_t index = job->indices[k];
    const Projected& g = job->projected[index];
    const float* feat = job->features + static_cast<size_t>(index) * job->stride;
    const float* grad = kGradients ? job->gradients + static_cast<size_t>(index) * 6 : nullptr;
    const float ca = g.ca, cb = g.cb, cc = g.cc;
    const float det = ca * cc - cb * cb;
    const float inv_ca = 1.f / ca;
    alignas(32) int32_t span_begin[kTile + W], span_end[kTile + W];
    const int row0 = std::max(y_begin, static_cast<int>(std::ceil(g.my - g.ext_y - 0.5f)));
    const int row1 = std::min(y_end - 1, static_cast<int>(std::floor(g.my + g.ext_y - 0.5f)));
    const F opacity = F{} + g.opacity;
    const F depth = F{} + g.depth;
    const I owner = I{} + static_cast<int32_t>(g.owner);
    // The ellipse's pixel span on each row, computed W rows at a time.
    for (int r = row0; r <= row1; r += W) {
      const F dy = (lane + static_cast<float>(r) + 0.5f) - g.my;
      const F disc = ca * g.span_d2 - det * dy * dy;
      const F root = Sqrt<W>(disc > 0.f ? disc : F{});
      const F mid = g.mx - 0.5f - cb * dy * inv_ca;
      const F half = root * inv_ca;
      const F lo_x = mid - half, hi_x = mid + half;
      constexpr float kFar = 1e9f;  // Keeps the integer conversion in range.
      const I lo = Ceil<W>(lo_x > -kFar ? lo_x : F{} - kFar);
      const I hi = Floor<W>(hi_x < kFar ? hi_x : F{} + kFar);
      Store(span_begin + (r - row0), disc >= 0.f ? lo : I{} + (1 << 30));
      Store(span_end + (r - row0), hi);
    }
    for (int row = row0; row <= row1; ++row) {
      const float dy = row + 0.5f - g.my;
      const int col0 = std::max(x_begin, span_begin[row - row0]);
      const int col1 = std::min(x_end - 1, span_end[row - row0]);
      if (col0 > col1) continue;
      const float row_term = cc * dy * dy;
      const float cross = 2.f * cb * dy;
      const float lx0 = static_cast<float>(col0 - x_begin);
      const float lx1 = static_cast<float>(col1 - x_begin);
      const float dx_origin = x_begin + 0.5f - g.mx;  // dx at tile column 0.
      const int row_base = (row - y_begin) * kTile;
      // Groups start at the span's first pixel, so a span of up to W pixels
      // takes one group. Lanes past the row end are masked (they read and
      // write back pixels of the next row, or the buffers' padding).
      for (int gx = col0 - x_begin; gx <= col1 - x_begin; gx += W) {
        const int p = row_base + gx;
        const F lx = lane + static_cast<float>(gx);
        const F t = Load<F>(trans + p);
        const I live = (lx >= lx0) & (lx <= lx1) & (t >= kMinTransmittance);
        if (MoveMask<W>(live) == 0) continue;
        const F dx = lx + dx_origin;
        const F d2 = ca * dx * dx + cross * dx + row_term;
        F alpha = opacity * FastExp2<W>(d2 * kMinusHalfLog2e);
        alpha = alpha < kMaxAlpha ? alpha : F{} + kMaxAlpha;
        const I blend = live & (alpha >= kMinAlpha);
        const unsigned live_bits = MoveMask<W>(live);
        const unsigned blend_bits = MoveMask<W>(blend);
        tested += __builtin_popcount(live_bits);
        if (blend_bits == 0) continue;
        contributing += __builtin_popcount(blend_bits);
        F weight = alpha * t;
        weight = blend ? weight : F{};
        int c = 0;
        if constexpr (kGradients) {
          for (; c < 3; ++c) {
            float* a = acc + c * kChannelStride + p;
            const F value = (feat[c] + grad[2 * c + 1] * dy) + grad[2 * c] * dx;
            Store(a, Load<F>(a) + weight * value);
          }
        }
        for (; c < count; ++c) {
          float* a = acc + c * kChannelStride + p;
          Store(a, Load<F>(a) + weight * feat[c]);
        }
        if (sh_rgb) {
          for (int c = 0; c < 3; ++c) {
            float* a = acc_rgb + c * kChannelStride + p;
            Store(a, Load<F>(a) + weight * g.rgb[c]);
          }
        }
        Store(acc_depth + p, Load<F>(acc_depth + p) + weight * depth);
        const F best = Load<F>(best_weight + p);
        const I better = weight > best;
        Store(best_weight + p, better ? weight : best);
        Store(best_owner + p, better ? owner : Load<I>(best_owner + p));
        const F t_next = blend ? t * (1.f - alpha) : t;
        Store(trans + p, t_next);
        done += blend & (t_next < kMinTransmittance);  // -1 per newly done pixel.
      }
    }
    for (int l = 0; l < W; ++l) active += done[l];
    done = I{};
  }
  job->tested = tested;
  job->contributing = contributing;
}

// The blend peak (raster_tile.h): for each W-pixel group of the tile, every
// Gaussian blended in turn, transmittance and RGB held in registers.
template <int W>
inline void BlendPeakTileFor(const PeakGaussian* gaussians, int count, float* out) {
  using F = typename Lanes<W>::F;
  F lane;
  for (int l = 0; l < W; ++l) lane[l] = static_cast<float>(l);
  for (int row = 0; row < kTile; ++row) {
    const float y = row + 0.5f;
    for (int gx = 0; gx < kTile; gx += W) {
      const F x = lane + static_cast<float>(gx) + 0.5f;
      F t = F{} + 1.f, r{}, g{}, b{};
      for (int k = 0; k < count; ++k) {
        const PeakGaussian& p = gaussians[k];
        const F dx = x - p.mx;
        const float dy = y - p.my;
        const F d2 = p.ca * dx * dx + (2.f * p.cb * dy) * dx + p.cc * dy * dy;
        F alpha = p.opacity * FastExp2<W>(d2 * kMinusHalfLog2e);
        alpha = alpha < kMaxAlpha ? alpha : F{} + kMaxAlpha;
        const F weight = alpha * t;
        r += weight * p.rgb[0];
        g += weight * p.rgb[1];
        b += weight * p.rgb[2];
        t = t * (1.f - alpha);
      }
      const int at = row * kTile + gx;
      Store(out + at, t);
      Store(out + kTilePixels + at, r);
      Store(out + 2 * kTilePixels + at, g);
      Store(out + 3 * kTilePixels + at, b);
    }
  }
}

// Dispatches on colour gradients and the channel count (3 is the common
// case, fixed at compile time).
template <int W>
inline void CompositeTileFor(TileJob* job) {
  if (job->gradients != nullptr) {
    if (job->count == 3) {
      CompositeTileLanes<W, 3, true>(job);
    } else {
      CompositeTileLanes<W, 0, true>(job);
    }
  } else if (job->count == 3) {
    CompositeTileLanes<W, 3, false>(job);
  } else if (job->count == 32) {
    CompositeTileLanes<W, 32, false>(job);
  } else {
    CompositeTileLanes<W, 0, false>(job);
  }
}

}  // namespace
}  // namespace pf::raster

#endif  // POINTFORWARD_ENGINE_RENDER_RASTER_TILE_KERNEL_H_
