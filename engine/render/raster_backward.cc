// The rasterizer's backward pass (raster_backward.h).
//
// The passes:
//  1. Project every Gaussian (in T: float for RenderBackward, double for the
//     checks), keeping its screen-space record.
//  2. Sort the visible ones by float depth, ties by index, and bin them into
//     the tiles VisitTiles gives (tile_binning.h): Render()'s tile lists.
//  3. Per tile (in parallel): front to back, Gaussian by Gaussian over the
//     pixels each can reach, keeping every pixel's contributions; then pixel
//     by pixel back to front, adding each pair's screen-space gradient into
//     the pair's slot.
//  4. Sum the slots per Gaussian in tile order, then differentiate each
//     Gaussian's projection (in parallel). The projection is run again
//     there rather than kept from pass 1: its tape is some 60 numbers a
//     Gaussian, and pass 1 keeps only the screen-space record.
#include "engine/render/raster_backward.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <type_traits>

#include "absl/strings/str_cat.h"
#include "common/thread_pool.h"
#include "engine/render/raster_frame.h"
#include "engine/render/raster_tile.h"
#include "engine/render/splat_projection.h"
#include "engine/render/tile_binning.h"

namespace pf {
namespace {

using raster::kMaxAlpha;
using raster::kMinAlpha;
using raster::kMinTransmittance;
using raster::kTile;
using raster::kTilePixels;
using raster::RenderFrame;

// The parameters a pass reads, in T.
template <typename T>
struct ParamView {
  const T* means;
  const T* rotations;
  const T* log_scales;
  const T* opacity_logits;
  const T* features;
  const T* colour_gradients;  // Null for flat colours.
};

// The view of arrays named as GaussianScene's (a scene, or GaussianParams).
template <typename T, typename Arrays>
ParamView<T> ViewOf(const Arrays& a) {
  return {a.means.data(),      a.rotations.data(),
          a.log_scales.data(), a.opacity_logits.data(),
          a.features.data(),   a.colour_gradients.empty() ? nullptr : a.colour_gradients.data()};
}

// Step of the central differences that give the distortion Jacobian's own
// derivative (the Jacobian itself uses the forward's 1e-6).
constexpr double kJacobianStep = 1e-4;

// One Gaussian's projection, and what its derivative needs.
template <typename T>
struct Tape {
  // Screen-space record (what compositing reads).
  T mx, my, ca, cb, cc, opacity, depth, ux, uy, vx, vy;
  float span_d2, ext_x, ext_y;
  // Intermediates.
  T sig, fade;
  T r[9];  // Camera-from-owner rotation (row-major).
  T xn, yn, tx, ty, inv_z;
  bool free_x, free_y;  // The Jacobian's point is not clamped.
  T d[4];               // Distortion Jacobian (row-major 2x2).
  T j[6];               // EWA Jacobian D [1/z 0 -tx/z; 0 1/z -ty/z] (2x3).
  T a[6];               // J R (2x3).
  T g[9];               // Rotation of the normalised quaternion.
  T q[4];               // Normalised quaternion.
  T q_norm;
  T s[3];    // Scales.
  T m[6];    // A G (2x3).
  T b[6];    // A G S (2x3).
  T cov[3];  // xx, xy, yy (with the low-pass).
  T det;
};

// The screen-space record of a Gaussian kept between the passes.
template <typename T>
struct ScreenSplat {
  T mx, my, ca, cb, cc, opacity, depth, ux, uy, vx, vy;
  float span_d2, ext_x, ext_y;
};

// Projects Gaussian `i` as ProjectSplat does, in T; false when it cannot be
// seen.
template <typename T>
bool ProjectWithTape(const GaussianScene& scene, const ParamView<T>& p, size_t i,
                     const RenderFrame& frame, Tape<T>* t) {
  const uint32_t owner = scene.owners[i];
  if (!frame.owner_live[owner]) return false;
  const raster::Transform& cam = frame.camera_from_owner[owner];
  T* r = t->r;
  T tr[3];
  for (int k = 0; k < 9; ++k) r[k] = cam.r[k];
  for (int k = 0; k < 3; ++k) tr[k] = cam.t[k];

  t->sig = T(1) / (T(1) + std::exp(-p.opacity_logits[i]));
  t->fade = 1;
  const float sigma = scene.lifespans[i];
  if (!std::isinf(sigma)) {
    const T u = (T(frame.render_time_s) - T(scene.times[i])) / (T(sigma) + T(1));
    t->fade = std::exp(T(-0.5) * u * u);
  }
  t->opacity = t->sig * t->fade;
  if (!(t->opacity >= T(kMinAlpha))) return false;

  const T* m = &p.means[3 * i];
  const T px = r[0] * m[0] + r[1] * m[1] + r[2] * m[2] + tr[0];
  const T py = r[3] * m[0] + r[4] * m[1] + r[5] * m[2] + tr[1];
  const T pz = r[6] * m[0] + r[7] * m[1] + r[8] * m[2] + tr[2];
  if (!(pz >= T(frame.near_plane))) return false;
  t->depth = pz;
  t->inv_z = T(1) / pz;
  t->xn = px * t->inv_z;
  t->yn = py * t->inv_z;
  t->tx = std::clamp(t->xn, T(frame.x_lo), T(frame.x_hi));
  t->ty = std::clamp(t->yn, T(frame.y_lo), T(frame.y_hi));
  t->free_x = t->tx == t->xn;
  t->free_y = t->ty == t->yn;
  const Lens& lens = frame.lens;
  if (lens.kind == Lens::kPinhole) {
    t->mx = T(frame.fx) * t->xn + T(frame.cx);
    t->my = T(frame.fy) * t->yn + T(frame.cy);
    t->d[0] = frame.fx;
    t->d[1] = t->d[2] = 0;
    t->d[3] = frame.fy;
  } else {
    double u, v;
    if (!LensProject(lens, px, py, pz, &u, &v)) return false;
    t->mx = u;
    t->my = v;
    double d[4];
    LensJacobian(lens, t->tx, t->ty, d);
    for (int k = 0; k < 4; ++k) t->d[k] = d[k];
  }
  const T* d = t->d;
  const T iz = t->inv_z;
  T* j = t->j;
  j[0] = d[0] * iz, j[1] = d[1] * iz, j[2] = -(d[0] * t->tx + d[1] * t->ty) * iz;
  j[3] = d[2] * iz, j[4] = d[3] * iz, j[5] = -(d[2] * t->tx + d[3] * t->ty) * iz;
  for (int row = 0; row < 2; ++row) {
    for (int col = 0; col < 3; ++col) {
      t->a[3 * row + col] =
          j[3 * row] * r[col] + j[3 * row + 1] * r[3 + col] + j[3 * row + 2] * r[6 + col];
    }
  }
  const T* q = &p.rotations[4 * i];
  const T qn = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3];
  if (!(qn > 0)) return false;
  t->q_norm = std::sqrt(qn);
  for (int k = 0; k < 4; ++k) t->q[k] = q[k] / t->q_norm;
  const T w = t->q[0], x = t->q[1], y = t->q[2], z = t->q[3];
  T* g = t->g;
  g[0] = 1 - 2 * (y * y + z * z), g[1] = 2 * (x * y - w * z), g[2] = 2 * (x * z + w * y);
  g[3] = 2 * (x * y + w * z), g[4] = 1 - 2 * (x * x + z * z), g[5] = 2 * (y * z - w * x);
  g[6] = 2 * (x * z - w * y), g[7] = 2 * (y * z + w * x), g[8] = 1 - 2 * (x * x + y * y);
  for (int k = 0; k < 3; ++k) t->s[k] = std::exp(p.log_scales[3 * i + k]);
  for (int row = 0; row < 2; ++row) {
    for (int col = 0; col < 3; ++col) {
      const T* a = &t->a[3 * row];
      t->m[3 * row + col] = a[0] * g[col] + a[1] * g[3 + col] + a[2] * g[6 + col];
      t->b[3 * row + col] = t->m[3 * row + col] * t->s[col];
    }
  }
  const T* b = t->b;
  const T low_pass = scene.low_pass;
  t->cov[0] = b[0] * b[0] + b[1] * b[1] + b[2] * b[2] + low_pass;
  t->cov[1] = b[0] * b[3] + b[1] * b[4] + b[2] * b[5];
  t->cov[2] = b[3] * b[3] + b[4] * b[4] + b[5] * b[5] + low_pass;
  t->det = t->cov[0] * t->cov[2] - t->cov[1] * t->cov[1];
  if (!(t->det > 0)) return false;
  const float opacity = static_cast<float>(t->opacity);
  const float d2_max = 2.f * std::log(opacity * 255.f) * raster::kExtentMargin + 1e-4f;
  const float ext_x = std::sqrt(d2_max * static_cast<float>(t->cov[0]));
  const float ext_y = std::sqrt(d2_max * static_cast<float>(t->cov[2]));
  const float mx = static_cast<float>(t->mx), my = static_cast<float>(t->my);
  if (mx + ext_x < 0 || mx - ext_x > frame.width || my + ext_y < 0 || my - ext_y > frame.height ||
      !std::isfinite(mx) || !std::isfinite(my)) {
    return false;
  }
  t->span_d2 = d2_max;
  t->ext_x = ext_x;
  t->ext_y = ext_y;
  t->ca = t->cov[2] / t->det;
  t->cb = -t->cov[1] / t->det;
  t->cc = t->cov[0] / t->det;
  t->ux = b[0] * t->ca + b[3] * t->cb;
  t->uy = b[0] * t->cb + b[3] * t->cc;
  t->vx = b[1] * t->ca + b[4] * t->cb;
  t->vy = b[1] * t->cb + b[4] * t->cc;
  return true;
}

// Indices into a Gaussian's screen-space gradient: centre, conic, opacity,
// depth, then (after reduction) the colour-gradient frame.
enum Slot : int { kMx, kMy, kCa, kCb, kCc, kOpacity, kDepth, kGeometrySlots };

// Layout of one pair's slot: the geometry, then per value channel the sum of
// dL/dvalue, then (textured) per RGB channel the sums of dL/dvalue dx and dy.
struct SlotLayout {
  int channels = 3;       // Value channels with a gradient.
  bool textured = false;  // Colour gradients.
  int values() const { return kGeometrySlots; }
  int moments() const { return kGeometrySlots + channels; }
  int size() const { return kGeometrySlots + channels + (textured ? 6 : 0); }
};

// One blended pair of a pixel, front to back.
template <typename T>
struct Contribution {
  uint32_t k;  // Position in the tile's list.
  T alpha;     // Clamped.
  T trans;     // Transmittance in front of it.
  T gauss;     // exp(-d^2 / 2).
  bool clamped;
};

// What the tile pass reads.
template <typename T>
struct TilePass {
  const GaussianScene* scene;
  ParamView<T> params;
  const RenderFrame* frame;
  const ScreenSplat<T>* splats;  // [N]
  const OutputGradients<T>* grads;
  SlotLayout layout;
  // Forward outputs to fill (the double checks), or null; depth and
  // features only where sized (as RenderOptions asks).
  std::vector<T>*rgb_out, *alpha_out, *depth_out, *features_out;
};

// The value of channel c of Gaussian `i` at offset (dx, dy) from its centre.
template <typename T>
T ValueAt(const TilePass<T>& pass, size_t i, int c, T dx, T dy) {
  const int nc = pass.scene->num_channels;
  T value = pass.params.features[i * nc + c];
  if (c < 3 && pass.params.colour_gradients != nullptr) {
    const ScreenSplat<T>& s = pass.splats[i];
    const T* g = &pass.params.colour_gradients[6 * i + 2 * c];
    value += g[0] * (s.ux * dx + s.uy * dy) + g[1] * (s.vx * dx + s.vy * dy);
  }
  return value;
}

// The pixels of one tile row that splat `s` can reach: those whose centre
// satisfies d^2 <= span_d2 lie in [*x0, *x1], a pixel wider each side than
// the ellipse's chord (for rounding; the caller tests d^2 itself). False
// when none can.
template <typename T>
bool RowReach(const ScreenSplat<T>& s, double py, int x_begin, int x_end, int* x0, int* x1) {
  const double ca = s.ca, cb = s.cb, cc = s.cc, dy = py - double(s.my);
  const double disc = ca * double(s.span_d2) - (ca * cc - cb * cb) * dy * dy;
  const double half = std::sqrt(std::max(disc, 0.0)) / ca;
  const double mid = double(s.mx) - 0.5 - cb * dy / ca;  // Chord's middle, as a pixel index.
  if (!(mid + half + 1 >= x_begin && mid - half - 1 <= x_end - 1)) return false;
  *x0 = std::max(x_begin, static_cast<int>(std::floor(std::max(mid - half, -1e9))) - 1);
  *x1 = std::min(x_end - 1, static_cast<int>(std::ceil(std::min(mid + half, 1e9))) + 1);
  return *x0 <= *x1;
}

// Front to back, then back to front, over every pixel of tile (tx, ty) with
// its depth-ordered `list`; adds each pair's gradient into `slots`
// ([list size, layout.size()]). The front-to-back pass takes the list's
// Gaussians in order and visits only the rows and columns each can reach
// (RowReach); the back-to-front pass takes pixel by pixel, row by row, so
// each slot sums the same terms in the same order as a pass over every
// pixel and every Gaussian would.
template <typename T>
void BackwardTile(const TilePass<T>& pass, int tx, int ty, const uint32_t* list, size_t size,
                  T* slots, int64_t* contributing) {
  const RenderFrame& frame = *pass.frame;
  const GaussianScene& scene = *pass.scene;
  const int nc = scene.num_channels;
  const SlotLayout& layout = pass.layout;
  const int stride = layout.size();
  const int channels = layout.channels;
  const OutputGradients<T>& grads = *pass.grads;
  // Per pixel of the tile: its contributions front to back, transmittance,
  // weighted depth and (filling the forward) values.
  thread_local std::vector<Contribution<T>> contributions[kTilePixels];
  thread_local std::vector<T> out_values;
  T trans[kTilePixels], depth_sum[kTilePixels];
  const bool fill = pass.rgb_out != nullptr;
  if (fill) out_values.assign(static_cast<size_t>(kTilePixels) * nc, T(0));
  std::vector<T> g_value(channels);
  const int x_begin = tx * kTile, y_begin = ty * kTile;
  const int x_end = std::min(frame.width, x_begin + kTile);
  const int y_end = std::min(frame.height, y_begin + kTile);
  for (int p = 0; p < kTilePixels; ++p) {
    contributions[p].clear();
    trans[p] = 1;
    depth_sum[p] = 0;
  }

  // Front to back.
  int active = (x_end - x_begin) * (y_end - y_begin);  // Pixels not saturated.
  for (size_t k = 0; k < size && active > 0; ++k) {
    const uint32_t i = list[k];
    const ScreenSplat<T>& s = pass.splats[i];
    const double my = s.my, ext_y = s.ext_y;
    const int row0 =
        std::max(y_begin, static_cast<int>(std::floor(std::max(my - ext_y - 0.5, -1e9))) - 1);
    const int row1 =
        std::min(y_end - 1, static_cast<int>(std::ceil(std::min(my + ext_y - 0.5, 1e9))) + 1);
    for (int y = row0; y <= row1; ++y) {
      const T py = T(y) + T(0.5);
      int x0, x1;
      if (!RowReach(s, double(py), x_begin, x_end, &x0, &x1)) continue;
      for (int x = x0; x <= x1; ++x) {
        const int p = (y - y_begin) * kTile + (x - x_begin);
        if (trans[p] < T(kMinTransmittance)) continue;
        const T px = T(x) + T(0.5);
        const T dx = px - s.mx, dy = py - s.my;
        const T d2 = s.ca * dx * dx + T(2) * s.cb * dx * dy + s.cc * dy * dy;
        if (!(d2 <= T(s.span_d2))) continue;
        const T gauss = std::exp(T(-0.5) * d2);
        const T raw = s.opacity * gauss;
        const bool clamped = !(raw < T(kMaxAlpha));
        const T alpha = clamped ? T(kMaxAlpha) : raw;
        if (alpha < T(kMinAlpha)) continue;
        contributions[p].push_back({static_cast<uint32_t>(k), alpha, trans[p], gauss, clamped});
        const T w = alpha * trans[p];
        depth_sum[p] += w * s.depth;
        if (fill) {
          T* out = &out_values[static_cast<size_t>(p) * nc];
          for (int c = 0; c < nc; ++c) out[c] += w * ValueAt(pass, i, c, dx, dy);
        }
        trans[p] *= T(1) - alpha;
        if (trans[p] < T(kMinTransmittance)) --active;
      }
    }
  }

  for (int y = y_begin; y < y_end; ++y) {
    for (int x = x_begin; x < x_end; ++x) {
      const int p = (y - y_begin) * kTile + (x - x_begin);
      const size_t pixel = static_cast<size_t>(y) * frame.width + x;
      const T px = T(x) + T(0.5), py = T(y) + T(0.5);
      const std::vector<Contribution<T>>& pixel_contributions = contributions[p];
      *contributing += static_cast<int64_t>(pixel_contributions.size());
      const T alpha_out = T(1) - trans[p];
      if (fill) {
        const T* out = &out_values[static_cast<size_t>(p) * nc];
        (*pass.alpha_out)[pixel] = alpha_out;
        for (int c = 0; c < 3; ++c) (*pass.rgb_out)[3 * pixel + c] = out[c];
        if (!pass.features_out->empty()) {
          for (int c = 0; c < nc; ++c) (*pass.features_out)[pixel * nc + c] = out[c];
        }
        if (!pass.depth_out->empty()) {
          (*pass.depth_out)[pixel] = alpha_out > 0 ? depth_sum[p] / alpha_out : T(0);
        }
      }
      if (pixel_contributions.empty()) continue;

      // The upstream gradient of each value channel (rgb and features read
      // the same values), of the depth sum and of alpha.
      for (int c = 0; c < channels; ++c) {
        T g = 0;
        if (c < 3 && !grads.rgb.empty()) g += grads.rgb[3 * pixel + c];
        if (!grads.features.empty()) g += grads.features[pixel * nc + c];
        g_value[c] = g;
      }
      T g_alpha = grads.alpha.empty() ? T(0) : grads.alpha[pixel];
      T g_depth_sum = 0;
      if (!grads.depth.empty() && alpha_out > 0) {
        const T g_depth = grads.depth[pixel];
        g_depth_sum = g_depth / alpha_out;
        g_alpha -= g_depth * depth_sum[p] / (alpha_out * alpha_out);
      }

      // Back to front: `behind` is sum_{j behind} w_j (g . v_j + g_z z_j).
      T behind = 0;
      for (size_t r = pixel_contributions.size(); r-- > 0;) {
        const Contribution<T>& con = pixel_contributions[r];
        const uint32_t i = list[con.k];
        const ScreenSplat<T>& s = pass.splats[i];
        const T dx = px - s.mx, dy = py - s.my;
        const T w = con.alpha * con.trans;
        T own = g_depth_sum * s.depth;
        for (int c = 0; c < channels; ++c) own += g_value[c] * ValueAt(pass, i, c, dx, dy);
        T* slot = slots + static_cast<size_t>(con.k) * stride;
        for (int c = 0; c < channels; ++c) slot[layout.values() + c] += g_value[c] * w;
        if (layout.textured) {
          T* moment = slot + layout.moments();
          for (int c = 0; c < 3; ++c) {
            moment[2 * c] += g_value[c] * w * dx;
            moment[2 * c + 1] += g_value[c] * w * dy;
          }
        }
        slot[kDepth] += g_depth_sum * w;
        if (!con.clamped) {
          const T one_minus = T(1) - con.alpha;
          const T g_a = con.trans * own - behind / one_minus + g_alpha * trans[p] / one_minus;
          slot[kOpacity] += g_a * con.gauss;
          const T g_d2 = T(-0.5) * con.alpha * g_a;
          slot[kMx] -= g_d2 * T(2) * (s.ca * dx + s.cb * dy);
          slot[kMy] -= g_d2 * T(2) * (s.cb * dx + s.cc * dy);
          slot[kCa] += g_d2 * dx * dx;
          slot[kCb] += g_d2 * T(2) * dx * dy;
          slot[kCc] += g_d2 * dy * dy;
        }
        behind += w * own;
      }
    }
  }
}

// Differentiates Gaussian i's projection: `screen` is its screen-space
// gradient [kGeometrySlots] plus the frame's (ux, uy, vx, vy); adds into
// `out`'s rows of i.
template <typename T>
void BackwardProjection(const GaussianScene& scene, const ParamView<T>& params, size_t i,
                        const RenderFrame& frame, const T* screen, const T g_frame[4],
                        GaussianParams<T>* out) {
  Tape<T> t;
  if (!ProjectWithTape(scene, params, i, frame, &t)) return;
  const T* r = t.r;

  // Frame (ux, uy, vx, vy) = B^T conic, and the conic itself.
  T gb[6] = {0, 0, 0, 0, 0, 0};
  T g_ca = screen[kCa], g_cb = screen[kCb], g_cc = screen[kCc];
  const T* b = t.b;
  gb[0] += g_frame[0] * t.ca + g_frame[1] * t.cb;
  gb[3] += g_frame[0] * t.cb + g_frame[1] * t.cc;
  gb[1] += g_frame[2] * t.ca + g_frame[3] * t.cb;
  gb[4] += g_frame[2] * t.cb + g_frame[3] * t.cc;
  g_ca += g_frame[0] * b[0] + g_frame[2] * b[1];
  g_cb += g_frame[0] * b[3] + g_frame[1] * b[0] + g_frame[2] * b[4] + g_frame[3] * b[1];
  g_cc += g_frame[1] * b[3] + g_frame[3] * b[4];
  // Conic = inverse covariance.
  const T det = t.det;
  const T g_det = -(g_ca * t.cov[2] - g_cb * t.cov[1] + g_cc * t.cov[0]) / (det * det);
  const T g_xx = g_cc / det + g_det * t.cov[2];
  const T g_yy = g_ca / det + g_det * t.cov[0];
  const T g_xy = -g_cb / det - T(2) * g_det * t.cov[1];
  // Covariance = B B^T + low-pass.
  for (int k = 0; k < 3; ++k) {
    gb[k] += T(2) * g_xx * b[k] + g_xy * b[3 + k];
    gb[3 + k] += T(2) * g_yy * b[3 + k] + g_xy * b[k];
  }
  // B = (A G) S.
  T gm[6], ga[6] = {0, 0, 0, 0, 0, 0}, gg[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
  T* g_ls = &out->log_scales[3 * i];
  for (int col = 0; col < 3; ++col) {
    gm[col] = gb[col] * t.s[col];
    gm[3 + col] = gb[3 + col] * t.s[col];
    g_ls[col] += (gb[col] * t.m[col] + gb[3 + col] * t.m[3 + col]) * t.s[col];
  }
  for (int row = 0; row < 2; ++row) {
    for (int jj = 0; jj < 3; ++jj) {
      for (int col = 0; col < 3; ++col) {
        ga[3 * row + jj] += gm[3 * row + col] * t.g[3 * jj + col];
        gg[3 * jj + col] += t.a[3 * row + jj] * gm[3 * row + col];
      }
    }
  }
  // Rotation matrix of the normalised quaternion, then the normalisation.
  const T w = t.q[0], x = t.q[1], y = t.q[2], z = t.q[3];
  T gq[4];
  gq[0] = 2 * (-z * gg[1] + y * gg[2] + z * gg[3] - x * gg[5] - y * gg[6] + x * gg[7]);
  gq[1] = 2 * (y * gg[1] + z * gg[2] + y * gg[3] - w * gg[5] + z * gg[6] + w * gg[7]) -
          4 * x * (gg[4] + gg[8]);
  gq[2] = 2 * (x * gg[1] + w * gg[2] + x * gg[3] + z * gg[5] - w * gg[6] + z * gg[7]) -
          4 * y * (gg[0] + gg[8]);
  gq[3] = 2 * (-w * gg[1] + x * gg[2] + w * gg[3] + y * gg[5] + x * gg[6] + y * gg[7]) -
          4 * z * (gg[0] + gg[4]);
  const T dot = gq[0] * w + gq[1] * x + gq[2] * y + gq[3] * z;
  for (int k = 0; k < 4; ++k) out->rotations[4 * i + k] += (gq[k] - t.q[k] * dot) / t.q_norm;

  // A = J R; J = D [1/z 0 -tx/z; 0 1/z -ty/z].
  T gj[6];
  for (int row = 0; row < 2; ++row) {
    for (int ii = 0; ii < 3; ++ii) {
      gj[3 * row + ii] = ga[3 * row] * r[3 * ii] + ga[3 * row + 1] * r[3 * ii + 1] +
                         ga[3 * row + 2] * r[3 * ii + 2];
    }
  }
  const T* d = t.d;
  const T* j = t.j;
  const T iz = t.inv_z;
  T g_z = screen[kDepth];
  for (int k = 0; k < 6; ++k) g_z -= gj[k] * j[k] * iz;
  T gd[4] = {(gj[0] - gj[2] * t.tx) * iz, (gj[1] - gj[2] * t.ty) * iz, (gj[3] - gj[5] * t.tx) * iz,
             (gj[4] - gj[5] * t.ty) * iz};
  T g_tx = -(gj[2] * d[0] + gj[5] * d[2]) * iz;
  T g_ty = -(gj[2] * d[1] + gj[5] * d[3]) * iz;
  T g_xn = 0, g_yn = 0;
  const Lens& lens = frame.lens;
  if (lens.kind != Lens::kPinhole) {
    // The Jacobian moves with the point it is taken at.
    const double h = kJacobianStep;
    double dp[4], dm[4];
    LensJacobian(lens, t.tx + h, t.ty, dp);
    LensJacobian(lens, t.tx - h, t.ty, dm);
    for (int k = 0; k < 4; ++k) g_tx += gd[k] * T((dp[k] - dm[k]) / (2 * h));
    LensJacobian(lens, t.tx, t.ty + h, dp);
    LensJacobian(lens, t.tx, t.ty - h, dm);
    for (int k = 0; k < 4; ++k) g_ty += gd[k] * T((dp[k] - dm[k]) / (2 * h));
  }
  if (t.free_x) g_xn += g_tx;
  if (t.free_y) g_yn += g_ty;
  // Centre: through D (the projection's Jacobian at the mean).
  g_xn += d[0] * screen[kMx] + d[2] * screen[kMy];
  g_yn += d[1] * screen[kMx] + d[3] * screen[kMy];
  // Normalised coordinates of the camera-frame point.
  const T g_px = g_xn * iz, g_py = g_yn * iz;
  g_z -= (g_xn * t.xn + g_yn * t.yn) * iz;
  T* g_mean = &out->means[3 * i];
  for (int k = 0; k < 3; ++k) g_mean[k] += r[k] * g_px + r[3 + k] * g_py + r[6 + k] * g_z;
  // Opacity = sigmoid(logit) * fade.
  out->opacity_logits[i] += screen[kOpacity] * t.fade * t.sig * (T(1) - t.sig);
}

// Resizes every array of `g` to the scene's sizes, zeroed.
template <typename T>
void ZeroParams(const GaussianScene& scene, GaussianParams<T>* g) {
  const size_t n = scene.size();
  g->means.assign(3 * n, T(0));
  g->rotations.assign(4 * n, T(0));
  g->log_scales.assign(3 * n, T(0));
  g->opacity_logits.assign(n, T(0));
  g->features.assign(n * scene.num_channels, T(0));
  if (scene.has_colour_gradients()) g->colour_gradients.assign(6 * n, T(0));
}

absl::Status CheckGradientSize(const char* name, size_t actual, size_t expected, bool allowed,
                               const char* needs) {
  if (actual == 0) return absl::OkStatus();
  if (!allowed) {
    return absl::InvalidArgumentError(absl::StrCat("grads.", name, ": given, but ", needs));
  }
  if (actual != expected) {
    return absl::InvalidArgumentError(
        absl::StrCat("grads.", name, ": has ", actual, " values, expected ", expected));
  }
  return absl::OkStatus();
}

// The whole backward pass in T. `forward` (optional) receives the render.
template <typename T>
absl::StatusOr<GaussianParams<T>> Backward(const GaussianScene& scene, const ParamView<T>& params,
                                           const RenderCamera& camera, int64_t timestamp_us,
                                           const std::vector<ActorEdit>& edits,
                                           const OutputGradients<T>& grads,
                                           const RenderOptions& options, BackwardStats* stats,
                                           testing::DoubleRender* forward,
                                           ScreenGradients* screen_out) {
  if (camera.rolling_shutter.has_value()) {
    return absl::InvalidArgumentError(
        "camera: the backward pass has no rolling shutter; optimise global-shutter views only");
  }
  RenderFrame frame;
  if (absl::Status status =
          raster::SetUpRenderFrame(scene.instances, scene.time_origin_us, scene.fade_span, camera,
                                   timestamp_us, edits, options.near_plane, &frame);
      !status.ok()) {
    return status;
  }
  if (absl::Status status = CheckRenderable(scene); !status.ok()) return status;
  if (scene.sh_degree >= 0) {
    return absl::InvalidArgumentError(
        absl::StrCat("scene.sh_degree: ", scene.sh_degree,
                     " but the backward pass takes colour from the features (sh_degree -1)"));
  }
  const size_t pixels = static_cast<size_t>(frame.width) * frame.height;
  const int nc = scene.num_channels;
  for (const absl::Status& s :
       {CheckGradientSize("rgb", grads.rgb.size(), 3 * pixels, true, ""),
        CheckGradientSize("alpha", grads.alpha.size(), pixels, true, ""),
        CheckGradientSize("depth", grads.depth.size(), pixels, options.depth,
                          "the render has no depth (RenderOptions::depth)"),
        CheckGradientSize("features", grads.features.size(), pixels * nc, options.features,
                          "the render has no features (RenderOptions::features)")}) {
    if (!s.ok()) return s;
  }

  // 1. Project.
  const size_t n = scene.size();
  std::vector<ScreenSplat<T>> splats(n);
  std::vector<uint8_t> visible(n, 0);
  ThreadPool& pool = DefaultThreadPool();
  constexpr int64_t kChunk = 4096;
  pool.ParallelFor(0, static_cast<int64_t>((n + kChunk - 1) / kChunk), 1,
                   [&](int64_t c0, int64_t c1) {
                     for (size_t i = c0 * kChunk; i < std::min(n, size_t(c1) * kChunk); ++i) {
                       Tape<T> t;
                       if (!ProjectWithTape(scene, params, i, frame, &t)) continue;
                       visible[i] = 1;
                       splats[i] = {t.mx, t.my, t.ca, t.cb, t.cc,      t.opacity, t.depth,
                                    t.ux, t.uy, t.vx, t.vy, t.span_d2, t.ext_x,   t.ext_y};
                     }
                   });

  // 2. Depth order (float depth bits, then index: Render()'s radix order),
  // then the tile lists.
  std::vector<uint64_t> keys;
  for (size_t i = 0; i < n; ++i) {
    if (!visible[i]) continue;
    const uint32_t bits = raster::SortDepthBits(static_cast<float>(splats[i].depth),
                                                static_cast<uint32_t>(i), scene.order_band);
    keys.push_back((static_cast<uint64_t>(bits) << 32) | i);
  }
  {
    // Keys rise with the index: sorting by the depth bits alone, stably,
    // is the (depth bits, index) order.
    std::vector<uint64_t> buffer;
    raster::RadixSortByHighWord(&keys, &buffer, pool);
  }
  const int num_tiles = frame.tiles_x * frame.tiles_y;
  std::vector<uint64_t> tile_begin;
  std::vector<uint32_t> lists;
  {
    raster::TileBinScratch scratch;
    raster::BinByTile(
        keys.size(), num_tiles,
        [&](size_t k, auto&& emit) {
          const uint32_t i = static_cast<uint32_t>(keys[k]);
          const ScreenSplat<T>& s = splats[i];
          raster::VisitTiles(static_cast<float>(s.mx), static_cast<float>(s.my),
                             static_cast<float>(s.ca), static_cast<float>(s.cb),
                             static_cast<float>(s.cc), s.span_d2, s.ext_x, s.ext_y, frame.width,
                             frame.height, frame.tiles_x, [&](uint32_t tile) { emit(tile, i); });
        },
        pool, &scratch, &tile_begin, &lists);
  }

  // 3. Per tile, per pixel.
  TilePass<T> pass;
  pass.scene = &scene;
  pass.params = params;
  pass.frame = &frame;
  pass.splats = splats.data();
  pass.grads = &grads;
  pass.layout.channels = grads.features.empty() ? 3 : nc;
  pass.layout.textured = params.colour_gradients != nullptr;
  pass.rgb_out = pass.alpha_out = pass.depth_out = pass.features_out = nullptr;
  if (forward != nullptr) {
    forward->rgb.assign(3 * pixels, 0.0);
    forward->alpha.assign(pixels, 0.0);
    if (options.depth) forward->depth.assign(pixels, 0.0);
    if (options.features) forward->features.assign(pixels * nc, 0.0);
    if constexpr (std::is_same_v<T, double>) {
      pass.rgb_out = &forward->rgb;
      pass.alpha_out = &forward->alpha;
      pass.depth_out = &forward->depth;
      pass.features_out = &forward->features;
    }
  }
  const int stride = pass.layout.size();
  std::vector<T> slots(lists.size() * stride, T(0));
  std::vector<int64_t> contributing(num_tiles, 0);
  pool.ParallelFor(0, num_tiles, 1, [&](int64_t t0, int64_t t1) {
    for (int64_t tile = t0; tile < t1; ++tile) {
      BackwardTile(pass, static_cast<int>(tile % frame.tiles_x),
                   static_cast<int>(tile / frame.tiles_x), lists.data() + tile_begin[tile],
                   tile_begin[tile + 1] - tile_begin[tile],
                   slots.data() + tile_begin[tile] * stride, &contributing[tile]);
    }
  });

  // 4. Sum the slots per Gaussian in tile order, then through the projection.
  std::vector<T> screen(n * stride, T(0));
  for (size_t k = 0; k < lists.size(); ++k) {
    T* to = &screen[static_cast<size_t>(lists[k]) * stride];
    const T* from = &slots[k * stride];
    for (int c = 0; c < stride; ++c) to[c] += from[c];
  }
  GaussianParams<T> out;
  ZeroParams(scene, &out);
  if (screen_out != nullptr) {
    screen_out->visible = visible;
    screen_out->centre.assign(2 * n, 0.f);
  }
  const SlotLayout layout = pass.layout;
  pool.ParallelFor(0, static_cast<int64_t>((n + kChunk - 1) / kChunk), 1,
                   [&](int64_t c0, int64_t c1) {
                     for (size_t i = c0 * kChunk; i < std::min(n, size_t(c1) * kChunk); ++i) {
                       if (!visible[i]) continue;
                       T* sc = &screen[i * stride];
                       for (int c = 0; c < layout.channels; ++c) {
                         out.features[i * nc + c] = sc[layout.values() + c];
                       }
                       T g_frame[4] = {0, 0, 0, 0};
                       if (layout.textured) {
                         // value_c = f_c + gu_c u + gv_c v, u = ux dx + uy dy, v = vx dx + vy dy.
                         const ScreenSplat<T>& s = splats[i];
                         const T* cg = &params.colour_gradients[6 * i];
                         const T* mo = sc + layout.moments();
                         for (int c = 0; c < 3; ++c) {
                           const T gu = cg[2 * c], gv = cg[2 * c + 1];
                           const T e = sc[layout.values() + c], xs = mo[2 * c], ys = mo[2 * c + 1];
                           sc[kMx] -= e * (gu * s.ux + gv * s.vx);
                           sc[kMy] -= e * (gu * s.uy + gv * s.vy);
                           out.colour_gradients[6 * i + 2 * c] = xs * s.ux + ys * s.uy;
                           out.colour_gradients[6 * i + 2 * c + 1] = xs * s.vx + ys * s.vy;
                           g_frame[0] += xs * gu;
                           g_frame[1] += ys * gu;
                           g_frame[2] += xs * gv;
                           g_frame[3] += ys * gv;
                         }
                       }
                       if (screen_out != nullptr) {
                         screen_out->centre[2 * i] = static_cast<float>(sc[kMx]);
                         screen_out->centre[2 * i + 1] = static_cast<float>(sc[kMy]);
                       }
                       BackwardProjection(scene, params, i, frame, sc, g_frame, &out);
                     }
                   });
  if (stats != nullptr) {
    stats->gaussians_visible = static_cast<int64_t>(keys.size());
    stats->pairs = static_cast<int64_t>(lists.size());
    stats->pairs_contributing = 0;
    for (int64_t c : contributing) stats->pairs_contributing += c;
    const size_t result =
        (out.means.size() + out.rotations.size() + out.log_scales.size() +
         out.opacity_logits.size() + out.features.size() + out.colour_gradients.size()) *
        sizeof(T);
    stats->working_bytes = static_cast<int64_t>(
        splats.size() * sizeof(ScreenSplat<T>) + n + keys.size() * 8 + tile_begin.size() * 8 +
        lists.size() * 4 + (slots.size() + screen.size()) * sizeof(T) + result);
  }
  return out;
}

// dL/d a camera motion (raster_backward.h) from the mean and rotation
// gradients of the Gaussians of `frame`'s render. The camera moved by
// (w, t) sees x_c' = R(w)^T (x_c - t) = x_c - t + x_c x w to first order,
// and each Gaussian's camera-frame rotation turned by -w: in its owner's
// frame q' = (1, -R^T w / 2) q (R camera from owner), whose derivative is
// -(0, e_k) q / 2. Summed in chunks, then the chunks in order.
template <typename T>
CameraMotion MotionGradient(const GaussianScene& scene, const ParamView<T>& params,
                            const RenderFrame& frame, const T* grad_means,
                            const T* grad_rotations) {
  const size_t n = scene.size();
  constexpr size_t kChunk = 1 << 15;
  const size_t chunks = (n + kChunk - 1) / kChunk;
  std::vector<CameraMotion> partial(chunks, CameraMotion{});
  DefaultThreadPool().ParallelFor(0, static_cast<int64_t>(chunks), 1, [&](int64_t c0, int64_t c1) {
    for (int64_t c = c0; c < c1; ++c) {
      CameraMotion& sum = partial[c];
      for (size_t i = c * kChunk; i < std::min(n, (c + 1) * kChunk); ++i) {
        const uint32_t owner = scene.owners[i];
        if (!frame.owner_live[owner]) continue;
        const raster::Transform& cam = frame.camera_from_owner[owner];
        const T* m = &params.means[3 * i];
        const T* gm = &grad_means[3 * i];
        double x[3], g[3];
        for (int r = 0; r < 3; ++r) {
          const float* row = &cam.r[3 * r];
          x[r] = row[0] * double(m[0]) + row[1] * double(m[1]) + row[2] * double(m[2]) + cam.t[r];
          g[r] = row[0] * double(gm[0]) + row[1] * double(gm[1]) + row[2] * double(gm[2]);
        }
        const T* q = &params.rotations[4 * i];
        const T* gq = &grad_rotations[4 * i];
        const double qw = q[0], qx = q[1], qy = q[2], qz = q[3];
        // (0, e_k) q for k = x, y, z.
        const double turn[3][4] = {{-qx, qw, -qz, qy}, {-qy, qz, qw, -qx}, {-qz, -qy, qx, qw}};
        double owner_w[3];
        for (int k = 0; k < 3; ++k) {
          owner_w[k] = -0.5 * (gq[0] * turn[k][0] + gq[1] * turn[k][1] + gq[2] * turn[k][2] +
                               gq[3] * turn[k][3]);
        }
        sum[0] += g[1] * x[2] - g[2] * x[1];
        sum[1] += g[2] * x[0] - g[0] * x[2];
        sum[2] += g[0] * x[1] - g[1] * x[0];
        for (int r = 0; r < 3; ++r) {
          sum[r] += cam.r[3 * r] * owner_w[0] + cam.r[3 * r + 1] * owner_w[1] +
                    cam.r[3 * r + 2] * owner_w[2];
          sum[3 + r] -= g[r];
        }
      }
    }
  });
  CameraMotion total{};
  for (const CameraMotion& p : partial) {
    for (int k = 0; k < 6; ++k) total[k] += p[k];
  }
  return total;
}

// MotionGradient for `camera`'s render at `timestamp_us`.
template <typename T>
absl::StatusOr<CameraMotion> MotionGradientOf(const GaussianScene& scene,
                                              const ParamView<T>& params,
                                              const RenderCamera& camera, int64_t timestamp_us,
                                              const std::vector<ActorEdit>& edits,
                                              const GaussianParams<T>& grads, double near_plane) {
  if (camera.rolling_shutter.has_value()) {
    return absl::InvalidArgumentError(
        "camera: the camera motion's gradient has no rolling shutter; global-shutter views only");
  }
  if (absl::Status status = CheckRenderable(scene); !status.ok()) return status;
  if (grads.means.size() != 3 * scene.size() || grads.rotations.size() != 4 * scene.size()) {
    return absl::InvalidArgumentError(absl::StrCat(
        "grads: ", grads.means.size() / 3, " means and ", grads.rotations.size() / 4,
        " rotations for ", scene.size(), " Gaussians; pass RenderBackward()'s gradients"));
  }
  RenderFrame frame;
  if (absl::Status status =
          raster::SetUpRenderFrame(scene.instances, scene.time_origin_us, scene.fade_span, camera,
                                   timestamp_us, edits, near_plane, &frame);
      !status.ok()) {
    return status;
  }
  return MotionGradient(scene, params, frame, grads.means.data(), grads.rotations.data());
}

}  // namespace

RenderCamera MovedCamera(const RenderCamera& camera, const CameraMotion& motion) {
  RenderCamera moved = camera;
  const Rigid step{RotationFromVector({motion[0], motion[1], motion[2]}),
                   {motion[3], motion[4], motion[5]}};
  moved.world_from_camera = camera.world_from_camera * step;
  return moved;
}

absl::StatusOr<CameraMotion> CameraMotionGradient(const GaussianScene& scene,
                                                  const RenderCamera& camera, int64_t timestamp_us,
                                                  const std::vector<ActorEdit>& edits,
                                                  const SceneGradients& grads,
                                                  const RenderOptions& options) {
  return MotionGradientOf<float>(scene, ViewOf<float>(scene), camera, timestamp_us, edits, grads,
                                 options.near_plane);
}

absl::StatusOr<SceneGradients> RenderBackward(const GaussianScene& scene,
                                              const RenderCamera& camera, int64_t timestamp_us,
                                              const std::vector<ActorEdit>& edits,
                                              const RenderOutputGradients& grads,
                                              const RenderOptions& options, BackwardStats* stats,
                                              ScreenGradients* screen) {
  return Backward<float>(scene, ViewOf<float>(scene), camera, timestamp_us, edits, grads, options,
                         stats, nullptr, screen);
}

namespace testing {

GaussianParams<double> ParamsInDouble(const GaussianScene& scene) {
  auto widen = [](const std::vector<float>& v) { return std::vector<double>(v.begin(), v.end()); };
  return {widen(scene.means),          widen(scene.rotations), widen(scene.log_scales),
          widen(scene.opacity_logits), widen(scene.features),  widen(scene.colour_gradients)};
}

absl::StatusOr<DoubleRender> RenderBackwardInDouble(
    const GaussianScene& scene, const GaussianParams<double>& params, const RenderCamera& camera,
    int64_t timestamp_us, const OutputGradients<double>& grads, const RenderOptions& options) {
  if (absl::Status status = CheckRenderable(scene); !status.ok()) return status;
  const size_t n = scene.size();
  if (params.means.size() != 3 * n || params.rotations.size() != 4 * n ||
      params.log_scales.size() != 3 * n || params.opacity_logits.size() != n ||
      params.features.size() != n * scene.num_channels ||
      params.colour_gradients.size() != scene.colour_gradients.size()) {
    return absl::InvalidArgumentError("params: sizes differ from the scene's");
  }
  DoubleRender result;
  absl::StatusOr<GaussianParams<double>> g =
      Backward<double>(scene, ViewOf<double>(params), camera, timestamp_us, {}, grads, options,
                       nullptr, &result, nullptr);
  if (!g.ok()) return g.status();
  result.grads = *std::move(g);
  return result;
}

absl::StatusOr<CameraMotion> CameraMotionGradientInDouble(
    const GaussianScene& scene, const GaussianParams<double>& params, const RenderCamera& camera,
    int64_t timestamp_us, const GaussianParams<double>& grads, const RenderOptions& options) {
  return MotionGradientOf<double>(scene, ViewOf<double>(params), camera, timestamp_us, {}, grads,
                                  options.near_plane);
}

}  // namespace testing
}  // namespace pf
