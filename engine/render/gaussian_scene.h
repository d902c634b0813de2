// The in-memory Gaussian scene, in structure-of-arrays form.
//
// Gaussian i is background (owner 0) or belongs to instance k (owner k,
// 1-based into `instances`). Background means live in world space; an
// instance's means and rotations live in its canonical frame, the frame of
// its first box (docs/DESIGN.md section 3): at render time t' they are moved
// to the world by the instance's box pose at t'.
//
// Colour comes from spherical harmonics when `sh_degree` >= 0 (scenes from
// 3DGS tools), else from the first three feature channels. Those may vary
// linearly across a Gaussian (`colour_gradients`, reconstructed scenes): at
// local coordinates (u, v) along the Gaussian's first two axes, in units of
// its standard deviations, channel c is features[c] + g_cu u + g_cv v. A
// pixel at screen offset d from the centre takes the expected (u, v) given
// d, B^T Sigma^-1 d (B: the axes projected to the screen and scaled by the
// std-devs, Sigma the 2D covariance with the low-pass), so a Gaussian seen
// edge-on or much smaller than the low-pass blends to its centre colour.
//
// `low_pass` is the screen-space variance (pixels^2) the rasterizer adds to
// every projected 2D covariance. It belongs to the scene because a scene's
// colours are fitted under one: 3DGS tools train with 0.3 (kThreeDgsLowPass,
// what PLY files from them need); our reconstruction uses 0.1 (about the
// variance of a one-pixel box, 1/12, which is what antialiased camera
// images integrate over), docs/QUALITY.md has the comparison.
//
// `order_band` is a share of depth within which Gaussians keep a fixed order
// of their own instead of their depth order. A reconstruction's discs that
// overlap on one surface then stack the same way in every view, as they did
// in the context views its colours were fitted to; by strict depth order their
// stacking would turn on micrometres and differ from view to view.
//
// `lidar_intensity_channel` names the feature channel a LiDAR render reads
// its intensity from (lidar_render.h); -1: the scene has none.
#ifndef POINTFORWARD_ENGINE_RENDER_GAUSSIAN_SCENE_H_
#define POINTFORWARD_ENGINE_RENDER_GAUSSIAN_SCENE_H_

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "common/colour_space.h"
#include "common/geometry.h"

namespace pf {

// A box of an instance track, in world space.
struct TrackBox {
  int64_t timestamp_us = 0;
  Vec3 center;
  Vec3 size;      // Length (box x), width (y), height (z).
  Quat rotation;  // Box-to-world.
};

// A moving actor: its id, category and boxes sorted by time.
struct InstanceTrack {
  std::string id;
  std::string category;
  std::vector<TrackBox> boxes;  // Sorted by timestamp_us; boxes[0] is canonical.
};

// The low-pass of the reference 3DGS rasterizer, and the default.
inline constexpr float kThreeDgsLowPass = 0.3f;
// The range ValidateScene accepts for GaussianScene::low_pass.
inline constexpr float kMaxLowPass = 4.f;
// The largest GaussianScene::order_band ValidateScene accepts.
inline constexpr float kMaxOrderBand = 0.05f;
// The largest GaussianScene::render_blur, pixels.
inline constexpr float kMaxRenderBlur = 4.f;
// The largest GaussianScene::render_blur_growth, milliradians per metre.
inline constexpr float kMaxRenderBlurGrowth = 100.f;

// A CONTEXT view's camera as the render blur's growth sees it
// (GaussianScene::blur_anchors): its centre and optical axis in world space.
struct BlurAnchor {
  std::array<float, 3> centre{};
  std::array<float, 3> axis{0, 0, 1};  // Unit.
};

// The ego vehicle's body as one rig camera sees it: fixed in that camera's
// image whatever the pose, so renders of the camera show it on top of the
// scene (ApplyEgoLayer, ego_layer.h).
struct EgoLayer {
  std::string camera_id;  // The clip's Camera.id.
  int width = 0, height = 0;
  std::vector<uint8_t> mask;  // [H, W] 1 on the body.
  // [H, W, 3] the body's colour, in the scene's colour_encoding; 0 off it:
  // the mean over the camera's CONTEXT views, drawn at every time where
  // there are no frames.
  std::vector<float> rgb;
  // The body as each CONTEXT time of the camera showed it, by time (strictly
  // ascending): a render at time t draws the two frames either side of t
  // mixed linearly in t, the first before it and the last after it
  // (ApplyEgoLayer). The body changes with what it mirrors as the car moves.
  struct Frame {
    int64_t timestamp_us = 0;
    std::vector<float> rgb;  // [B, 3] the body pixels' colours, in pixel order.
  };
  std::vector<Frame> frames;

