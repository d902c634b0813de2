// Sparse sampling (paper section 3.1): N_s static queries per view and N_d
// per instance, spread to cover the scene without redundancy.
//
// Static: each view's image is cut into a grid of cells of side
// s = sqrt(W H / N_s) pixels (at least 1) and one pixel per cell is taken:
// one of the pixels whose centre lies in the cell, picked by a hash of its
// position (stratified, so every part of the image is covered, no regular
// pattern aliases and no two cells take the same pixel); far-layer pixels take one cell
// in far_stride x far_stride. A point that another view sees (depth
// consistent within 3 %) with a footprint smaller by more than
// `finer_view_ratio` is left to that view, so every surface is sampled by
// the view that sees it in most detail, if that view's time is within
// `finer_view_seconds` of the point's own view's (a scene whose discs fade
// with time would draw the finer view's discs faded there). A point whose
// voxel (side: its footprint rounded up to a power of two) was already
// filled by an earlier view is skipped, so surfaces seen by several views
// are not sampled again. Dynamic pixels are left to the instances. Those
// two rules remove redundant queries, not budget: the paper's query count
// is N = V N_s + O N_d, so when they leave fewer than V N_s static queries,
// all views are sampled again on grids refined by sqrt(kept / (V N_s))
// (fill_static_budget), which spends the freed budget on detail instead of
// dropping it, on cells at most sqrt(max_refill) = sqrt(2) finer (about
// twice what was kept).
//
// A visible query on the near side of an occluding edge gets a smaller
// footprint (edge_footprint_scale), so its disc does not spread over the
// background behind the silhouette.
//
// Dynamic: every pixel of every view that lies in instance k's box, moved to
// the canonical frame, thinned by a uniform voxel grid whose side is found by
// bisection so that at most N_d points remain (one per voxel).
//
// Hidden queries: where the camera moves, the strip of background that a
// foreground edge hid from every context view comes into view, and with
// nothing there the render has a hole (a third of the TARGET-frame error on
// the synth clip). So a sampled pixel near the near side of a depth edge
// also gets a query where the background's surface (its plane) continues
// behind it, or on the far layer when the background is the sky, coloured
// like the surfaces the views saw nearest it along its plane, the road's
// direction counting less (hidden_colour_from_surfaces), else like the
// background nearest it in the image (a blend of the first background pixel
// in each of 8 directions); it is marked `hidden`, taken
// on a coarser grid (it copies one colour: no detail to sample), and dropped
// when another view sees the point (that view samples it) or sees past it
// (the point would float in free space). A surface seen at a grazing angle
// gets no hidden query; nor do sky directions below the horizontal, or
// points below the scene's floor (the 1st percentile of measured heights
// less 0.5 m, "up" from the surfaces that face up). The ego vehicle's body
// (ContextView::ego) hides the road under it in every view of its camera,
// and a camera that moves on sees that road past the body's edge: a body
// pixel within the band below ground seen above the body's edge in its
// column (facing up) gets a hidden query where the level plane through that
// ground point meets its ray, dropped when another view's depth there is
// within 10 % of the point's (the plane lies a few centimetres off the road
// that view measured).
//
// Dense mode (the pixel-aligned model): every valid pixel is a query (and
// one pixel of the band in behind_stride^2 gets its hidden query).
#ifndef POINTFORWARD_ENGINE_RECON_SPARSE_SAMPLING_H_
#define POINTFORWARD_ENGINE_RECON_SPARSE_SAMPLING_H_

#include <cstdint>
#include <limits>
#include <optional>
#include <vector>

#include "engine/recon/context_views.h"
#include "engine/recon/query_lifting.h"
#include "engine/recon/query_set.h"
#include "engine/recon/view_depth.h"
#include "engine/render/gaussian_scene.h"

