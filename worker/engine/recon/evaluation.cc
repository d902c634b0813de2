// Reconstruct, render the held-out frames, measure.
#include "worker/engine/recon/evaluation.h"

// The generated protobuf header first (see image_io.h).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <nlohmann/json.hpp>

#include "absl/strings/str_cat.h"
#include "common/file_util.h"
#include "common/status_macros.h"
#include "pointforward/v1/clip.pb.h"
#include "worker/engine/recon/image_metrics.h"
#include "worker/engine/recon/recon_flags.h"
#include "worker/engine/recon/scene_graph.h"
#include "worker/engine/render/rasterizer.h"

namespace pf {
namespace {

double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

nlohmann::json OptionalNumber(const std::optional<double>& value) {
  return value.has_value() && std::isfinite(*value) ? nlohmann::json(*value) : nlohmann::json();
}

}  // namespace

MeanMetrics MeanOf(const std::vector<FrameMetrics>& frames) {
  MeanMetrics mean;
  auto average = [&](auto get) -> std::optional<double> {
    double sum = 0;
    int count = 0;
    for (const FrameMetrics& f : frames) {
      const std::optional<double> v = get(f);
      if (!v.has_value()) continue;
      sum += *v;
      ++count;
    }
    if (count == 0) return std::nullopt;
    return sum / count;
  };
  mean.psnr = average([](const FrameMetrics& f) { return std::optional<double>(f.psnr); });
  mean.ssim = average([](const FrameMetrics& f) { return std::optional<double>(f.ssim); });
  mean.depth_rmse = average([](const FrameMetrics& f) { return f.depth_rmse; });
  mean.dynamic_psnr = average([](const FrameMetrics& f) { return f.dynamic_psnr; });
  return mean;
}

std::string EvalReportJson(const EvalReport& report) {
  nlohmann::ordered_json j;
  j["model"] = ReconModelName(report.options.model);
  j["gaussians"] = report.gaussians;
  j["reconstructSeconds"] = report.stats.total_seconds;
  j["renderSeconds"] = report.render_seconds;
  j["fusion"] = FusionWeightsName(report.options.fusion.weights);
  j["lifespan"] = report.options.fusion.lifespan;
  j["staticGaussians"] = report.stats.static_gaussians;
  j["dynamicGaussians"] = report.stats.dynamic_gaussians;
  j["farGaussians"] = report.stats.far_gaussians;
  j["instances"] = report.stats.instances;
  j["contextViews"] = report.stats.views;
  j["ns"] = report.stats.static_per_view;
  j["nd"] = report.stats.dynamic_per_instance;
  nlohmann::ordered_json stages = nlohmann::ordered_json::object();
  for (const auto& [name, seconds] : report.stats.stage_seconds) stages[name] = seconds;
  j["stageSeconds"] = stages;
  j["mean"] = {{"psnr", OptionalNumber(report.mean.psnr)},
               {"ssim", OptionalNumber(report.mean.ssim)},
               {"depthRmse", OptionalNumber(report.mean.depth_rmse)},
               {"dynamicPsnr", OptionalNumber(report.mean.dynamic_psnr)}};
  nlohmann::ordered_json frames = nlohmann::ordered_json::array();
  for (const FrameMetrics& f : report.frames) {
    nlohmann::ordered_json frame;
    frame["camera"] = f.camera;
    frame["timestampUs"] = f.timestamp_us;
    frame["psnr"] = f.psnr;
    frame["ssim"] = f.ssim;
    frame["depthRmse"] = OptionalNumber(f.depth_rmse);
    frame["dynamicPsnr"] = OptionalNumber(f.dynamic_psnr);
    frame["dynamicPixels"] = f.dynamic_pixels;
    frame["holeFraction"] = f.hole_fraction;
    frame["contactSheet"] = f.contact_sheet;
    frames.push_back(std::move(frame));
  }
  j["frames"] = frames;
  // Replace invalid UTF-8 (in camera ids) rather than throw.
  return j.dump(2, ' ', false, nlohmann::ordered_json::error_handler_t::replace) + "\n";
}

absl::StatusOr<EvalReport> EvaluateClip(const LoadedClip& loaded, const ReconOptions& options,
                                        const std::string& out_dir) {
  EvalReport report;
  report.options = options;
  LoadViewsOptions view_options;
  view_options.allow_outside_paths = options.allow_outside_paths;
  const auto load_start = std::chrono::steady_clock::now();
  ASSIGN_OR_RETURN(const std::vector<ContextView> targets,
                   LoadViews(loaded, FrameSelection::kTarget, view_options));
  if (targets.empty()) {
    return absl::InvalidArgumentError("frames: the clip has no TARGET frame to evaluate on");
  }
  RETURN_IF_ERROR(MakeDirs(out_dir));
  if (options.progress) {
    options.progress(absl::StrCat("loaded ", targets.size(), " target frames in ",
                                  SecondsSince(load_start), " s"));
  }

  ASSIGN_OR_RETURN(ReconResult recon, Reconstruct(loaded, options));
  const GaussianScene& scene = recon.scene;
  report.gaussians = static_cast<int64_t>(scene.size());
  report.stats = recon.stats;

  RenderOptions render_options;
  render_options.features = false;
  render_options.instance = false;
  for (size_t t = 0; t < targets.size(); ++t) {
    const ContextView& target = targets[t];
    const auto start = std::chrono::steady_clock::now();
    ASSIGN_OR_RETURN(RenderBuffers buffers, Render(scene, {target.camera, target.world_from_camera},
                                                   target.timestamp_us, {}, render_options));
    FrameMetrics m;
    m.render_seconds = SecondsSince(start);
    const auto metrics_start = std::chrono::steady_clock::now();
    report.render_seconds += m.render_seconds;
    m.camera = target.camera_id;
    m.timestamp_us = target.timestamp_us;
    ImageF render(buffers.width, buffers.height, 3);
    render.pixels = buffers.rgb;
    m.psnr = Psnr(target.rgb, render).value_or(0.0);
    m.ssim = Ssim(target.rgb, render).value_or(0.0);
    if (target.depth.width > 0) {
      ImageF depth(buffers.width, buffers.height, 1);
      depth.pixels = buffers.depth;
      m.depth_rmse = DepthRmse(target.depth, depth);
    }
    const std::vector<uint8_t> mask =
        DynamicMask(target.camera, target.world_from_camera, scene.instances, target.timestamp_us);
    for (uint8_t v : mask) m.dynamic_pixels += v != 0;
    m.dynamic_psnr = Psnr(target.rgb, render, mask);
    int64_t holes = 0;
    for (float a : buffers.alpha) holes += a < 0.5f;
    m.hole_fraction = double(holes) / double(std::max<size_t>(1, buffers.alpha.size()));
    if (m.dynamic_pixels == 0) m.dynamic_psnr.reset();
    m.contact_sheet = absl::StrCat(target.camera_id, "_", target.timestamp_us, ".png");
    RETURN_IF_ERROR(
        WritePng(absl::StrCat(out_dir, "/", m.contact_sheet), ContactSheet(target.rgb, render)));
    if (options.progress) {
      options.progress(absl::StrCat("target ", t + 1, "/", targets.size(), " ", m.contact_sheet,
                                    ": PSNR ", m.psnr, " dB, SSIM ", m.ssim, " (render ",
                                    m.render_seconds, " s, metrics ", SecondsSince(metrics_start),
                                    " s)"));
    }
    report.frames.push_back(std::move(m));
  }
  report.mean = MeanOf(report.frames);
  RETURN_IF_ERROR(WriteFileAtomic(absl::StrCat(out_dir, "/report.json"), EvalReportJson(report)));
  return report;
}

}  // namespace pf
