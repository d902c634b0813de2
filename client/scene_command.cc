// pf scene info SCENE: prints what a Gaussian scene holds (counts, channels,
// SH degree, instances and their time ranges, bounds).
// pf scene export SCENE --ply OUT.ply [--time-us T]: writes a standard 3DGS
// PLY; instances are placed in the world at T (default: the time origin).
// SCENE is our scene file or a .ply.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_format.h"
#include "client/commands.h"
#include "common/command_line.h"
#include "common/geometry.h"
#include "common/status_macros.h"
#include "engine/render/instance_pose.h"
#include "engine/render/ply_io.h"
#include "engine/render/scene_source.h"

namespace pf {
namespace {

constexpr char kSceneUsage[] =
    "usage: pf scene info SCENE | pf scene export SCENE --ply OUT.ply [--time-us T]";

// Axis-aligned bounds of a set of points.
struct Bounds {
  Vec3 lo{std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity(),
          std::numeric_limits<double>::infinity()};
  Vec3 hi{-lo.x, -lo.y, -lo.z};
  void Add(const Vec3& p) {
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], p[a]);
      hi[a] = std::max(hi[a], p[a]);
    }
  }
  std::string ToString() const {
    if (lo.x > hi.x) return "empty";
    return absl::StrFormat("[%.3f, %.3f, %.3f] .. [%.3f, %.3f, %.3f]", lo.x, lo.y, lo.z, hi.x, hi.y,
                           hi.z);
  }
};

std::string Seconds(int64_t us) { return absl::StrFormat("%.3f s", us * 1e-6); }

int Info(const std::string& path) {
  absl::StatusOr<OpenedScene> opened = OpenScene(path);
  if (!opened.ok()) return ReportError("scene info", opened.status());
  const GaussianScene& scene = opened->scene;

  // Counts per owner; bounds of Gaussian centres in the world at the time
  // origin.
  std::vector<size_t> per_owner(scene.instances.size() + 1, 0);
  std::vector<Rigid> poses(scene.instances.size() + 1);
  for (size_t k = 0; k < scene.instances.size(); ++k) {
    poses[k + 1] = InstancePoseAt(scene.instances[k].boxes, scene.time_origin_us);
  }
  Bounds all, background;
  size_t finite_lifespans = 0;
  for (size_t i = 0; i < scene.size(); ++i) {
    const uint32_t owner = scene.owners[i];
    ++per_owner[owner];
    const Vec3 p =
        poses[owner] * Vec3{scene.means[3 * i], scene.means[3 * i + 1], scene.means[3 * i + 2]};
    all.Add(p);
    if (owner == 0) background.Add(p);
    if (std::isfinite(scene.lifespans[i])) ++finite_lifespans;
  }

  std::printf("scene:        %s\n", path.c_str());
  std::printf("format:       %s\n", opened->format.c_str());
  std::printf("id:           %s\n", opened->scene_id.c_str());
  std::printf("model:        %s\n", opened->model.c_str());
  std::printf("gaussians:    %zu (static %zu, dynamic %zu)\n", scene.size(), per_owner[0],
              scene.size() - per_owner[0]);
  std::printf("channels:     %d\n", scene.num_channels);
  std::printf("sh degree:    %s\n",
              scene.sh_degree < 0 ? "none" : absl::StrCat(scene.sh_degree).c_str());
  std::printf("low-pass:     %g px^2\n", scene.low_pass);
  std::printf("order band:   %g of depth\n", scene.order_band);
  if (scene.render_blur_growth > 0 && !scene.blur_anchors.empty()) {
    std::printf("render blur:  %g px, growing by %g mrad/m away from %zu CONTEXT cameras\n",
                scene.render_blur, scene.render_blur_growth, scene.blur_anchors.size());
  } else {
    std::printf("render blur:  %g px\n", scene.render_blur);
  }
  std::printf("intensity:    %s\n",
              scene.lidar_intensity_channel < 0
                  ? "none"
                  : absl::StrCat("LiDAR, channel ", scene.lidar_intensity_channel).c_str());
  std::printf("colour:       %s\n", scene.has_colour_gradients() ? "gradients" : "flat");
  std::printf("time origin:  %lld us\n", static_cast<long long>(scene.time_origin_us));
  if (scene.fade_span.bounded()) {
    std::printf("fade span:    [%g, %g] s after it (renders outside fade as at its ends)\n",
                scene.fade_span.begin, scene.fade_span.end);
  }
  std::printf("lifespans:    %zu finite, %zu never fade\n", finite_lifespans,
              scene.size() - finite_lifespans);
  std::printf("bounds:       %s (all, world, at the time origin)\n", all.ToString().c_str());
  std::printf("static:       %s\n", background.ToString().c_str());
  std::printf("instances:    %zu\n", scene.instances.size());
  for (size_t k = 0; k < scene.instances.size(); ++k) {
    const InstanceTrack& track = scene.instances[k];
    const int64_t begin = track.boxes.front().timestamp_us;
    const int64_t end = track.boxes.back().timestamp_us;
    std::printf("  %-12s %-12s %8zu gaussians, %3zu boxes, t [%lld, %lld] us (%s)\n",
                track.id.c_str(), track.category.empty() ? "-" : track.category.c_str(),
                per_owner[k + 1], track.boxes.size(), static_cast<long long>(begin),
                static_cast<long long>(end), Seconds(end - begin).c_str());
  }
  std::printf("ego layers:   %zu\n", scene.ego_layers.size());
  for (const EgoLayer& layer : scene.ego_layers) {
    std::printf("  %-12s %dx%d, %.1f %% of the pixels on the body", layer.camera_id.c_str(),
                layer.width, layer.height, 100.0 * layer.body_share());
    if (layer.frames.empty()) {
      std::printf(", one colour at every time\n");
    } else {
      std::printf(", %zu frames in t [%lld, %lld] us\n", layer.frames.size(),
                  static_cast<long long>(layer.frames.front().timestamp_us),
                  static_cast<long long>(layer.frames.back().timestamp_us));
    }
  }
  for (const auto& [key, value] : opened->metadata) {
    std::printf("metadata:     %s = %s\n", key.c_str(), value.c_str());
  }
  return kExitOk;
}