namespace pf {

// The paper's budgets, for 768 x 576 images.
inline constexpr int64_t kDefaultStaticPerView = 100000;
inline constexpr int64_t kDefaultDynamicPerInstance = 10000;

struct SamplingOptions {
  int64_t static_per_view = kDefaultStaticPerView;            // N_s
  int64_t dynamic_per_instance = kDefaultDynamicPerInstance;  // N_d
  int far_stride = 3;             // Far-layer cells taken: one in far_stride^2.
  bool skip_covered = true;       // Skip static points whose voxel an earlier view filled.
  double finer_view_ratio = 1.2;  // Leave points to views this much finer; <= 0: off.
  // ... but only to views within this many seconds of the point's view.
  double finer_view_seconds = std::numeric_limits<double>::infinity();
  // Keep the paper's count of static queries, V x N_s, up to about
  // max_refill times what the two rules above kept: when they leave fewer
  // than 95 % of it, every view's cell side is multiplied by
  // max(sqrt(kept / (V x N_s)), 1 / sqrt(max_refill)) and the views are
  // sampled again, once. (Many views of one street leave little each; their
  // full V x N_s crowds every view with discs.)
  bool fill_static_budget = true;
  double max_refill = 2.0;
  bool dense = false;  // Every valid pixel, no thinning (pixel-aligned).
  // Hidden queries (FindBehindSources, view_depth.h): a sampled pixel within
  // this many pixels of a deeper background also gets a query on its ray
  // where the nearest such background's surface continues behind it, with
  // the background's colour, unless another view sees that point or past
  // it, or it would lie below the scene's floor (sparse_sampling.cc); an
  // ego-body pixel within this many pixels below the ground above the
  // body's edge, one on the road under the body. < 1: none.
  int behind_band_px = 256;
  double behind_min_jump = 0.1;  // Relative depth jump that makes an occlusion edge.
  // A visible query whose source pixel is on the near side of an occluding
  // edge (a surface more than behind_min_jump deeper in its 3x3
  // neighbourhood; not the far layer) gets its footprint, so its disc,
  // scaled by this: the disc stops near the silhouette instead of spreading
  // about a pixel onto the background behind it, where the image's edge is
  // one antialiased pixel. Against the sky the discs keep their size, or
  // the far layer would show through a roof line in the depth render. 1: off.
  double edge_footprint_scale = 0.35;
  // Hidden queries take one cell in behind_stride^2 (behind far-layer
  // backgrounds: in k^2, k the smallest multiple of behind_stride >=
  // far_stride), with footprints as much larger.
  int behind_stride = 2;
  // A hidden query not on the far layer takes the colour of the surfaces
  // that the views saw nearest it in 3D, on its own plane, rather than the
  // background next to it in its one view (SeenSurfaces,
  // sparse_sampling.cc): the strip a van hides from every view goes on with
  // the shop front seen in front of and behind the van by other views. Off,
  // or where no seen surface lies within reach: the background next to it
  // in the image (BackgroundColour).
  bool hidden_colour_from_surfaces = true;
  // Street scenes run along the road: kerbs, pavements, shop windows, signs
  // and storeys. Distances along the direction in which the context cameras
  // travel count this much in that search, in [0.01, 1] (1: isotropic;
  // cameras that travel less than 1 m: isotropic).
  double hidden_road_scale = 0.1;
};

// Returns the budget `at_768x576` scaled by the pixel count relative to
// 768 x 576 (at least 1).
int64_t ScaledBudget(int64_t at_768x576, int width, int height);

// N_s's scaling: as ScaledBudget up to 768 x 576, by the square root of the
// pixel count's ratio above it (with the image's side). The depth the
// queries are lifted with (LiDAR, its completion) does not get finer with
// the image, and finer discs on it draw new views worse: at 1936x1216,
// 0.43 x ScaledBudget.
int64_t ScaledStaticBudget(int64_t at_768x576, int width, int height);

// One view's inputs to sampling.
struct SamplingView {
  const ContextView* view = nullptr;
  const ViewDepth* depth = nullptr;
  const LiftedView* lifted = nullptr;
  const std::vector<uint32_t>* owners = nullptr;  // [H, W] box membership at the view's time
  // The view's N_s is SamplingOptions::static_per_view times this (its grid
  // cells 1 / sqrt(this) as wide); the budget the refill keeps is the sum.
  double static_density = 1.0;
};

// Per view of `views`, whether its camera stands still: the camera has two
// or more views and each lies within kStillCentre and kStillAngle
// (scene_graph.h) of its first. A rig stopped at a light sees the same
// pixels at every time, so the skip of covered voxels leaves one view's
// worth of queries per camera, and the renders wanted of it are at those
// poses, where more discs per pixel draw more of the image (ReconOptions::
// still_rig_density).
std::vector<bool> StillCameraViews(const std::vector<ContextView>& views);

// Returns the queries of `views` as described above. `tracks` give the
// canonical frames of the owners.
QuerySet SampleQueries(const std::vector<SamplingView>& views,
                       const std::vector<InstanceTrack>& tracks, const SamplingOptions& options);

// Returns the owner of every lifted pixel of a view: box membership of its
// point at `timestamp_us` with kMembershipMargin (scene_graph.h); far-layer
// and invalid pixels are 0. With the view's `rolling_shutter`, at the time of
// the pixel's line (LineTime).
std::vector<uint32_t> PixelOwners(const LiftedView& lifted, const ViewDepth& depth,
                                  const std::vector<InstanceTrack>& tracks, int64_t timestamp_us,
                                  const std::optional<RollingShutter>& rolling_shutter = {});

// The boxes of a rolling-shutter view are taken at this many evenly spaced
// times of its readout; a pixel's line takes the nearest (LineTime).
inline constexpr int kLineTimeSamples = 9;

// Which of the kLineTimeSamples times stands for pixel `pixel` of a width x
// height view read by `rolling_shutter` (0 without one), and that time.
int LineTimeSample(const std::optional<RollingShutter>& rolling_shutter, int width, int height,
                   size_t pixel);
int64_t LineTime(int64_t timestamp_us, const std::optional<RollingShutter>& rolling_shutter,
                 int sample);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RECON_SPARSE_SAMPLING_H_
