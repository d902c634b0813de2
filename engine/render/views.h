// What to render: a pointforward.v1.RenderViews message (proto/pointforward/
// v1/views.proto, proto3 JSON) turned into cameras, views and actor edits
// the rasterizer takes, checked against the scene.
//
//   ASSIGN_OR_RETURN(RenderRequest request, LoadRenderViews("views.json", scene));
//   for (const RenderView& view : request.views) Render(scene, view.camera, ...);
//
// Errors are INVALID_ARGUMENT naming the field as a path into the message:
// `views[2].camera: unknown camera 'x'`, `views[0].worldFromCamera: not a
// rigid transform`, `edits[1].instance: unknown instance 'car9'`.
#ifndef POINTFORWARD_ENGINE_RENDER_VIEWS_H_
#define POINTFORWARD_ENGINE_RENDER_VIEWS_H_

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "engine/render/gaussian_scene.h"
#include "engine/render/lidar_spec.h"
#include "engine/render/rasterizer.h"
#include "pointforward/v1/views.pb.h"

namespace pf {

// One image to render, with what its output header needs to say.
struct RenderView {
  // Output file stem: the View's name, or "<camera>_<timestamp_us>" with
  // characters other than letters, digits, '_', '-', '.' replaced by '_'.
  std::string name;
  std::string camera_id;  // Camera.id.
  RenderCamera camera;
  int64_t timestamp_us = 0;
  std::string camera_model;  // "pinhole", "opencv", "fisheye" or "ftheta".
  // opencv: k1 k2 p1 p2 k3; fisheye: k1 k2 k3 k4; ftheta: the angle-to-pixel
  // polynomial, theta^0 .. theta^5 (fitted when the camera gave its inverse
  // only); pinhole: empty.
  std::vector<double> distortion;
};

// One LiDAR sweep to render.
struct LidarRenderView {
  std::string name;  // Output file stem: the LidarView's name or "lidar_<timestamp_us>".
  LidarSpec spec;    // Defaults filled in.
  LidarSweepPose pose;
};

struct RenderRequest {
  std::vector<RenderView> views;
  std::vector<ActorEdit> edits;
  std::vector<LidarRenderView> lidars;
};

// The files each view and each LiDAR sweep write, as suffixes of its output
// stem (RenderViewName, RenderLidarName): a view's EXR and PNG preview; a
// sweep's range image and point record.
inline constexpr std::array<const char*, 2> kViewFileSuffixes = {".exr", ".png"};
inline constexpr std::array<const char*, 2> kLidarFileSuffixes = {".range.exr", ".lidar.bin"};

// Returns the output file stem of `view` as ParseRenderViews names it: its
// name, else "<camera>_<timestamp_us>" made fit for a file name.
std::string RenderViewName(const pointforward::v1::View& view);

// The frames of a render job: its views, then its LiDAR sweeps, numbered
// from 0 in that order (how render jobs count and chunk them).
inline int64_t RenderItemCount(const pointforward::v1::RenderViews& views) {
  return int64_t{views.views_size()} + views.lidars_size();
}

// Returns the output file stem of `lidar` as RenderRequestFromProto names it:
// its name, else "lidar_<timestamp_us>".
std::string RenderLidarName(const pointforward::v1::LidarView& lidar);

// The rolling shutter of a view or a clip frame. INVALID_ARGUMENT naming the
// field (`field` + ".readout", ".readoutUs", ".worldFromCameraEnd") for an
// unset readout, a negative readoutUs or an end pose that is not 16 finite
// numbers of a rigid transform.
absl::StatusOr<RollingShutter> RollingShutterFromProto(
    const pointforward::v1::RollingShutter& message, const std::string& field);

// Checks `views` and turns it into what the rasterizer takes: cameras valid
// and with unique ids, each view's camera known and its pose a rigid 4x4
// (16 numbers), view names unique and usable as file names, LiDAR sweeps
// with a valid spec (CheckLidarSpec, zeros taken as the defaults) and rigid
// poses, their names unique among the views' too, edits naming an
// instance once each, with a kind, and (for TRAJECTORY) at least one box with
// a 3-number centre and a non-zero 4-number rotation. Trajectory boxes are
// sorted by time; equal timestamps are an error. An edit must name one of
// `instances` when given (a scene's: InstanceIds); without them any instance
// is accepted (the server, before the scene exists).
absl::StatusOr<RenderRequest> RenderRequestFromProto(
    const pointforward::v1::RenderViews& views,
    const std::optional<std::vector<std::string>>& instances);

// The ids of `scene`'s instances, in order.
std::vector<std::string> InstanceIds(const GaussianScene& scene);

// Parses RenderViews JSON `json` and returns RenderRequestFromProto of it
// against `scene`'s instances. Malformed JSON (or unknown fields) is
// INVALID_ARGUMENT with protobuf's message.
absl::StatusOr<RenderRequest> ParseRenderViews(const std::string& json, const GaussianScene& scene);

// Reads the file at `path` and returns ParseRenderViews of its content; errors
// start with the path.
absl::StatusOr<RenderRequest> LoadRenderViews(const std::string& path, const GaussianScene& scene);

}  // namespace pf

#endif  // POINTFORWARD_ENGINE_RENDER_VIEWS_H_
