// pf render SCENE --cameras VIEWS.json --out DIR
//           [--outputs rgb,alpha,depth,features,instance,filled] [--device cpu|cuda:N]
// Renders every view of VIEWS.json (pointforward.v1.RenderViews) of SCENE
// (our scene file or a 3DGS .ply) into DIR: <view>.exr, <view>.png, for each
// LiDAR sweep <lidar>.range.exr and <lidar>.lidar.bin, and a manifest.json. Progress per view goes
// to stderr, a summary to stdout.
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "absl/strings/str_cat.h"
#include "client/commands.h"
#include "common/command_line.h"
#include "common/compute_device.h"
#include "common/file_util.h"
#include "common/status_macros.h"
#include "engine/render/device_renderer.h"
#include "engine/render/render_outputs.h"
#include "engine/render/scene_source.h"
#include "engine/render/views.h"

namespace pf {
namespace {

constexpr char kRenderUsage[] =
    "usage: pf render SCENE --cameras VIEWS.json --out DIR "
    "[--outputs rgb,alpha,depth,features,instance,filled] [--device cpu|cuda:N]";

absl::Status RenderCommand(const CommandLine& cl) {
  if (cl.positional().size() != 1) return absl::InvalidArgumentError(kRenderUsage);
  RETURN_IF_ERROR(cl.Require({"cameras", "out"}, kRenderUsage));
  absl::StatusOr<OutputChannels> parsed = ParseOutputChannels(cl.GetList("outputs"));
  if (!parsed.ok()) {
    return absl::InvalidArgumentError(absl::StrCat("--outputs: ", parsed.status().message()));
  }
  const OutputChannels channels = *parsed;
  ASSIGN_OR_RETURN(const ComputeDevice device,
                   ParseComputeDevice(cl.Get("device", "cpu"), "--device"));
  const auto start = std::chrono::steady_clock::now();
  ASSIGN_OR_RETURN(OpenedScene opened, OpenScene(cl.positional()[0]));
  ASSIGN_OR_RETURN(const RenderRequest request, LoadRenderViews(cl.Get("cameras"), opened.scene));
  const std::string out_dir = cl.Get("out");
  RETURN_IF_ERROR(MakeDirs(out_dir));
  ASSIGN_OR_RETURN(const std::unique_ptr<DeviceRenderer> renderer,
                   DeviceRenderer::Create(&opened.scene, device, "--device"));
  std::fprintf(
      stderr, "pf render: %zu gaussians (%s), %zu views, %zu edits, on %s\n", opened.scene.size(),
      opened.format.c_str(), request.views.size(), request.edits.size(),
      device.kind == ComputeDevice::Kind::kCpu
          ? "the CPU"
          : absl::StrCat(device.ToString(), ", ", CudaDeviceDescription(device.index)).c_str());

  const SceneLabel label{opened.scene_id, opened.model, opened.scene.colour_encoding};
  std::vector<ManifestEntry> entries;
  double render_ms_total = 0;
  for (size_t i = 0; i < request.views.size(); ++i) {
    const RenderView& view = request.views[i];
    absl::StatusOr<ManifestEntry> entry =
        RenderViewToFiles(*renderer, view, request.edits, channels, label, out_dir);
    if (!entry.ok()) return StatusWithContext(entry.status(), absl::StrCat("views[", i, "]"));
    render_ms_total += entry->render_ms;
    std::fprintf(stderr, "[%zu/%zu] %s: %dx%d at %lld us, %.1f ms -> %s\n", i + 1,
                 request.views.size(), view.name.c_str(), entry->width, entry->height,
                 static_cast<long long>(view.timestamp_us), entry->render_ms, entry->exr.c_str());
    entries.push_back(*std::move(entry));
  }
  std::vector<LidarManifestEntry> lidars;
  for (size_t i = 0; i < request.lidars.size(); ++i) {
    const LidarRenderView& lidar = request.lidars[i];
    absl::StatusOr<LidarManifestEntry> entry =
        RenderLidarToFiles(opened.scene, lidar, request.edits, out_dir);
    if (!entry.ok()) return StatusWithContext(entry.status(), absl::StrCat("lidars[", i, "]"));
    std::fprintf(
        stderr,
        "[lidar %zu/%zu] %s: %d beams x %d columns at %lld us, %lld returns, %.1f ms -> %s\n",
        i + 1, request.lidars.size(), lidar.name.c_str(), entry->beams, entry->columns,
        static_cast<long long>(entry->timestamp_us), static_cast<long long>(entry->returns),
        entry->render_ms, entry->range_exr.c_str());
    render_ms_total += entry->render_ms;
    lidars.push_back(*std::move(entry));
  }
  RETURN_IF_ERROR(WriteManifest(absl::StrCat(out_dir, "/manifest.json"), label, entries, lidars));
  const double total_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  std::printf(
      "rendered %zu views and %zu LiDAR sweeps of %s to %s (manifest.json): render %.1f ms, "
      "total %.1f ms\n",
      entries.size(), lidars.size(), cl.positional()[0].c_str(), out_dir.c_str(), render_ms_total,
      total_ms);
  return absl::OkStatus();
}

}  // namespace

int RunRender(const std::vector<std::string>& args) {
  absl::StatusOr<CommandLine> cl =
      CommandLine::Parse(args, {"cameras", "out", "outputs", "device"});
  if (!cl.ok()) return ReportError("render", cl.status());
  const absl::Status status = RenderCommand(*cl);
  return status.ok() ? kExitOk : ReportError("render", status);
}

}  // namespace pf
