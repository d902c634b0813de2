// Gaussian decoding (DESIGN.md section 3, step 6), analytic: each fused
// query becomes one 3D Gaussian of the scene.
//
// - Mean: the query's position (world, or the instance's canonical frame).
// - Features (kReconChannels = 8): [0..2] fused RGB (a hidden query's own
//   colour: fusion sees the foreground in front of it), [3..5] the unit surface
//   normal (same frame as the mean), [6] multi-view agreement in (0, 1], 0
//   for a hidden query (no view observes it; colour_refinement.h keeps its
//   colour), [7] LiDAR intensity (0 here; lidar_intensity.h fills it where
//   the clip has LiDAR).
//   The renderer's RGB is the first three channels (identity decoder).
// - Rotation and scale: a flat disc on the local surface. Its axes are t1
//   (the source ray projected on the tangent plane), t2 = n x t1 and the
//   normal n. Across the ray the spacing of neighbouring queries is the
//   footprint f (depth / focal x sampling stride); along t1 the surface is
//   seen at a slant, so the spacing there is f / |cos theta| (theta between
//   ray and normal, the stretch capped at max_stretch). Standard deviations
//   are tangent_sigma times those spacings, and normal_sigma x f across.
// - Opacity: min_opacity + (max_opacity - min_opacity) x agreement (a
//   hidden query takes max_opacity: it stands for an opaque surface). A
//   query that at least contradicted_views views see past (fusion's
//   contradictions, observations x (1 / agreement - 1)) is a floater of its
//   view's depth more likely than a surface: contradicted_min_opacity +
//   (max_opacity - contradicted_min_opacity) x agreement^3, so one seen
//   through by many views all but vanishes (on a clip of many views of one
//   street its floaters, left at half opacity, hid the surfaces of the other
//   views: docs/QUALITY.md, "Where pandaset_half loses: floaters").
// - Time: the source view's time (seconds since time_origin_us); lifespan
//   from fusion.
// - The scene's screen-space low-pass (GaussianScene::low_pass) is
//   options.low_pass, else DefaultLowPass(): 0.1 px^2 where every CONTEXT
//   view has a dense depth map (about the one-pixel box the camera images
//   integrate over; the 3DGS default 0.3 blurs every render by more than
//   that), 0.2 px^2 where depth comes from LiDAR, sparse maps or nothing
//   (docs/QUALITY.md, "What each default is worth").
// - The scene's order band (GaussianScene::order_band) is options.order_band,
//   0.0005: discs within 0.05 % of each other's depth (1 cm at 20 m: the
//   overlapping discs of several views on one surface) stack in one fixed
//   order in every view, so a new view, or the same one a millimetre away,
//   sees them as the colour fit did (docs/QUALITY.md, "Order band").
#ifndef POINTFORWARD_ENGINE_RECON_GAUSSIAN_DECODER_H_
#define POINTFORWARD_ENGINE_RECON_GAUSSIAN_DECODER_H_

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "engine/recon/context_views.h"
#include "engine/recon/fusion.h"
#include "engine/recon/query_set.h"
#include "engine/render/gaussian_scene.h"

namespace pf {

// Feature channels of reconstructed scenes.
inline constexpr int kReconChannels = 8;
// The channel of multi-view agreement; 0 marks a hidden Gaussian.
inline constexpr int kAgreementChannel = 6;
// The channel of LiDAR intensity (GaussianScene::lidar_intensity_channel).
inline constexpr int kIntensityChannel = 7;

struct DecoderOptions {
  double tangent_sigma = 0.65;  // Std-dev along the surface per query spacing.
  double normal_sigma = 0.1;    // Std-dev across the surface per footprint.
  double max_stretch = 4.0;     // Cap of 1 / |cos theta|.
  double min_opacity = 0.5;
  double max_opacity = 0.98;
  int contradicted_views = 3;  // Views seeing past a query that make it a floater; 0: off.
  double contradicted_min_opacity = 0.01;
  // The scene's screen-space low-pass, pixels^2; unset: DefaultLowPass().
  std::optional<float> low_pass;
  float order_band = 0.0005f;  // The scene's order band (GaussianScene::order_band).
  // Static Gaussians off the far layer fade with time away from their source
  // view's (the paper's lifespan, FadeStaticGaussians): over about this many
  // CONTEXT frames of a camera. 0: no fade.
  double fade_frames = 5;
};

// The screen-space low-pass of a reconstructed scene (pixels^2) when none is
// given: kExactDepthLowPass where every CONTEXT view's depth was a dense
// depth map, else kMeasuredDepthLowPass: renders from measured depth are
// closer to the frames a little blurred (docs/QUALITY.md).
inline constexpr float kExactDepthLowPass = 0.1f;
inline constexpr float kMeasuredDepthLowPass = 0.2f;
inline float DefaultLowPass(bool all_views_dense_depth) {
  return all_views_dense_depth ? kExactDepthLowPass : kMeasuredDepthLowPass;
}

// Returns the scene of `queries` fused as `fused` (its low-pass
// options.low_pass, kExactDepthLowPass if unset). `view_times_us[v]` is the
// time of view v; `time_origin_us` becomes the scene's time origin; `tracks`
// become its instances (instance k owns queries with owner k + 1).
GaussianScene DecodeGaussians(const QuerySet& queries, const FusedQueries& fused,
                              const std::vector<int64_t>& view_times_us, int64_t time_origin_us,
                              const std::vector<InstanceTrack>& tracks,
                              const DecoderOptions& options = {});

// The lifespan FadeStaticGaussians gives static Gaussians (below):
// max(0, fade_frames x g - 1) seconds, g the mean spacing of consecutive
// CONTEXT times of a camera (`view_cameras[v]`, `view_times_us[v]` per
// view; over every camera with two or more). nullopt where nothing fades:
// fade_frames 0, or no camera with two CONTEXT times.
std::optional<double> FadeSigma(const std::vector<std::string>& view_cameras,
                                const std::vector<int64_t>& view_times_us, double fade_frames);

// The paper's lifespan for static Gaussians, without a learned model: a
// static Gaussian off the far layer (owners[i] 0, far[i] 0) is drawn at
// o exp(-((t - t_i) / (sigma + 1))^2 / 2) at time t (splat_projection.h),
// t_i its source view's time, sigma = max(0, fade_frames x g - 1) seconds, g
// the mean spacing of consecutive CONTEXT times of a camera (over every
// camera with two or more), so a view's discs fade over the frames around
// it: where many views cover a street, the discs of views far off in time
// (their depth's floaters among them) give way to those of nearer views.
// Lifespans already shorter are kept. The scene's fade span becomes the
// CONTEXT times (`view_cameras[v]`, `view_times_us[v]` per view), so a
// render before or after them fades as at the first or last. Nothing
// changes where fade_frames is 0 or no camera has two CONTEXT times.
void FadeStaticGaussians(const std::vector<std::string>& view_cameras,
                         const std::vector<int64_t>& view_times_us,
                         const std::vector<uint32_t>& owners, const std::vector<uint8_t>& far,
                         double fade_frames, GaussianScene* scene);

// Returns the rotation (as a quaternion) whose columns are the disc axes
// (t1, t2, n) for a surface of normal `normal` seen along `ray`, and the
// slant stretch 1 / |cos theta| (capped at `max_stretch`).
Quat DiscFrame(const Vec3& normal, const Vec3& ray, double max_stretch, double* stretch);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RECON_GAUSSIAN_DECODER_H_
