// The projection of one Gaussian into a view, shared by Render()
// (rasterizer.cc) and ComputeCompositingWeights() (compositing_weights.cc),
// so the colour fit records exactly the weights the rasterizer composites:
// time-faded opacity, camera-frame mean, pixel centre through the camera
// model, the EWA covariance J W Sigma W^T J^T + s I (s the scene's
// GaussianScene::low_pass; distortion linearised at the mean), its conic and
// the opacity-aware extent (the Mahalanobis radius where alpha drops to
// 1/255), and the ellipse-versus-rectangle test of the binning. Header-only so the rasterizer's
// per-Gaussian loop still inlines it; the PF_HD functions are also the CUDA
// rasterizer's (cuda_rasterizer.cu), so both paths project the same way.
#ifndef POINTFORWARD_ENGINE_RENDER_SPLAT_PROJECTION_H_
#define POINTFORWARD_ENGINE_RENDER_SPLAT_PROJECTION_H_

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <utility>
#include <vector>

#include "common/host_device.h"
#include "engine/camera/camera_model.h"
#include "engine/camera/lens.h"
#include "engine/render/gaussian_scene.h"
#include "engine/render/raster_tile.h"

namespace pf {
namespace raster {

// The row spans and tile tests use a slightly larger radius than the exact
// 1/255 level, so float rounding never drops a pixel that the alpha test
// would keep; the alpha test decides.
inline constexpr float kExtentMargin = 1.001f;
// Pinhole Jacobians are evaluated no further than this fraction of the image
// size outside the image (as 3DGS clamps at 1.3 tan(fov)), so Gaussians far
// off screen do not blow up into huge splats.
inline constexpr float kJacobianGuard = 0.15f;
// ProjectSplat's early rejections: a fade exponent past ln 255 (with room
// for rounding), the extent's d^2 at opacity 1 (2 ln 255 kExtentMargin +
// 1e-4, rounded up), and the factor that keeps the bound on the extents
// above the extents float rounding gives.
inline constexpr float kFadeReject = 5.5413f;  // ln 255 = 5.54126.
inline constexpr float kMaxSpanD2 = 11.094f;   // 11.0936.
inline constexpr float kExtentBound = 1.01f;

PF_HD inline float ClampTo(float x, float lo, float hi) { return x < lo ? lo : (hi < x ? hi : x); }

// The key Gaussian i is depth-sorted by, as float bits (non-negative floats
// sort as unsigned integers): its depth times 1 + order_band x u_i, u_i in
// [0, 1) a fixed hash of i (GaussianScene::order_band), so Gaussians within
// that share of each other's depth keep one order in every view.
PF_HD inline uint32_t SortDepthBits(float depth, uint32_t i, float order_band) {
  if (order_band > 0) {
    const float u = static_cast<float>((i * 2654435761u) >> 8) * (1.f / 16777216.f);
    depth *= 1.f + order_band * u;
  }
  uint32_t bits;
  memcpy(&bits, &depth, sizeof(bits));
  return bits;
}

// The radix sort's digits: three LSD passes of 11 bits over the high word
// (shifts 32, 43, 54).
inline constexpr int kSortDigitBits = 11;
inline constexpr size_t kSortDigits = size_t{1} << kSortDigitBits;

// Sorts `keys` by their high 32 bits (SortDepthBits), stably: three LSD
// passes of kSortDigitBits, so keys (bits << 32 | index) end in (depth,
// index) order. `buffer` is scratch space.
inline void RadixSortByHighWord(std::vector<uint64_t>* keys, std::vector<uint64_t>* buffer) {
  buffer->resize(keys->size());
  uint64_t* from = keys->data();
  uint64_t* to = buffer->data();
  const size_t n = keys->size();
  for (int shift = 32; shift < 64; shift += kSortDigitBits) {
    size_t count[kSortDigits + 1] = {};
    for (size_t k = 0; k < n; ++k) ++count[((from[k] >> shift) & (kSortDigits - 1)) + 1];
    for (size_t b = 0; b < kSortDigits; ++b) count[b + 1] += count[b];
    for (size_t k = 0; k < n; ++k) to[count[(from[k] >> shift) & (kSortDigits - 1)]++] = from[k];
    std::swap(from, to);
  }
  // Three passes: the result is in `buffer`.
  keys->swap(*buffer);
}

// A view's camera as the projection reads it, in float (the lens in double).
struct ProjectionCamera {
  int width = 0, height = 0;
  Lens lens;
  float fx = 0, fy = 0, cx = 0, cy = 0;
  float x_lo = 0, x_hi = 0, y_lo = 0, y_hi = 0;  // Jacobian clamp, normalised.
  float near_plane = 0.01f;
  float render_time_s = 0;  // Seconds since the scene's time origin.
};

// Fills `camera` for `model` at scene time `time_s`.
inline void SetUpProjectionCamera(const CameraModel& model, float near_plane, float time_s,
                                  ProjectionCamera* camera) {
  camera->width = model.width();
  camera->height = model.height();
  camera->lens = model.lens();
  camera->fx = static_cast<float>(model.fx());
  camera->fy = static_cast<float>(model.fy());
  camera->cx = static_cast<float>(model.cx());
  camera->cy = static_cast<float>(model.cy());
  if (!model.has_distortion()) {
    camera->x_lo = static_cast<float>((-kJacobianGuard * camera->width - model.cx()) / model.fx());
    camera->x_hi =
        static_cast<float>(((1 + kJacobianGuard) * camera->width - model.cx()) / model.fx());
    camera->y_lo = static_cast<float>((-kJacobianGuard * camera->height - model.cy()) / model.fy());
    camera->y_hi =
        static_cast<float>(((1 + kJacobianGuard) * camera->height - model.cy()) / model.fy());
  } else {
    // Distorted pixels are not linear in x/z: clamp at the model's valid
    // radius (Project() culls means beyond it).
    const float r = static_cast<float>(std::min(model.max_normalized_radius(), 1e3));
    camera->x_lo = camera->y_lo = -r;
    camera->x_hi = camera->y_hi = r;
  }
  camera->near_plane = near_plane;
  camera->render_time_s = time_s;
}

// What compositing reads of a projected Gaussian.
struct SplatGeometry {
  float mx, my;      // Pixel-space centre.
  float ca, cb, cc;  // Conic (inverse 2D covariance).
  float opacity;     // Time-faded.
  float span_d2;     // d^2 bound of the row spans and tile tests.
  float ext_x, ext_y;
  float depth;  // Camera-frame z.
  // The expected local coordinates (along the Gaussian's first two axes, in
  // std-devs) of screen offset (dx, dy): u = ux dx + uy dy, v = vx dx + vy dy
  // (B^T Sigma^-1 d; GaussianScene::colour_gradients).
  float ux, uy, vx, vy;
};

// The compositing record of geometry `g` of a Gaussian of `owner` (its SH
// colour zero, for the caller to fill).
PF_HD inline Projected ToProjected(const SplatGeometry& g, uint32_t owner) {
  Projected p;
  p.mx = g.mx;
  p.my = g.my;
  p.ca = g.ca;
  p.cb = g.cb;
  p.cc = g.cc;
  p.opacity = g.opacity;
  p.span_d2 = g.span_d2;
  p.ext_x = g.ext_x;
  p.ext_y = g.ext_y;
  p.depth = g.depth;
  p.rgb[0] = p.rgb[1] = p.rgb[2] = 0;
  p.owner = owner;
  p.pad[0] = p.pad[1] = 0;
  return p;
}

// Writes the screen-space colour gradient of a Gaussian with local colour
// gradients `grad` ([3, 2], GaussianScene::colour_gradients) projected as
// `g`: out[2c], out[2c + 1] = d channel c / d x, d y (pixels).
PF_HD inline void ScreenColourGradients(const float* grad, const SplatGeometry& g, float* out) {
  for (int c = 0; c < 3; ++c) {
    const float gu = grad[2 * c], gv = grad[2 * c + 1];
    out[2 * c] = gu * g.ux + gv * g.vx;
    out[2 * c + 1] = gu * g.uy + gv * g.vy;
  }
}

// The per-Gaussian arrays the projection reads (GaussianScene's, on the
// host or copied to a GPU).
struct SplatArrays {
  const float* means = nullptr;           // [N, 3]
  const float* rotations = nullptr;       // [N, 4]
  const float* log_scales = nullptr;      // [N, 3]
  const float* opacity_logits = nullptr;  // [N]
  const float* times = nullptr;           // [N]
  const float* lifespans = nullptr;       // [N]
  float low_pass = 0;
};

inline SplatArrays ArraysOf(const GaussianScene& scene) {
  return {scene.means.data(),      scene.rotations.data(),
          scene.log_scales.data(), scene.opacity_logits.data(),
          scene.times.data(),      scene.lifespans.data(),
          scene.low_pass};
}

// Projects Gaussian `i`, whose owner frame maps to the camera by `r`
// (row-major 3x3) and `t`; false when it cannot be seen (faded out, behind
// the near plane, outside the distortion model or the image).
// kEarlyRejects: test first, before the costly parts, what rules a Gaussian
// out whatever its opacity and rotation (most of a large scene is out of
// any one view); each early test is conservative, so the result is the
// same either way (false only skips them, for the tests that show it).
template <bool kEarlyRejects = true>
PF_HD inline bool ProjectSplat(const SplatArrays& scene, size_t i, const ProjectionCamera& camera,
                               const float* r, const float* t, SplatGeometry* out) {
  // A fade alone under 1/255 (the sigmoid is at most 1).
  const float sigma = scene.lifespans[i];
  float fade_u = 0.f;
  if (!std::isinf(sigma)) {
    fade_u = (camera.render_time_s - scene.times[i]) / (sigma + 1.f);
    if (kEarlyRejects && 0.5f * fade_u * fade_u > kFadeReject) return false;
  }

  // Camera-frame mean.
  const float* m = &scene.means[3 * i];
  const float px = r[0] * m[0] + r[1] * m[1] + r[2] * m[2] + t[0];
  const float py = r[3] * m[0] + r[4] * m[1] + r[5] * m[2] + t[1];
  const float pz = r[6] * m[0] + r[7] * m[1] + r[8] * m[2] + t[2];
  if (!(pz >= camera.near_plane)) return false;

  // Pixel centre and the 2x2 Jacobian of pixel w.r.t. normalised coordinates.
  const float inv_z = 1.f / pz;
  const float xn = px * inv_z, yn = py * inv_z;
  const float tx = ClampTo(xn, camera.x_lo, camera.x_hi);
  const float ty = ClampTo(yn, camera.y_lo, camera.y_hi);
  float mx, my;
  float d00 = camera.fx, d01 = 0, d10 = 0, d11 = camera.fy;
  const Lens& lens = camera.lens;
  if (lens.kind == Lens::kPinhole) {
    mx = camera.fx * xn + camera.cx;
    my = camera.fy * yn + camera.cy;
  } else {
    double u, v;
    if (!LensProject(lens, px, py, pz, &u, &v)) return false;
    mx = static_cast<float>(u);
    my = static_cast<float>(v);
    // Central differences of the distortion at the (clamped) point.
    double d[4];
    LensJacobian(lens, tx, ty, d);
    d00 = static_cast<float>(d[0]);
    d01 = static_cast<float>(d[1]);
    d10 = static_cast<float>(d[2]);
    d11 = static_cast<float>(d[3]);
  }
  // J = D * [1/z 0 -tx/z; 0 1/z -ty/z], 2x3.
  const float j00 = d00 * inv_z, j01 = d01 * inv_z, j02 = -(d00 * tx + d01 * ty) * inv_z;
  const float j10 = d10 * inv_z, j11 = d11 * inv_z, j12 = -(d10 * tx + d11 * ty) * inv_z;
  // Off the image whatever the Gaussian's rotation and opacity: row k of
  // B below has a norm of at most the largest scale times that of row k of
  // J (R and the Gaussian's rotation are orthonormal), and the extent's
  // d^2 at most its value at opacity 1.
  if (kEarlyRejects) {
    const float* ls = &scene.log_scales[3 * i];
    const float s_max = std::exp(std::max(ls[0], std::max(ls[1], ls[2])));
    const float s2 = s_max * s_max;
    const float row0 = j00 * j00 + j01 * j01 + j02 * j02;
    const float row1 = j10 * j10 + j11 * j11 + j12 * j12;
    const float bound_x = kExtentBound * std::sqrt(kMaxSpanD2 * (s2 * row0 + scene.low_pass));
    const float bound_y = kExtentBound * std::sqrt(kMaxSpanD2 * (s2 * row1 + scene.low_pass));
    if (mx + bound_x < 0 || mx - bound_x > camera.width || my + bound_y < 0 ||
        my - bound_y > camera.height) {
      return false;
    }
  }
  // Opacity, faded by time.
  float opacity = 1.f / (1.f + std::exp(-scene.opacity_logits[i]));
  if (!std::isinf(sigma)) opacity *= std::exp(-0.5f * fade_u * fade_u);
  if (!(opacity >= kMinAlpha)) return false;
  // A = J * R_cam (2x3).
  const float a00 = j00 * r[0] + j01 * r[3] + j02 * r[6];
  const float a01 = j00 * r[1] + j01 * r[4] + j02 * r[7];
  const float a02 = j00 * r[2] + j01 * r[5] + j02 * r[8];
  const float a10 = j10 * r[0] + j11 * r[3] + j12 * r[6];
  const float a11 = j10 * r[1] + j11 * r[4] + j12 * r[7];
  const float a12 = j10 * r[2] + j11 * r[5] + j12 * r[8];
  // Gaussian rotation (normalised quaternion) and scales.
  const float* q = &scene.rotations[4 * i];
  const float qn = q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3];
  if (!(qn > 0)) return false;
  const float s = 1.f / std::sqrt(qn);
  const float w = q[0] * s, x = q[1] * s, y = q[2] * s, z = q[3] * s;
  const float g00 = 1 - 2 * (y * y + z * z), g01 = 2 * (x * y - w * z), g02 = 2 * (x * z + w * y);
  const float g10 = 2 * (x * y + w * z), g11 = 1 - 2 * (x * x + z * z), g12 = 2 * (y * z - w * x);
  const float g20 = 2 * (x * z - w * y), g21 = 2 * (y * z + w * x), g22 = 1 - 2 * (x * x + y * y);
  const float* ls = &scene.log_scales[3 * i];
  const float s0 = std::exp(ls[0]), s1 = std::exp(ls[1]), s2 = std::exp(ls[2]);
  // B = A * G * S (2x3); cov = B B^T + low-pass.
  const float b00 = (a00 * g00 + a01 * g10 + a02 * g20) * s0;
  const float b01 = (a00 * g01 + a01 * g11 + a02 * g21) * s1;
  const float b02 = (a00 * g02 + a01 * g12 + a02 * g22) * s2;
  const float b10 = (a10 * g00 + a11 * g10 + a12 * g20) * s0;
  const float b11 = (a10 * g01 + a11 * g11 + a12 * g21) * s1;
  const float b12 = (a10 * g02 + a11 * g12 + a12 * g22) * s2;
  const float cov_xx = b00 * b00 + b01 * b01 + b02 * b02 + scene.low_pass;
  const float cov_xy = b00 * b10 + b01 * b11 + b02 * b12;
  const float cov_yy = b10 * b10 + b11 * b11 + b12 * b12 + scene.low_pass;
  const float det = cov_xx * cov_yy - cov_xy * cov_xy;
  if (!(det > 0)) return false;
  const float inv_det = 1.f / det;

