// LiDAR intensity for a reconstructed scene: each Gaussian takes the mean
// intensity of the LiDAR returns around it (the sweeps nearest the CONTEXT
// frames, the depth stage's), in its owner's frame, so a rendered sweep
// (lidar_render.h) reads the intensity the sensor recorded there.
//
// The returns are averaged into voxel grids of four cell sizes
// (kIntensityCells: 0.05, 0.2, 0.8 and 3.2 m), per owner: a point inside an
// instance's box at its sweep's time (kMembershipMargin) is moved into the
// instance's canonical frame and counts for that instance alone. A Gaussian
// takes the trilinear blend of the occupied cells among the 8 around its mean
// in the finest grid that has one (weights renormalised over those cells); a
// Gaussian with none within the coarsest grid's reach keeps intensity 0.
// The intensity is in the clip's units; it does not depend on the direction
// or range the sensor sees the surface from.
#ifndef POINTFORWARD_ENGINE_RECON_LIDAR_INTENSITY_H_
#define POINTFORWARD_ENGINE_RECON_LIDAR_INTENSITY_H_

#include <cstdint>
#include <vector>

#include "engine/recon/view_depth.h"
#include "engine/render/gaussian_scene.h"

namespace pf {

inline constexpr double kIntensityCells[] = {0.05, 0.2, 0.8, 3.2};

struct LidarIntensityStats {
  int64_t points = 0;    // Returns used.
  int64_t assigned = 0;  // Gaussians given an intensity.
  int64_t finest = 0;    // Of them, from the finest grid.
};

// Sets channel `channel` of every Gaussian of `scene` (instances in their
// canonical frames, from scene->instances) from the returns of `sweeps`.
// Points without an intensity (a sweep whose `intensities` is empty) are
// left out. Does not set scene->lidar_intensity_channel.
LidarIntensityStats FuseLidarIntensity(const std::vector<const LidarSweepData*>& sweeps,
                                       int channel, GaussianScene* scene);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RECON_LIDAR_INTENSITY_H_