int Export(const CommandLine& cl) {
  if (cl.positional().size() != 2) {
    return ReportError("scene export", absl::InvalidArgumentError(kSceneUsage));
  }
  if (absl::Status required = cl.Require({"ply"}, kSceneUsage); !required.ok()) {
    return ReportError("scene export", required);
  }
  const std::string& path = cl.positional()[1];
  absl::StatusOr<OpenedScene> opened = OpenScene(path);
  if (!opened.ok()) return ReportError("scene export", opened.status());
  PlyExportOptions options;
  if (cl.Has("time-us")) {
    absl::StatusOr<int64_t> t = cl.GetInt("time-us", 0);
    if (!t.ok()) return ReportError("scene export", t.status());
    options.timestamp_us = *t;
  }
  const std::string out = cl.Get("ply");
  const absl::Status status = ExportPly(opened->scene, out, options);
  if (!status.ok()) return ReportError("scene export", status);
  std::printf("wrote %s: %zu gaussians, sh degree %d, instances placed at %lld us\n", out.c_str(),
              opened->scene.size(), std::max(opened->scene.sh_degree, 0),
              static_cast<long long>(options.timestamp_us.value_or(opened->scene.time_origin_us)));
  if (!opened->scene.ego_layers.empty()) {
    std::printf(
        "note: the scene's %zu ego layers (the ego body per camera) have no place in a "
        "PLY and are left out\n",
        opened->scene.ego_layers.size());
  }
  return kExitOk;
}

}  // namespace

int RunScene(const std::vector<std::string>& args) {
  absl::StatusOr<CommandLine> cl = CommandLine::Parse(args, {"ply", "time-us"});
  if (!cl.ok()) return ReportError("scene", cl.status());
  const std::vector<std::string>& words = cl->positional();
  if (words.empty()) return ReportError("scene", absl::InvalidArgumentError(kSceneUsage));
  if (words[0] == "info") {
    if (words.size() != 2 || cl->Has("ply") || cl->Has("time-us")) {
      return ReportError("scene info", absl::InvalidArgumentError(kSceneUsage));
    }
    return Info(words[1]);
  }
  if (words[0] == "export") return Export(*cl);
  return ReportError("scene", absl::InvalidArgumentError(absl::StrCat(
                                  "unknown subcommand '", words[0], "'; ", kSceneUsage)));
}

}  // namespace pf