  // Opacity-aware extent: alpha = o exp(-d^2 / 2) >= 1/255 <=> d^2 <= 2 ln(255 o).
  const float d2_max = 2.f * std::log(opacity * 255.f) * kExtentMargin + 1e-4f;
  const float ext_x = std::sqrt(d2_max * cov_xx), ext_y = std::sqrt(d2_max * cov_yy);
  if (mx + ext_x < 0 || mx - ext_x > camera.width || my + ext_y < 0 || my - ext_y > camera.height ||
      !std::isfinite(mx) || !std::isfinite(my)) {
    return false;
  }
  out->mx = mx;
  out->my = my;
  out->ca = cov_yy * inv_det;
  out->cb = -cov_xy * inv_det;
  out->cc = cov_xx * inv_det;
  out->opacity = opacity;
  out->span_d2 = d2_max;
  out->ext_x = ext_x;
  out->ext_y = ext_y;
  out->depth = pz;
  out->ux = b00 * out->ca + b10 * out->cb;
  out->uy = b00 * out->cb + b10 * out->cc;
  out->vx = b01 * out->ca + b11 * out->cb;
  out->vy = b01 * out->cb + b11 * out->cc;
  return true;
}

// Projects Gaussian `i` of `scene` (ProjectSplat on the scene's arrays).
inline bool ProjectSplatGeometry(const GaussianScene& scene, size_t i,
                                 const ProjectionCamera& camera, const float* r, const float* t,
                                 SplatGeometry* out) {
  return ProjectSplat<true>(ArraysOf(scene), i, camera, r, t, out);
}

// Returns the smallest d^2 of the conic over the rectangle of pixel centres
// [x0, x1] x [y0, y1] (offsets from the Gaussian's centre): the binning's
// exact ellipse-versus-rectangle test.
PF_HD inline float MinD2OverRect(float ca, float cb, float cc, float x0, float x1, float y0,
                                 float y1) {
  if (x0 <= 0 && x1 >= 0 && y0 <= 0 && y1 >= 0) return 0;
  const float dy0 = ClampTo(-cb * x0 / cc, y0, y1);  // Fixed dx, best dy in [y0, y1].
  const float dy1 = ClampTo(-cb * x1 / cc, y0, y1);
  const float dx0 = ClampTo(-cb * y0 / ca, x0, x1);  // Fixed dy, best dx in [x0, x1].
  const float dx1 = ClampTo(-cb * y1 / ca, x0, x1);
  const float e0 = ca * x0 * x0 + 2 * cb * x0 * dy0 + cc * dy0 * dy0;
  const float e1 = ca * x1 * x1 + 2 * cb * x1 * dy1 + cc * dy1 * dy1;
  const float e2 = ca * dx0 * dx0 + 2 * cb * dx0 * y0 + cc * y0 * y0;
  const float e3 = ca * dx1 * dx1 + 2 * cb * dx1 * y1 + cc * y1 * y1;
  const float a = e1 < e0 ? e1 : e0, b = e3 < e2 ? e3 : e2;
  return b < a ? b : a;
}

// Calls visit(tile) for every 16x16 tile of a width x height image (tiles_x
// per row, row-major) whose pixel centres the ellipse of (mx, my, conic,
// span_d2, extents) reaches: the pixel-centre bounds, clipped to the image,
// then the exact ellipse-versus-rectangle test unless one tile holds them.
template <typename Visit>
PF_HD inline void VisitTiles(float mx, float my, float ca, float cb, float cc, float span_d2,
                             float ext_x, float ext_y, int width, int height, int tiles_x,
                             Visit&& visit) {
  const int px0 = std::max(0, static_cast<int>(std::ceil(mx - ext_x - 0.5f)));
  const int px1 = std::min(width - 1, static_cast<int>(std::floor(mx + ext_x - 0.5f)));
  const int py0 = std::max(0, static_cast<int>(std::ceil(my - ext_y - 0.5f)));
  const int py1 = std::min(height - 1, static_cast<int>(std::floor(my + ext_y - 0.5f)));
  if (px0 > px1 || py0 > py1) return;
  const int tx0 = px0 / kTile, tx1 = px1 / kTile, ty0 = py0 / kTile, ty1 = py1 / kTile;
  if (tx0 == tx1 && ty0 == ty1) {  // One tile: no loop, no test.
    visit(static_cast<uint32_t>(ty0 * tiles_x + tx0));
    return;
  }
  for (int ty = ty0; ty <= ty1; ++ty) {
    const float y0 = std::max(ty * kTile, py0) + 0.5f - my;
    const float y1 = std::min(ty * kTile + kTile - 1, py1) + 0.5f - my;
    for (int tx = tx0; tx <= tx1; ++tx) {
      const float x0 = std::max(tx * kTile, px0) + 0.5f - mx;
      const float x1 = std::min(tx * kTile + kTile - 1, px1) + 0.5f - mx;
      if (MinD2OverRect(ca, cb, cc, x0, x1, y0, y1) > span_d2) continue;
      visit(static_cast<uint32_t>(ty * tiles_x + tx));
    }
  }
}

}  // namespace raster
}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RENDER_SPLAT_PROJECTION_H_
