// Writes a synthetic clip directory, what `pf synth` produces:
//
//   DIR/clip.json                 pointforward.v1.Clip (proto3 JSON), written last
//   DIR/synth.json                generator parameters (synth_params.h)
//   DIR/images/<cam>_<t>.png      colour, t = timestamp in microseconds
//   DIR/depth/<cam>_<t>.exr       float depth along the camera z axis, 0 = sky
//   DIR/lidar/<t>.bin             float32 little-endian (x, y, z, intensity)
//
// Every frame at a kContextTimestampsUs time is CONTEXT, the rest TARGET.
// Every vehicle has a box at every frame timestamp.
#ifndef POINTFORWARD_ENGINE_SYNTH_SYNTH_CLIP_WRITER_H_
#define POINTFORWARD_ENGINE_SYNTH_SYNTH_CLIP_WRITER_H_

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "engine/synth/synth_ray_caster.h"
#include "engine/synth/synth_scene.h"
#include "pointforward/v1/clip.pb.h"

namespace pf {

// What WriteSynthClip wrote.
struct SynthClipSummary {
  int cameras = 0;
  int frames = 0;  // Images over all cameras.
  int context_frames = 0;
  int target_frames = 0;
  int lidar_sweeps = 0;
  int64_t lidar_points = 0;
  int instances = 0;
};

// Returns the manifest of the clip of `scene`, with the file names
// WriteSynthClip uses (relative to the clip directory).
pointforward::v1::Clip BuildSynthClip(const SynthScene& scene);

// Returns the camera of the manifest for rig camera `camera`.
pointforward::v1::Camera SynthCameraProto(const RigCamera& camera);

// Renders what WriteSynthClip writes for rig camera `camera` at the time of
// `snapshot` (SnapshotAt(scene, timestamp_us * 1e-6)): its colour before the
// PNG's 8-bit quantisation, and its depth map. For clips kept in memory.
RenderedView RenderSynthFrame(const SceneSnapshot& snapshot, int camera);

// Generates the scene of `options` and writes its clip under `out_dir`
// (created if missing; existing files of the same names are replaced).
// Logs progress through spdlog.
absl::StatusOr<SynthClipSummary> WriteSynthClip(const SynthOptions& options,
                                                const std::string& out_dir);

// Returns the file content of a LiDAR sweep: float32 little-endian records.
std::string EncodeLidarPoints(const std::vector<float>& points);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_SYNTH_SYNTH_CLIP_WRITER_H_
