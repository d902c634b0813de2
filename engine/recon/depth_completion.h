// Classical (non-learned) completion of a sparse depth map: IP-Basic (Ku,
// Harakeh, Waslander 2018, "In Defense of Classical Image Processing: Fast
// Depth Completion on the CPU"), and the error of a dense map at held-out
// points. `pf eval`'s warp baseline (eval_baselines.h) completes LiDAR and
// sparse depth maps with it; it uses nothing of the reconstruction.
//
//   ImageF dense = CompleteDepthIpBasic(ProjectPoints(points, camera, pose));
//
// The steps, on a working grid of `scale` x `scale` pixel cells (each cell
// the nearest measured depth inside it; scale 1 is the image itself), with
// the paper's kernel sizes in cells:
//   1. invert: d -> d_max - d on measured cells, so that a maximum filter
//      prefers the nearer surface (d_max: the deepest measurement + 1 m);
//   2. dilate with a 5x5 diamond;
//   3. close small holes: 5x5 full kernel (dilate, then erode);
//   4. fill empty cells from a 7x7 full dilation;
//   5. (extrapolate) extend each column's top value up to the top row, then
//      fill empty cells from a 31x31 full dilation;
//   6. 5x5 median of the non-empty cells;
//   7. 5x5 bilateral filter (spatial sigma 2 cells, range sigma 1.5 m);
//   8. invert back; the grid is upsampled to the image bilinearly between
//      cells within 5 % of each other's depth, from the pixel's own cell
//      across larger jumps, so depth edges stay sharp to a cell.
// The paper tuned its kernels on KITTI, where the LiDAR marks about 5 % of
// the pixels; IpBasicScale picks the cell size at which a sparser map has
// that density on the grid, so the kernels keep their meaning on large
// images with sparse LiDAR.
#ifndef POINTFORWARD_ENGINE_RECON_DEPTH_COMPLETION_H_
#define POINTFORWARD_ENGINE_RECON_DEPTH_COMPLETION_H_

#include <cstdint>

#include "engine/image/image_io.h"

namespace pf {

struct IpBasicOptions {
  // Side of the working grid's cells in pixels; <= 0: IpBasicScale(sparse).
  int scale = 0;
  // Step 5: extend the top values upward and fill large holes. Without it
  // pixels above the highest measurement, and holes wider than the small
  // kernels bridge, stay unknown.
  bool extrapolate = true;
};

// Returns the working-grid cell size for `sparse` ([H, W, 1], 0 unknown):
// round(sqrt(0.05 / density)) clamped to [1, 16], the density being the
// share of measured pixels among the rows from the highest measured row to
// the lowest. 1 for a map with no measurement.
int IpBasicScale(const ImageF& sparse);

// Returns the dense completion of `sparse` ([H, W, 1] z depth, 0 or
// non-finite unknown) as described above: [H, W, 1], 0 where it stays
// unknown (everywhere for a map with no measurement).
ImageF CompleteDepthIpBasic(const ImageF& sparse, const IpBasicOptions& options = {});

// Returns true when `depth` ([H, W, 1], 0 unknown) is sparse, such as LiDAR
// projected into an image: fewer than half of its known pixels have all four
// neighbours known. A rendered or stereo depth map, whose unknown pixels are
// whole regions (the sky), is not. False for a map with no known pixel.
bool IsSparseDepth(const ImageF& depth);

// The error of a dense depth map at held-out measurements.
struct DepthErrors {
  int64_t points = 0;      // Held-out pixels where the dense map has depth.
  int64_t missing = 0;     // Held-out pixels where it has none.
  double abs_rel = 0;      // Mean |dense - truth| / truth.
  double rmse = 0;         // Metres.
  double within_5pct = 0;  // Share of points with |dense - truth| < 5 % of truth.
};

// Returns the errors of `dense` at the pixels where `held_out` (same size,
// [H, W, 1], 0 none) has a depth; zeros when there is none.
DepthErrors MeasureDepthCompletion(const ImageF& dense, const ImageF& held_out);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RECON_DEPTH_COMPLETION_H_
