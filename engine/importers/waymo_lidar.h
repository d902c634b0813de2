// Waymo LiDAR range images to points, as the Waymo Open Dataset tools do it:
// row i of a laser's range image has inclination beam_inclinations reversed
// (row 0 is the highest beam; uniform between beam_inclination_min and _max
// when the list is empty), column j has azimuth
//   ((W - j - 0.5) / W * 2 - 1) * pi - atan2(extrinsic[1][0], extrinsic[0][0]),
// a return at range r is r * (cos incl cos az, cos incl sin az, sin incl) in
// the laser frame, and the extrinsic takes it to the vehicle frame. Where the
// range image carries per-pixel vehicle poses (the TOP laser), each point is
// moved through its pixel's pose into the frame pose's vehicle frame, which
// removes the smear of the car's motion during the sweep.
#ifndef POINTFORWARD_ENGINE_IMPORTERS_WAYMO_LIDAR_H_
#define POINTFORWARD_ENGINE_IMPORTERS_WAYMO_LIDAR_H_

#include <vector>

#include "absl/status/statusor.h"
#include "common/geometry.h"
#include "waymo/frame.pb.h"

namespace pf {

// True if any laser of `frame` carries a first-return range image.
bool HasWaymoRangeImages(const pointforward::waymo::Frame& frame);

// Returns the first returns of every laser of `frame` as float32 (x, y, z,
// intensity) records in the vehicle frame at the frame pose (`[N, 4]`, row
// major); pixels with range <= 0 are no return. INVALID_ARGUMENT naming the
// laser for a missing calibration or a range image of the wrong shape;
// DATA_LOSS when a compressed image does not inflate or parse.
absl::StatusOr<std::vector<float>> WaymoRangeImagesToPoints(const pointforward::waymo::Frame& frame,
                                                            const Rigid& world_from_vehicle);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_IMPORTERS_WAYMO_LIDAR_H_
