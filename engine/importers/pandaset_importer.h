// `pf import pandaset`: a PandaSet sequence directory to a clip directory.
//
// What is read (docs/IMPORTERS.md has the conventions and the checks):
// - camera/<name>/NN.jpg (one directory per camera), intrinsics.json
//   {fx, fy, cx, cy} with pixel centres on integers (the manifest's cx, cy
//   are +0.5), poses.json (per frame {position, heading}: camera-to-world,
//   OpenCV axes), timestamps.json (per frame, seconds).
// - lidar/NN.pkl.gz: points in the world frame from both LiDARs (d = 0 the
//   360-degree Pandar64, d = 1 the forward PandarGT); one sweep per frame,
//   at lidar/timestamps.json, written in a sensor frame with the axes of
//   lidar/poses.json and the Pandar64's head as its origin: the poses are
//   not where the head is, so it is found from the Pandar64's own points
//   (spinning_lidar_origin.h; ImportResult::warnings says where, or that
//   the pose was kept).
// - annotations/cuboids/NN.pkl.gz: boxes in the world at the LiDAR's time;
//   every track becomes an instance (id = uuid, category = label); the
//   `stationary` ones (parked cars, signs, cones) keep one pose, and
//   reconstruction keeps such tracks with the static scene
//   (engine/recon/scene_graph.h IsStillTrack). A box seen by both LiDARs is listed twice
//   (cuboids.sensor_id 0 and 1, each naming the other as cuboids.sibling_id): the Pandar64's is
//   kept. Rotation Rz(yaw + 90 degrees), size (dimensions.y, dimensions.x,
//   dimensions.z).
// The pickles are pandas DataFrames: pandaset_pickles.py (beside this file;
// installed beside the `pf` binary) turns them into .npy and JSON with
// /usr/bin/python3 and Debian's python3-pandas.
#ifndef POINTFORWARD_ENGINE_IMPORTERS_PANDASET_IMPORTER_H_
#define POINTFORWARD_ENGINE_IMPORTERS_PANDASET_IMPORTER_H_

#include <limits>
#include <string>

#include "absl/status/statusor.h"
#include "engine/importers/clip_output.h"

namespace pf {

// The file name of the pickle reader, which `pf` looks for beside itself.
inline constexpr char kPandasetPicklesModule[] = "pandaset_pickles.py";

// Frame numbers [begin, end) of a sequence.
struct FrameRange {
  int begin = 0;
  int end = std::numeric_limits<int>::max();
};

struct PandasetOptions {
  FrameRange frames;  // Frames to import; the default takes all.
  // 0 < scale <= 1: images resized by it (area filter) and intrinsics scaled
  // with them (fx' = fx * s, cx' = (cx + 0.5) * s for the integer-centred
  // PandaSet cx). The output size is round(W * s) x round(H * s); s is then
  // the exact ratio of the sizes per axis.
  double scale = 1.0;
  std::string python = "/usr/bin/python3";
  std::string module;  // Path of pandaset_pickles.py.
};

// Parses --frames "A:B" (half-open, [A, B)), "A:" or ":B" with frame numbers
// >= 0; INVALID_ARGUMENT naming --frames otherwise.
absl::StatusOr<FrameRange> ParseFrameRange(const std::string& text);

// Imports the sequence at `sequence_dir` into `options.out_dir` and writes the
// manifest. Errors: NOT_FOUND for a missing directory or file (named);
// INVALID_ARGUMENT for malformed JSON (the field named), an unknown camera in
// options.cameras (listing those the sequence has), no frames in the range,
// a bad scale, images of one camera with different sizes, or a pickle the
// reader cannot read; FAILED_PRECONDITION when python3, pandas or the reader
// module is missing (naming the Debian package to install).
// options.start_us / duration_us are not used (frames are chosen by number).
absl::StatusOr<ImportResult> ImportPandaset(const std::string& sequence_dir,
                                            const ImportOptions& options,
                                            const PandasetOptions& pandaset);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_IMPORTERS_PANDASET_IMPORTER_H_
