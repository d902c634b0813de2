// What a render job writes: one EXR per view, a PNG preview beside it and a
// manifest.json of everything written (docs/SCENE_FORMAT.md, "Render
// outputs", has the long form).
//
// EXR (scanline, ZIP compression), channels in this order, each only when
// selected by OutputChannels:
//   R, G, B   half   colour premultiplied by alpha, scene-linear light
//                    (Rec. 709 primaries, D65): a scene whose colours are
//                    sRGB-encoded has each pixel's colour decoded,
//                    alpha * EOTF(rgb / alpha) (rgb)
//   A         half   alpha (alpha)
//   Z         float  expected depth along the camera z axis in metres,
//                    normalised by alpha; 0 where nothing was hit (depth)
//   feature.000 .. feature.NNN
//             half   the scene's N_c feature channels, premultiplied by alpha,
//                    as the scene holds them (for a reconstructed scene the
//                    first three are its colour in its own encoding) (features)
//   instance  uint   owner of the largest contributor: 0 background or empty,
//                    k the scene's k-th instance (instance)
//   filled.R, filled.G, filled.B
//             half   opaque colour, linear as R, G, B: rgb where alpha >= 0.5, elsewhere rgb
//                    composited over a push-pull fill of itself, so pixels
//                    the scene does not cover take the colour around them
//                    instead of black (hole_fill.h; filled; only when asked
//                    for by name)
// (OpenEXR stores channels sorted by name; readers find them by name.)
// Header attributes:
//   worldToCamera      m44f, the OpenEXR standard attribute: world to a camera
//                      frame with x right, y up, z forward, in Imath's
//                      row-vector convention (p_cam = p_world * M)
//   pf:worldFromCamera m44d, our pose: row-major column-vector convention,
//                      OpenCV camera axes (x right, y down, z forward)
//   pf:fx, pf:fy, pf:cx, pf:cy  double, intrinsics in pixels (pixel centres
//                      at +0.5)
//   pf:cameraModel     string "pinhole" | "opencv" | "fisheye" | "ftheta"
//   pf:distortion      float[] the model's coefficients (opencv: k1 k2 p1 p2
//                      k3; fisheye: k1 k2 k3 k4; ftheta: pixels at theta^0
//                      .. theta^5, fx = fy = the theta^1 term); absent for
//                      pinhole
//   pf:camera, pf:view string, camera id and view name
//   timestamp_us       double, the render time (exact for |t| < 2^53)
//   pf:timestampUs     string, the same as decimal digits
//   pf:sceneId, pf:model, pf:version  strings
//   software           "PointForward <version>"
//   chromaticities     the OpenEXR standard attribute: Rec. 709 / sRGB
//                      primaries and D65 white, with oiio:ColorSpace "Linear"
// The PNG preview is what a display shows: the premultiplied colour (the
// un-premultiplied colour composited over black) clamped to [0, 1],
// sRGB-encoded, 8-bit RGB (DisplayRgb).
#ifndef POINTFORWARD_ENGINE_RENDER_RENDER_OUTPUTS_H_
#define POINTFORWARD_ENGINE_RENDER_RENDER_OUTPUTS_H_

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "common/colour_space.h"
#include "engine/image/image_io.h"
#include "engine/render/device_renderer.h"
#include "engine/render/rasterizer.h"
#include "engine/render/views.h"

