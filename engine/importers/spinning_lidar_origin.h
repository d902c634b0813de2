// Where a spinning multi-beam LiDAR's head is, found from its own points.
//
// Some datasets give a LiDAR pose that is not the sensor's optical centre
// (PandaSet's lidar/poses.json puts the roof Pandar64 1.9 m low, near the
// road: docs/IMPORTERS.md). The points themselves say where the centre is:
// a spinning head fires its lasers in columns, each laser at a fixed
// elevation, so two points fired one after the other in one column differ in
// elevation by a fixed laser spacing when, and only when, elevations are
// measured from the true centre (seen from elsewhere the difference depends
// on how far away each point is). The centre is the offset that gathers
// those differences tightest.
#ifndef POINTFORWARD_ENGINE_IMPORTERS_SPINNING_LIDAR_ORIGIN_H_
#define POINTFORWARD_ENGINE_IMPORTERS_SPINNING_LIDAR_ORIGIN_H_

#include <cstdint>
#include <vector>

#include "common/geometry.h"

namespace pf {

// One return of a spinning LiDAR: where it is, in a frame whose z axis is
// the spin axis (the dataset's sensor frame), and when it was fired.
struct FiredPoint {
  Vec3 position;
  double time_s = 0;
};

struct LidarOriginEstimate {
  // The head's centre in the points' frame (the frame's origin when not
  // reliable).
  Vec3 centre;
  int64_t pairs = 0;  // Point pairs that measured it.
  // How tightly the pairs' elevation differences gather (the sum of squared
  // shares of a 0.01-degree histogram) at `centre` and at the frame's origin.
  double concentration = 0, concentration_at_origin = 0;
  // At least kMinPairs pairs and a concentration at least twice the
  // origin's: the points did locate the head.
  bool reliable = false;
};

// Pairs needed for a reliable estimate.
inline constexpr int64_t kMinLidarOriginPairs = 200;

// Estimates the head's centre from `sweeps`, each a list of returns in firing
// order (the order the sensor recorded them) in the points' frame. Pairs are
// consecutive returns less than 25 microseconds apart, both over 3 m away
// horizontally, one at least 1.5 times as far as the other, and within 0.5
// degrees of azimuth of each other as seen from some centre in the search
// box: +-1.5 m across the spin axis and -1 to 3 m along it (searched coarse
// to fine, to 1 cm).
LidarOriginEstimate EstimateSpinningLidarOrigin(const std::vector<std::vector<FiredPoint>>& sweeps);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_IMPORTERS_SPINNING_LIDAR_ORIGIN_H_