  bool on_body(size_t pixel) const { return mask[pixel] != 0; }
  // How many pixels, and what share of the image, are on the body.
  uint64_t body_pixels() const {
    uint64_t on = 0;
    for (uint8_t m : mask) on += m != 0;
    return on;
  }
  double body_share() const {
    return mask.empty() ? 0.0 : double(body_pixels()) / double(mask.size());
  }
};

// The scene times (seconds since the time origin) a render's time is held
// within where finite lifespans fade a Gaussian's opacity: a render before
// `begin` fades as at `begin`, one after `end` as at `end`, so a scene whose
// Gaussians fade away from the times they were seen from still shows them at
// times past those. Actors are posed at the render's own time either way.
struct FadeSpan {
  float begin = -std::numeric_limits<float>::infinity();
  float end = std::numeric_limits<float>::infinity();
  bool bounded() const { return !std::isinf(begin) || !std::isinf(end); }
  float Clamp(float time_s) const { return std::min(std::max(time_s, begin), end); }
};

struct GaussianScene {
  int num_channels = 3;               // N_c, 3..256.
  int sh_degree = -1;                 // -1: no SH; 0..3 otherwise.
  float low_pass = kThreeDgsLowPass;  // Screen-space low-pass, pixels^2, in [0, kMaxLowPass].
  // Gaussians whose depths lie within this share of each other are drawn in
  // a fixed order of their own (a hash of the index), the same in every view;
  // in [0, kMaxOrderBand]. 0 (3DGS scenes): strict depth order.
  float order_band = 0;
  // Scene time of t = 0 for `times`; lifespans are in seconds.
  int64_t time_origin_us = 0;
  // Reconstructed scenes: their CONTEXT times; unbounded by default (older
  // scene files, PLYs).
  FadeSpan fade_span;
  // What the colours (SH or the first three feature channels, and their
  // gradients) encode, so a render's colour is too: sRGB-encoded values (3DGS
  // scenes; reconstructions in the sRGB working space) or linear light.
  // Render outputs convert from it (render_outputs.h).
  ColourEncoding colour_encoding = ColourEncoding::kSrgb;
  // Std-dev in pixels of the blur DeviceRenderer gives every render's
  // colour, features and alpha at the least, and its actors' pixels where
  // it grows (render_blur.h RenderBlurAt), in [0, kMaxRenderBlur]; 0: none
  // (the default, and scene files before version 10).
  float render_blur = 0;
  // How the render blur grows away from what the CONTEXT views saw
  // (RenderBlurAt, render_blur.h): milliradians per metre of a render's
  // distance from the nearest of `blur_anchors`, in [0, kMaxRenderBlurGrowth];
  // 0: none (the default, and scene files before version 11).
  float render_blur_growth = 0;
  std::vector<BlurAnchor> blur_anchors;
  // The feature channel of LiDAR intensity, in [0, num_channels); -1: none.
  int lidar_intensity_channel = -1;

  std::vector<float> means;           // [N, 3]
  std::vector<float> rotations;       // [N, 4] (w, x, y, z), any norm > 0
  std::vector<float> log_scales;      // [N, 3] natural log of the std-devs
  std::vector<float> opacity_logits;  // [N] opacity = sigmoid(logit)
  std::vector<float> features;        // [N, num_channels]
  std::vector<float> sh;              // [N, 3, (sh_degree+1)^2] channel-major; empty if none
  std::vector<float> times;           // [N] seconds since time_origin_us
  std::vector<float> lifespans;       // [N] sigma in seconds; +inf: never fades
  std::vector<uint32_t> owners;       // [N] 0 background, k: instances[k-1]
  // [N, 3, 2] (g_cu, g_cv) per colour channel; empty: flat colours. Only
  // without SH.
  std::vector<float> colour_gradients;

  std::vector<InstanceTrack> instances;
  // At most one per camera id; empty for scenes of other sources.
  std::vector<EgoLayer> ego_layers;

  size_t size() const { return opacity_logits.size(); }
  int sh_coeffs() const { return sh_degree < 0 ? 0 : (sh_degree + 1) * (sh_degree + 1); }
  bool has_colour_gradients() const { return !colour_gradients.empty(); }

  // Resizes every per-Gaussian array to `n`, keeping existing entries; new
  // ones are identity rotations, zero elsewhere, lifespan +inf, owner 0
  // (colour gradients only when the scene has them).
  void Resize(size_t n);
};

// opacity_logits' conversions: sigmoid and its inverse (opacity in (0, 1)).
inline double OpacityOfLogit(float logit) { return 1 / (1 + std::exp(-double{logit})); }
inline float LogitOfOpacity(double opacity) {
  return static_cast<float>(std::log(opacity / (1 - opacity)));
}

inline void GaussianScene::Resize(size_t n) {
  const size_t old = size();
  means.resize(n * 3, 0.f);
  rotations.resize(n * 4, 0.f);
  for (size_t i = old; i < n; ++i) rotations[i * 4] = 1.f;
  log_scales.resize(n * 3, 0.f);
  opacity_logits.resize(n, 0.f);
  features.resize(n * num_channels, 0.f);
  if (sh_degree >= 0) sh.resize(n * 3 * sh_coeffs(), 0.f);
  times.resize(n, 0.f);
  lifespans.resize(n, std::numeric_limits<float>::infinity());
  owners.resize(n, 0);
  if (!colour_gradients.empty()) colour_gradients.resize(n * 6, 0.f);
}

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RENDER_GAUSSIAN_SCENE_H_