namespace pf {

// Which layers an EXR carries (`--outputs rgb,alpha,depth,features,instance,filled`).
struct OutputChannels {
  bool rgb = true;
  bool alpha = true;
  bool depth = true;
  bool features = true;
  bool instance = true;
  bool filled = false;
};

// Parses layer names ("rgb", "alpha", "depth", "features", "instance",
// "filled"); an empty list selects the first five (filled is only written
// when named). INVALID_ARGUMENT naming an unknown layer (the caller adds
// the field or flag it came from).
absl::StatusOr<OutputChannels> ParseOutputChannels(const std::vector<std::string>& names);

// Limits on one view's render (pf-server --max-pixels-per-image,
// --max-render-bytes); 0 means none.
struct RenderLimits {
  int64_t max_pixels_per_view = 0;
  int64_t max_bytes_per_view = 0;
};

// Returns about how many bytes rendering one `width` x `height` view takes:
// the render's buffers for `channels` (`num_features` feature channels), the
// fill's when asked for, and the preview. Does not overflow for any int32
// width and height.
int64_t EstimateRenderBytes(int64_t width, int64_t height, const OutputChannels& channels,
                            int num_features);

// Checks every camera and LiDAR sweep of `views` against `limits` before
// anything is allocated: INVALID_ARGUMENT naming "<prefix>cameras[i]" or
// "<prefix>lidars[i]" and the pf-server flag of the limit, e.g.
// "views.cameras[0]: 12000x12000 = 144000000 pixels per view exceed the
// limit of 50000000 (--max-pixels-per-image)". A sweep's rays count as a
// view's pixels.
absl::Status CheckRenderLimits(const pointforward::v1::RenderViews& views,
                               const OutputChannels& channels, int num_features,
                               const RenderLimits& limits, const std::string& prefix = "");

// Returns the EXR channel names for `channels` and `num_features` channels,
// in the order listed above.
std::vector<std::string> ExrChannelNames(const OutputChannels& channels, int num_features);

// Facts about the scene written into every header.
struct SceneLabel {
  std::string scene_id;  // E.g. the scene file's checksum.
  std::string model;     // E.g. "analytic", "3dgs-ply".
  // What the scene's colours, so the render's rgb, encode (GaussianScene::colour_encoding).
  ColourEncoding colour_encoding = ColourEncoding::kSrgb;
};

// Writes the EXR of `buffers` rendered through `view` to `path` atomically.
// INVALID_ARGUMENT if `buffers` lacks a selected layer or no layer is
// selected; INTERNAL with OpenImageIO's message if writing fails.
absl::Status WriteRenderExr(const std::string& path, const RenderBuffers& buffers,
                            const OutputChannels& channels, const RenderView& view,
                            const SceneLabel& scene);

// Returns the premultiplied colour of `buffers` (rgb, in `encoding`) as
// scene-linear light, as the EXR holds it: [H, W, 3].
std::vector<float> LinearRgb(const RenderBuffers& buffers, ColourEncoding encoding);

// Returns what a display shows of `buffers` (rgb, in `encoding`): the
// premultiplied colour clamped to [0, 1], sRGB-encoded. The PNG preview,
// and what `pf eval` measures against the camera images.
ImageF DisplayRgb(const RenderBuffers& buffers, ColourEncoding encoding);

// Writes DisplayRgb(buffers, encoding) to `path` as an 8-bit PNG, atomically.
absl::Status WritePreviewPng(const std::string& path, const RenderBuffers& buffers,
                             ColourEncoding encoding);

// One rendered view in the manifest; file names are relative to its directory.
struct ManifestEntry {
  std::string exr;
  std::string png;
  const RenderView* view = nullptr;  // Not owned; must outlive WriteManifest().
  std::vector<std::string> channels;
  int width = 0;
  int height = 0;
  double render_ms = 0;
};

// One rendered LiDAR sweep in the manifest.
struct LidarManifestEntry {
  std::string name;
  std::string range_exr;  // <name>.range.exr (WriteRangeImageExr).
  std::string points;     // <name>.lidar.bin (WriteSweepPoints).
  int64_t timestamp_us = 0;
  int beams = 0, columns = 0;
  int64_t returns = 0;
  std::vector<double> world_from_sensor;  // 16 numbers at the sweep's start.
  double render_ms = 0;
};

// Returns the manifest JSON: {"scene": {...}, "views": [{"name", "exr", "png",
// "camera", "cameraModel", "timestampUs", "worldFromCamera", "intrinsics",
// "width", "height", "channels", "renderMs"}]}, and with `lidars` a
// "lidars" array of {"name", "rangeExr", "points", "timestampUs", "beams",
// "columns", "returns", "worldFromSensor", "renderMs"}.
std::string ManifestJson(const SceneLabel& scene, const std::vector<ManifestEntry>& entries,
                         const std::vector<LidarManifestEntry>& lidars = {});

// The manifest's "views" and "lidars" arrays alone, as JSON text (a render
// chunk's part of the job's manifest).
std::string ManifestViewsJson(const std::vector<ManifestEntry>& entries);
std::string ManifestLidarsJson(const std::vector<LidarManifestEntry>& lidars);

// Renders `view` of the renderer's scene with `edits` and the layers of
// `channels`, and writes <view.name>.exr and <view.name>.png into `out_dir`:
// the step `pf render` and a worker's render chunk take for every view. A
// view of a camera with an ego layer in the scene shows the body on top
// (ApplyEgoLayer). Returns the view's manifest entry (with its render time); errors are the
// render's or the writes'.
absl::StatusOr<ManifestEntry> RenderViewToFiles(
    const DeviceRenderer& renderer, const RenderView& view, const std::vector<ActorEdit>& edits,
    const OutputChannels& channels, const SceneLabel& label, const std::string& out_dir);

// Renders the sweep `lidar` of `scene` with `edits` and writes
// <lidar.name>.range.exr and <lidar.name>.lidar.bin into `out_dir`; returns
// its manifest entry.
absl::StatusOr<LidarManifestEntry> RenderLidarToFiles(const GaussianScene& scene,
                                                      const LidarRenderView& lidar,
                                                      const std::vector<ActorEdit>& edits,
                                                      const std::string& out_dir);

// Writes ManifestJson(...) to `path` atomically.
absl::Status WriteManifest(const std::string& path, const SceneLabel& scene,
                           const std::vector<ManifestEntry>& entries,
                           const std::vector<LidarManifestEntry>& lidars = {});

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RENDER_RENDER_OUTPUTS_H_
