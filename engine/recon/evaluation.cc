// Reconstruct, render the held-out frames and any extra views, measure.
#include "engine/recon/evaluation.h"

// The generated protobuf header first (see image_io.h).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <nlohmann/json.hpp>
#include <set>

#include "absl/strings/str_cat.h"
#include "common/colour_space.h"
#include "common/elapsed.h"
#include "common/file_util.h"
#include "common/geometry.h"
#include "common/status_macros.h"
#include "engine/recon/depth_completion.h"
#include "engine/recon/eval_baselines.h"
#include "engine/recon/image_metrics.h"
#include "engine/recon/recon_options.h"
#include "engine/recon/scene_graph.h"
#include "engine/render/device_renderer.h"
#include "engine/render/ego_layer.h"
#include "engine/render/hole_fill.h"
#include "engine/render/rasterizer.h"
#include "engine/render/render_blur.h"
#include "pointforward/v1/clip.pb.h"
#include "pointforward/v1/views.pb.h"

namespace pf {
namespace {

nlohmann::json OptionalNumber(const std::optional<double>& value) {
  return value.has_value() && std::isfinite(*value) ? nlohmann::json(*value) : nlohmann::json();
}

// The figures a TARGET frame and an extra view share, in report order.
void AddFigures(const FrameMetrics& f, nlohmann::ordered_json* out) {
  (*out)["psnr"] = f.psnr;
  (*out)["psnrUnclamped"] = f.psnr_unclamped;
  (*out)["ssim"] = f.ssim;
  (*out)["depthRmse"] = OptionalNumber(f.depth_rmse);
  (*out)["lidarAbsRel"] = OptionalNumber(f.lidar_abs_rel);
  (*out)["lidarCoverage"] = OptionalNumber(f.lidar_coverage);
  (*out)["dynamicPsnr"] = OptionalNumber(f.dynamic_psnr);
  (*out)["filledPsnr"] = f.filled_psnr;
  if (f.ego_pixels > 0) (*out)["egoPixels"] = f.ego_pixels;
}

nlohmann::ordered_json MeanJson(const MeanMetrics& mean) {
  return {{"psnr", OptionalNumber(mean.psnr)},
          {"psnrUnclamped", OptionalNumber(mean.psnr_unclamped)},
          {"ssim", OptionalNumber(mean.ssim)},
          {"depthRmse", OptionalNumber(mean.depth_rmse)},
          {"lidarAbsRel", OptionalNumber(mean.lidar_abs_rel)},
          {"lidarCoverage", OptionalNumber(mean.lidar_coverage)},
          {"dynamicPsnr", OptionalNumber(mean.dynamic_psnr)},
          {"holeFraction", OptionalNumber(mean.hole_fraction)},
          {"filledPsnr", OptionalNumber(mean.filled_psnr)}};
}

// Returns the pixels off the ego body: 1 where `ego` is 0; empty (all) when
// `ego` is.
std::vector<uint8_t> ScenePixels(const std::vector<uint8_t>& ego) {
  std::vector<uint8_t> scene(ego.size());
  for (size_t i = 0; i < ego.size(); ++i) scene[i] = ego[i] == 0;
  return scene;
}

// Measures the opaque colour `image` (clamped to [0, 1] here) and its
// `depth` ([H, W, 1] z; empty: none) against `truth_rgb` (and `truth_depth`
// when it has pixels): psnr, psnrUnclamped, ssim, depthRmse (over the pixels
// where the truth has depth; also only where `depth` has, with
// `depth_where_known`), dynamicPsnr over `dynamic_mask` (none: left out).
// Pixels where `ego` (empty: none) is set are the ego vehicle's body: left
// out of every figure (SSIM: the windows centred on them).
FrameMetrics MeasureImage(const ImageF& truth_rgb, const ImageF& truth_depth, ImageF* image,
                          const ImageF& depth, bool depth_where_known,
                          std::vector<uint8_t> dynamic_mask, const std::vector<uint8_t>& ego) {
  FrameMetrics m;
  const std::vector<uint8_t> scene_pixels = ScenePixels(ego);
  for (size_t i = 0; i < ego.size(); ++i) {
    m.ego_pixels += ego[i] != 0;
    if (ego[i] != 0 && !dynamic_mask.empty()) dynamic_mask[i] = 0;
  }
  // The truth is a PNG or JPEG, in [0, 1]. The render is measured as an
  // image, the way its PNG preview and the contact sheet show it: clamped to
  // that range (the colour fit overshoots where discs overlap, and no value
  // above 1 shows brighter). Clamping never moves a pixel away from a truth
  // inside the range. psnrUnclamped keeps the raw render's figure.
  m.psnr_unclamped = Psnr(truth_rgb, *image, scene_pixels).value_or(0.0);
  for (float& v : image->pixels) v = std::clamp(v, 0.f, 1.f);
  m.psnr = Psnr(truth_rgb, *image, scene_pixels).value_or(0.0);
  m.ssim = Ssim(truth_rgb, *image, scene_pixels).value_or(0.0);
  if (truth_depth.width > 0 && depth.width > 0) {
    ImageF truth = truth_depth;
    for (size_t i = 0; i < truth.pixels.size(); ++i) {
      // 0: no truth there.
      if ((!ego.empty() && ego[i] != 0) || (depth_where_known && !(depth.pixels[i] > 0.f))) {
        truth.pixels[i] = 0.f;
      }
    }
    m.depth_rmse = DepthRmse(truth, depth);
  }
  for (uint8_t v : dynamic_mask) m.dynamic_pixels += v != 0;
  if (m.dynamic_pixels > 0) m.dynamic_psnr = Psnr(truth_rgb, *image, dynamic_mask);
  return m;
}

// Measures `buffers` (colours in `encoding`) as MeasureImage does against the
// sRGB-encoded `truth_rgb`, the render encoded as sRGB first (not clamped,
// for psnrUnclamped); depthRmse over every pixel where the truth has depth;
// and the render's holes: filledPsnr, holeFraction.
FrameMetrics Measure(const ImageF& truth_rgb, const ImageF& truth_depth,
                     const RenderBuffers& buffers, ColourEncoding encoding,
                     std::vector<uint8_t> dynamic_mask, const std::vector<uint8_t>& ego,
                     ImageF* render) {
  *render = ImageF(buffers.width, buffers.height, 3);
  render->pixels = buffers.rgb;
  ConvertColours(render->pixels.data(), buffers.alpha.size(), 3, 3, encoding,
                 ColourEncoding::kSrgb);
  ImageF depth(buffers.width, buffers.height, 1);
  depth.pixels = buffers.depth;
  FrameMetrics m =
      MeasureImage(truth_rgb, truth_depth, render, depth, false, std::move(dynamic_mask), ego);
  ImageF filled(buffers.width, buffers.height, 3);
  filled.pixels = FillUncovered(buffers.rgb, buffers.alpha, buffers.width, buffers.height);
  ConvertColours(filled.pixels.data(), buffers.alpha.size(), 3, 3, encoding, ColourEncoding::kSrgb);
  for (float& v : filled.pixels) v = std::clamp(v, 0.f, 1.f);
  const std::vector<uint8_t> scene_pixels = ScenePixels(ego);
  m.filled_psnr = Psnr(truth_rgb, filled, scene_pixels).value_or(0.0);
  int64_t holes = 0;
  const size_t pixels = buffers.alpha.size();
  for (size_t i = 0; i < pixels; ++i) {
    holes += buffers.alpha[i] < kCoveredAlpha && (ego.empty() || ego[i] == 0);
  }
  m.hole_fraction =
      double(holes) / double(std::max<int64_t>(1, static_cast<int64_t>(pixels) - m.ego_pixels));
  return m;
}

// Sets the LiDAR figures of `m` for the z depth `depth` against `lidar`
// (FrameBaselines::target_lidar); unset when `lidar` has no point.
void MeasureLidarDepth(const ImageF& depth, const ImageF& lidar, FrameMetrics* m) {
  if (lidar.width == 0 || depth.width != lidar.width || depth.height != lidar.height) return;
  const DepthErrors errors = MeasureDepthCompletion(depth, lidar);
  const int64_t points = errors.points + errors.missing;
  if (points == 0) return;
  m->lidar_coverage = double(errors.points) / double(points);
  if (errors.points > 0) m->lidar_abs_rel = errors.abs_rel;
}

// Measures the baselines of `target` (`dynamic_mask` as for its render).
void MeasureBaselines(const ContextView& target, const FrameBaselines& b,
                      const std::vector<uint8_t>& dynamic_mask, const pointforward::v1::Clip& clip,
                      FrameMetrics* nearest, FrameMetrics* warp) {
  auto sources = [&](const std::vector<int>& frames) {
    std::vector<FrameMetrics::Source> out;
    for (int f : frames) out.push_back({clip.frames(f).camera(), clip.frames(f).timestamp_us()});
    return out;
  };
  ImageF image = b.nearest_rgb;
  *nearest = MeasureImage(target.rgb, target.depth, &image, b.nearest_depth, true, dynamic_mask,
                          target.ego);
  nearest->filled_psnr = nearest->psnr;
  nearest->sources = sources(b.nearest_frames);
  image = b.warp.rgb;
  *warp =
      MeasureImage(target.rgb, target.depth, &image, b.warp.depth, true, dynamic_mask, target.ego);
  warp->filled_psnr = warp->psnr;
  int64_t holes = 0;
  for (size_t i = 0; i < b.warp.covered.size(); ++i) {
    holes += !b.warp.covered[i] && !target.is_ego(i);
  }
  warp->hole_fraction =
      double(holes) /
      double(std::max<int64_t>(1, static_cast<int64_t>(b.warp.covered.size()) - warp->ego_pixels));
  warp->sources = sources(b.warp_frames);
  MeasureLidarDepth(b.warp.depth, b.target_lidar, warp);
  for (FrameMetrics* m : {nearest, warp}) {
    m->camera = target.camera_id;
    m->timestamp_us = target.timestamp_us;
  }
}

// An extra view with the paths of its truth files, checked to exist (the
// colour) and to have the view's size.
struct ViewWithTruth {
  RenderView view;
  std::string rgb_path;
  std::string depth_path;  // Empty when there is no depth truth.
};

struct CheckedViews {
  std::vector<ViewWithTruth> views;
  std::vector<ActorEdit> edits;
};

// Finds every view's truth files, before anything expensive runs.
absl::StatusOr<CheckedViews> CheckExtraViews(const ExtraViews& extra) {
  const RenderRequest& request = extra.request;
  CheckedViews checked;
  checked.edits = request.edits;
  for (size_t i = 0; i < request.views.size(); ++i) {
    ViewWithTruth v;
    v.view = request.views[i];
    const std::string what = absl::StrCat("views[", i, "] '", v.view.name, "'");
    v.rgb_path = absl::StrCat(extra.truth_dir, "/", v.view.name, ".png");
    absl::StatusOr<ImageInfo> info = ReadImageInfo(v.rgb_path);
    if (absl::IsNotFound(info.status())) {
      return absl::NotFoundError(absl::StrCat(
          what, ": no truth image: ", v.rgb_path,
          " does not exist (pf synth render --clip CLIP_DIR --cameras VIEWS.json --out TRUTH_DIR "
          "writes <name>.png and <name>.exr per view)"));
    }
    if (!info.ok()) return StatusWithContext(info.status(), what);
    const int width = v.view.camera.model.width(), height = v.view.camera.model.height();
    if (info->width != width || info->height != height) {
      return absl::InvalidArgumentError(absl::StrCat(what, ": truth image ", v.rgb_path, " is ",
                                                     info->width, "x", info->height,
                                                     " but the view renders ", width, "x", height));
    }
    const std::string depth_path = absl::StrCat(extra.truth_dir, "/", v.view.name, ".exr");
    absl::StatusOr<ImageInfo> depth_info = ReadImageInfo(depth_path);
    if (depth_info.ok()) {
      if (depth_info->width != width || depth_info->height != height) {
        return absl::InvalidArgumentError(
            absl::StrCat(what, ": truth depth ", depth_path, " is ", depth_info->width, "x",
                         depth_info->height, " but the view renders ", width, "x", height));
      }
      v.depth_path = depth_path;
    } else if (!absl::IsNotFound(depth_info.status())) {
      return StatusWithContext(depth_info.status(), what);
    }
    checked.views.push_back(std::move(v));
  }
  return checked;
}

// Renders and measures the extra views, writing their contact sheets into
// `out_dir`/views/.
absl::Status EvaluateExtraViews(const GaussianScene& scene, const DeviceRenderer& renderer,
                                const CheckedViews& checked,
                                const std::optional<LaneShiftSpec>& lane_shift,
                                const ReconOptions& options, const std::string& out_dir,
                                EvalReport* report) {
  RETURN_IF_ERROR(MakeDirs(absl::StrCat(out_dir, "/views")));
  RenderOptions render_options;
  render_options.features = false;
  render_options.instance = false;
  const std::vector<InstanceTrack> moving = MovingTracks(scene.instances);
  for (size_t i = 0; i < checked.views.size(); ++i) {
    const RenderView& view = checked.views[i].view;
    const std::string what = absl::StrCat("views[", i, "] '", view.name, "'");
    ASSIGN_OR_RETURN(const ImageF truth_rgb, ReadImage(checked.views[i].rgb_path, 3));
    ImageF truth_depth;
    if (!checked.views[i].depth_path.empty()) {
      ASSIGN_OR_RETURN(truth_depth, ReadDepth(checked.views[i].depth_path));
    }
    const auto start = std::chrono::steady_clock::now();
    absl::StatusOr<RenderBuffers> buffers =
        renderer.Render(view.camera, view.timestamp_us, checked.edits, render_options);
    if (!buffers.ok()) return StatusWithContext(buffers.status(), what);
    if (const EgoLayer* ego = FindEgoLayer(scene, view.camera_id)) {
      ApplyEgoLayer(*ego, view.timestamp_us, &*buffers);
    }
    const double render_seconds = SecondsSince(start);
    // With actor edits the tracked boxes are not where the movers are.
    std::vector<uint8_t> mask;
    if (checked.edits.empty()) {
      mask =
          DynamicMask(view.camera.model, view.camera.world_from_camera, moving, view.timestamp_us);
    }
    ImageF render;
    FrameMetrics m = Measure(truth_rgb, truth_depth, *buffers, scene.colour_encoding,
                             std::move(mask), {}, &render);
    m.name = view.name;
    m.camera = view.camera_id;
    m.timestamp_us = view.timestamp_us;
    m.render_seconds = render_seconds;
    m.render_blur = RenderBlurAt(scene, view.camera);
    report->render_seconds += render_seconds;
    if (lane_shift.has_value()) {
      const auto shift = lane_shift->shift_of_view.find(view.name);
      if (shift != lane_shift->shift_of_view.end()) m.shift_m = shift->second;
    }
    m.contact_sheet = absl::StrCat("views/", view.name, ".png");
    RETURN_IF_ERROR(
        WritePng(absl::StrCat(out_dir, "/", m.contact_sheet), ContactSheet(truth_rgb, render)));
    ReportNote(options.progress, std::nullopt,
               absl::StrCat("view ", i + 1, "/", checked.views.size(), " ", view.name, ": PSNR ",
                            m.psnr, " dB, SSIM ", m.ssim));
    report->views.push_back(std::move(m));
  }
  report->views_mean = MeanOf(report->views);
  report->lane_shift = lane_shift;
  report->lane_shift_means = LaneShiftMeans(report->views);
  return absl::OkStatus();
}

// The frames of one camera, by time, for interpolating its pose.
struct TimedPose {
  int64_t timestamp_us;
  Rigid world_from_camera;
};

// Returns `a` moved towards `b` by `s` in [0, 1] (translation linear,
// rotation slerped).
Rigid InterpolatePose(const Rigid& a, const Rigid& b, double s) {
  Rigid r;
  r.rotation = ToMatrix(Slerp(FromMatrix(a.rotation), FromMatrix(b.rotation), s));
  r.translation = a.translation + s * (b.translation - a.translation);
  return r;
}

// Returns the shift as a name part: 1 -> "1", 1.5 -> "1.5", -2 -> "-2".
std::string ShiftName(double shift_m) { return absl::StrCat(shift_m); }

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
  mean.psnr_unclamped =
      average([](const FrameMetrics& f) { return std::optional<double>(f.psnr_unclamped); });
  mean.ssim = average([](const FrameMetrics& f) { return std::optional<double>(f.ssim); });
  mean.depth_rmse = average([](const FrameMetrics& f) { return f.depth_rmse; });
  mean.lidar_abs_rel = average([](const FrameMetrics& f) { return f.lidar_abs_rel; });
  mean.lidar_coverage = average([](const FrameMetrics& f) { return f.lidar_coverage; });
  mean.dynamic_psnr = average([](const FrameMetrics& f) { return f.dynamic_psnr; });
  mean.hole_fraction =
      average([](const FrameMetrics& f) { return std::optional<double>(f.hole_fraction); });
  mean.filled_psnr =
      average([](const FrameMetrics& f) { return std::optional<double>(f.filled_psnr); });
  return mean;
}

std::vector<LaneShiftMetrics> LaneShiftMeans(const std::vector<FrameMetrics>& views) {
  std::map<double, std::vector<FrameMetrics>> by_shift;
  for (const FrameMetrics& view : views) {
    if (view.shift_m.has_value()) by_shift[*view.shift_m].push_back(view);
  }
  std::vector<LaneShiftMetrics> means;
  for (const auto& [shift_m, group] : by_shift) {
    means.push_back({shift_m, static_cast<int>(group.size()), MeanOf(group)});
  }
  return means;
}

absl::StatusOr<LaneShift> MakeLaneShift(const pointforward::v1::Clip& clip,
                                        const std::vector<double>& shifts_m, int64_t time_us) {
  constexpr double kMaxShiftM = 100.0;
  std::vector<double> shifts = {0.0};
  std::set<double> seen;
  for (double shift : shifts_m) {
    if (!std::isfinite(shift) || std::abs(shift) > kMaxShiftM) {
      return absl::InvalidArgumentError(
          absl::StrCat("--lane-shift: ", shift, " is not a shift of at most ", kMaxShiftM, " m"));
    }
    if (!seen.insert(shift).second) {
      return absl::InvalidArgumentError(absl::StrCat("--lane-shift: ", shift, " given twice"));
    }
    if (shift != 0.0) shifts.push_back(shift);
  }

  // Each camera's frames by time (the first of equal timestamps kept).
  std::map<std::string, std::vector<TimedPose>> frames_of;
  for (int i = 0; i < clip.frames_size(); ++i) {
    const pointforward::v1::Frame& frame = clip.frames(i);
    if (frame.world_from_camera_size() != 16) {
      return absl::InvalidArgumentError(absl::StrCat("frames[", i,
                                                     "].worldFromCamera: expected 16 numbers, got ",
                                                     frame.world_from_camera_size()));
    }
    frames_of[frame.camera()].push_back(
        {frame.timestamp_us(), Rigid::FromRowMajor(frame.world_from_camera().data())});
  }
  for (auto& [camera, frames] : frames_of) {
    std::stable_sort(frames.begin(), frames.end(), [](const TimedPose& a, const TimedPose& b) {
      return a.timestamp_us < b.timestamp_us;
    });
    frames.erase(std::unique(frames.begin(), frames.end(),
                             [](const TimedPose& a, const TimedPose& b) {
                               return a.timestamp_us == b.timestamp_us;
                             }),
                 frames.end());
  }

  // Pose at time_us and travel around it, per camera with frames.
  struct CameraAtTime {
    const pointforward::v1::Camera* camera;
    Rigid pose;
  };
  std::vector<CameraAtTime> cameras;
  Vec3 up, travel, viewing;
  for (const pointforward::v1::Camera& camera : clip.cameras()) {
    const auto found = frames_of.find(camera.id());
    if (found == frames_of.end()) continue;
    const std::vector<TimedPose>& frames = found->second;
    if (time_us < frames.front().timestamp_us || time_us > frames.back().timestamp_us) {
      return absl::InvalidArgumentError(absl::StrCat(
          "--lane-shift-time-us: ", time_us, " is outside the frames of camera '", camera.id(),
          "' (", frames.front().timestamp_us, "..", frames.back().timestamp_us, " us)"));
    }
    // after: the first frame at or after time_us; prev / next: the nearest
    // frames strictly before and after it (the frame itself at either end).
    const auto after =
        std::lower_bound(frames.begin(), frames.end(), time_us,
                         [](const TimedPose& f, int64_t t) { return f.timestamp_us < t; });
    Rigid pose = after->world_from_camera;
    if (after->timestamp_us != time_us) {
      const TimedPose& before = *(after - 1);
      const double s =
          double(time_us - before.timestamp_us) / double(after->timestamp_us - before.timestamp_us);
      pose = InterpolatePose(before.world_from_camera, after->world_from_camera, s);
    }
    const auto prev = after == frames.begin() ? after : after - 1;
    auto next = after;
    if (after->timestamp_us == time_us && after + 1 != frames.end()) next = after + 1;
    travel = travel + (next->world_from_camera.translation - prev->world_from_camera.translation);
    up = up - pose.rotation.Col(1);
    viewing = viewing + pose.rotation.Col(2);
    cameras.push_back({&camera, pose});
  }
  if (cameras.empty()) {
    return absl::InvalidArgumentError("--lane-shift: the clip has no camera with frames");
  }

  // Forward: the travel, else the viewing direction; flattened against up.
  up = Normalized(up);
  constexpr double kMinTravelM = 1e-3;
  Vec3 forward = Norm(travel) > kMinTravelM * cameras.size() ? travel : viewing;
  forward = forward - Dot(forward, up) * up;
  const Vec3 left = Cross(up, forward);
  if (Norm(up) < 0.5 || Norm(left) < 1e-6) {
    return absl::InvalidArgumentError(
        "--lane-shift: cannot tell the ego's left (the cameras neither move nor share a "
        "forward direction)");
  }

  LaneShift result;
  result.spec.time_us = time_us;
  result.spec.left = Normalized(left);
  for (const CameraAtTime& c : cameras) *result.views.add_cameras() = *c.camera;
  for (const CameraAtTime& c : cameras) {
    for (double shift : shifts) {
      Rigid pose = c.pose;
      pose.translation = pose.translation + shift * result.spec.left;
      pointforward::v1::View* view = result.views.add_views();
      view->set_camera(c.camera->id());
      view->set_timestamp_us(time_us);
      for (double v : pose.ToRowMajor()) view->add_world_from_camera(v);
      view->set_name(absl::StrCat(c.camera->id(), "_shift", ShiftName(shift), "m"));
      result.spec.shift_of_view[view->name()] = shift;
    }
  }
  return result;
}

std::string EvalReportJson(const EvalReport& report) {
  nlohmann::ordered_json j;
  j["model"] = report.options.model;
  j["gaussians"] = report.gaussians;
  j["reconstructSeconds"] = report.stats.total_seconds;
  j["renderSeconds"] = report.render_seconds;
  j["fusion"] = FusionWeightsName(report.options.fusion.weights);
  j["lifespan"] = report.options.fusion.lifespan;
  j["lidarViews"] = report.stats.lidar_views;
  j["rollingShutterViews"] = report.stats.rolling_shutter_views;
  j["sparseDepthMapViews"] = report.stats.sparse_map_views;
  j["groundFill"] = report.options.completion.ground_fill;
  j["groundPixels"] = report.stats.ground_pixels;
  j["facades"] = report.options.completion.facades;
  j["egoLayer"] = report.options.ego_layer;
  j["egoBody"] = nlohmann::json::object();
  for (const auto& [camera, share] : report.stats.ego_body) j["egoBody"][camera] = share;
  j["facadePixels"] = report.stats.facade_pixels;
  j["stereo"] = report.options.completion.stereo;
  j["stereoPixels"] = report.stats.stereo_pixels;
  j["upwardPixels"] = report.stats.upward_pixels;
  j["enclosedPixels"] = report.stats.enclosed_pixels;
  j["splatSigma"] = report.options.decoder.tangent_sigma;
  j["lowPass"] = report.stats.low_pass;
  j["orderBand"] = report.options.decoder.order_band;
  j["renderBlur"] = report.stats.render_blur;
  j["renderBlurGrowth"] = report.stats.render_blur_growth;
  j["stillInstances"] = report.stats.still_instances;
  j["stillRigViews"] = report.stats.still_rig_views;
  j["stillRigDensity"] = report.options.still_rig_density;
  j["refineIterations"] = report.options.refinement.iterations;
  // What the scene has, not what was asked: --refine 0, or a fit over the
  // memory bound, leaves it flat.
  j["colour"] = report.stats.colour_gradients ? "gradients" : "flat";
  // The fit's memory bound (null: no fit ran).
  if (report.stats.colour_fit_bound_bytes > 0) {
    j["colourFitBoundGB"] = 1e-9 * double(report.stats.colour_fit_bound_bytes);
  } else {
    j["colourFitBoundGB"] = nullptr;
  }
  // 1 pixel in k of each view fitted (1: all; null: no fit).
  if (report.stats.colour_fit_pixel_stride > 0) {
    j["colourFitPixelStride"] = report.stats.colour_fit_pixel_stride;
  } else {
    j["colourFitPixelStride"] = nullptr;
  }
  // Colours are blended and fitted in workingSpace; every figure is measured
  // on the sRGB-encoded [0, 1] images (metricsColour), as the papers do.
  j["workingSpace"] = ColourEncodingName(report.options.colour_encoding);
  j["metricsColour"] = "srgb";
  j["staticGaussians"] = report.stats.static_gaussians;
  j["dynamicGaussians"] = report.stats.dynamic_gaussians;
  j["farGaussians"] = report.stats.far_gaussians;
  j["instances"] = report.stats.instances;
  j["contextViews"] = report.stats.views;
  j["ns"] = report.stats.static_per_view;
  j["nd"] = report.stats.dynamic_per_instance;
  // The per-scene optimisation: its loss and the stepped views' PSNR per
  // step (optimize_loss.png plots the loss).
  if (report.stats.optimize_steps > 0) {
    j["optimize"] = {{"steps", report.stats.optimize_steps},
                     {"lossCurve", "optimize_loss.png"},
                     {"loss", report.stats.optimize_loss},
                     {"contextPsnr", report.stats.optimize_psnr}};
    // --optimize-poses: each context view's correction, its camera turned
    // (a rotation vector in its own axes, degrees) and moved (metres).
    if (!report.stats.optimize_poses.empty()) {
      nlohmann::ordered_json poses = nlohmann::ordered_json::array();
      for (const ReconStats::PoseCorrection& p : report.stats.optimize_poses) {
        poses.push_back({{"frame", p.frame_index},
                         {"camera", p.camera_id},
                         {"rotationDeg",
                          {p.motion[0] * kDegreesPerRadian, p.motion[1] * kDegreesPerRadian,
                           p.motion[2] * kDegreesPerRadian}},
                         {"translationM", {p.motion[3], p.motion[4], p.motion[5]}}});
      }
      j["optimize"]["poseCorrections"] = poses;
    }
    // --optimize-densify: Gaussians split, cloned and pruned.
    if (report.stats.optimize_densify) {
      j["optimize"]["densify"] = {{"split", report.stats.optimize_split},
                                  {"cloned", report.stats.optimize_cloned},
                                  {"pruned", report.stats.optimize_pruned}};
    }
  } else {
    j["optimize"] = nullptr;
  }
  nlohmann::ordered_json stages = nlohmann::ordered_json::object();
  for (const auto& [name, seconds] : report.stats.stage_seconds) stages[name] = seconds;
  j["stageSeconds"] = stages;
  j["mean"] = MeanJson(report.mean);
  const bool baselines =
      report.nearest.size() == report.frames.size() && report.warp.size() == report.frames.size();
  if (baselines) {
    j["baselines"] = {{"nearest", MeanJson(report.nearest_mean)},
                      {"warp", MeanJson(report.warp_mean)}};
    j["baselineSeconds"] = report.baseline_seconds;
  }
  // A baseline's figures and the frames it was made from.
  auto baseline_json = [](const FrameMetrics& b) {
    nlohmann::ordered_json out;
    AddFigures(b, &out);
    out["holeFraction"] = b.hole_fraction;
    nlohmann::ordered_json sources = nlohmann::ordered_json::array();
    for (const FrameMetrics::Source& s : b.sources) {
      sources.push_back({{"camera", s.camera}, {"timestampUs", s.timestamp_us}});
    }
    out["frames"] = sources;
    return out;
  };
  // The rendered LiDAR: means over the sweeps, and each sweep's figures.
  if (report.lidar_render.empty()) {
    j["lidarRender"] = nullptr;
  } else {
    // The figures a sweep and the mean share, after `head`.
    auto with_figures = [](nlohmann::ordered_json head, const LidarSweepFigures& f) {
      head.update(nlohmann::ordered_json{{"points", f.points},
                                         {"hitShare", f.hit_share},
                                         {"rangeErrorMedian", f.range_error_median},
                                         {"rangeErrorP90", f.range_error_p90},
                                         {"earlyShare", f.early_share},
                                         {"lateShare", f.late_share},
                                         {"chamfer", f.chamfer}});
      if (f.intensity_rays > 0) {
        head.update(nlohmann::ordered_json{
            {"intensityRays", f.intensity_rays},
            {"intensityErrorMedian", f.intensity_error_median},
            {"intensityConstantErrorMedian", f.intensity_constant_error_median}});
      }
      if (f.cells > 0) {
        head.update(nlohmann::ordered_json{{"cells", f.cells},
                                           {"recordedDropShare", f.recorded_drop_share},
                                           {"renderedDropShare", f.rendered_drop_share},
                                           {"dropAgreement", f.drop_agreement}});
      }
      if (!f.beams.empty()) {
        nlohmann::ordered_json beams = nlohmann::ordered_json::array();
        for (const LidarBeamFigures& b : f.beams) {
          beams.push_back({{"elevationDeg", b.elevation_deg},
                           {"points", b.points},
                           {"hitShare", b.hit_share},
                           {"rangeErrorMedian", b.range_error_median},
                           {"rangeErrorP90", b.range_error_p90}});
        }
        head["perBeam"] = std::move(beams);
      }
      return head;
    };
    nlohmann::ordered_json sweeps = nlohmann::ordered_json::array();
    for (const LidarSweepFigures& f : report.lidar_render) {
      nlohmann::ordered_json sweep =
          with_figures({{"timestampUs", f.timestamp_us}, {"sweepPoints", f.sweep_points}}, f);
      sweep["renderSeconds"] = f.render_seconds;
      if (!f.beams_note.empty()) sweep["beamsNote"] = f.beams_note;
      sweeps.push_back(std::move(sweep));
    }
    const LidarSweepFigures mean = MeanLidarFigures(report.lidar_render);
    j["lidarRender"] = with_figures({{"sweeps", report.lidar_render.size()}}, mean);
    j["lidarRender"]["seconds"] = report.lidar_render_seconds;
    j["lidarRender"]["renderSeconds"] = mean.render_seconds;
    j["lidarRender"]["perSweep"] = std::move(sweeps);
  }
  nlohmann::ordered_json frames = nlohmann::ordered_json::array();
  for (size_t i = 0; i < report.frames.size(); ++i) {
    const FrameMetrics& f = report.frames[i];
    nlohmann::ordered_json frame;
    frame["camera"] = f.camera;
    frame["timestampUs"] = f.timestamp_us;
    AddFigures(f, &frame);
    frame["dynamicPixels"] = f.dynamic_pixels;
    frame["holeFraction"] = f.hole_fraction;
    frame["renderBlur"] = f.render_blur;
    frame["contactSheet"] = f.contact_sheet;
    if (baselines) {
      frame["baselines"] = {{"nearest", baseline_json(report.nearest[i])},
                            {"warp", baseline_json(report.warp[i])}};
    }
    frames.push_back(std::move(frame));
  }
  j["frames"] = frames;
  if (!report.views.empty()) {
    nlohmann::ordered_json views = nlohmann::ordered_json::array();
    for (const FrameMetrics& v : report.views) {
      nlohmann::ordered_json view;
      view["name"] = v.name;
      view["camera"] = v.camera;
      view["timestampUs"] = v.timestamp_us;
      if (v.shift_m.has_value()) view["shiftM"] = *v.shift_m;
      AddFigures(v, &view);
      view["holeFraction"] = v.hole_fraction;
      view["renderBlur"] = v.render_blur;
      view["contactSheet"] = v.contact_sheet;
      views.push_back(std::move(view));
    }
    j["views"] = views;
    j["viewsMean"] = MeanJson(report.views_mean);
  }
  if (report.lane_shift.has_value() && !report.lane_shift_means.empty()) {
    nlohmann::ordered_json shifts = nlohmann::ordered_json::array();
    for (const LaneShiftMetrics& s : report.lane_shift_means) {
      nlohmann::ordered_json entry = {{"shiftM", s.shift_m}, {"views", s.views}};
      entry.update(MeanJson(s.mean));
      shifts.push_back(std::move(entry));
    }
    j["laneShift"] = shifts;
    const LaneShiftMetrics& first = report.lane_shift_means.front();
    const LaneShiftMetrics* widest = &first;
    for (const LaneShiftMetrics& s : report.lane_shift_means) {
      if (std::abs(s.shift_m) > std::abs(widest->shift_m)) widest = &s;
    }
    auto drop = [](const std::optional<double>& from, const std::optional<double>& to) {
      return from.has_value() && to.has_value() ? std::optional<double>(*from - *to) : std::nullopt;
    };
    j["laneShiftDrop"] = {{"fromM", first.shift_m},
                          {"toM", widest->shift_m},
                          {"psnr", OptionalNumber(drop(first.mean.psnr, widest->mean.psnr))},
                          {"ssim", OptionalNumber(drop(first.mean.ssim, widest->mean.ssim))}};
    j["laneShiftTimeUs"] = report.lane_shift->time_us;
    const Vec3& left = report.lane_shift->left;
    j["laneShiftLeft"] = {left.x, left.y, left.z};
  }
  // Replace invalid UTF-8 (in camera ids) rather than throw.
  return j.dump(2, ' ', false, nlohmann::ordered_json::error_handler_t::replace) + "\n";
}

absl::StatusOr<EvalReport> EvaluateClip(const LoadedClip& loaded, const ReconOptions& options,
                                        const std::string& out_dir,
                                        const std::optional<ExtraViews>& extra) {
  EvalReport report;
  report.options = options;
  LoadViewsOptions view_options;
  view_options.allow_outside_paths = options.allow_outside_paths;
  const auto load_start = std::chrono::steady_clock::now();
  ASSIGN_OR_RETURN(const std::vector<ContextView> targets,
                   LoadViews(loaded, FrameSelection::kTarget, view_options));
  if (targets.empty() && !extra.has_value()) {
    return absl::InvalidArgumentError("frames: the clip has no TARGET frame to evaluate on");
  }
  std::optional<CheckedViews> extra_views;
  if (extra.has_value()) {
    ASSIGN_OR_RETURN(extra_views, CheckExtraViews(*extra));
  }
  RETURN_IF_ERROR(MakeDirs(out_dir));
  ReportNote(options.progress, std::nullopt,
             absl::StrCat("loaded ", targets.size(), " target frames in ", SecondsSince(load_start),
                          " s"));

  ASSIGN_OR_RETURN(ReconResult recon, Reconstruct(loaded, options));
  const GaussianScene& scene = recon.scene;
  report.gaussians = static_cast<int64_t>(scene.size());
  report.stats = recon.stats;

  // Renders run on the GPU that --device names when the CUDA rasterizer can
  // use it (fusion's LibTorch may not), else on the CPU.
  const ComputeDevice render_device = options.device.kind == ComputeDevice::Kind::kCuda &&
                                              CheckCudaDevice(options.device.index).ok()
                                          ? options.device
                                          : ComputeDevice{};
  ASSIGN_OR_RETURN(const std::unique_ptr<DeviceRenderer> renderer,
                   DeviceRenderer::Create(&scene, render_device, "--device"));
  RenderOptions render_options;
  render_options.features = false;
  render_options.instance = false;
  EvalBaselines baselines(loaded, view_options);
  // dynamicPsnr is over the actors that move; still ones are drawn as static.
  const std::vector<InstanceTrack> moving = MovingTracks(scene.instances);
  for (size_t t = 0; t < targets.size(); ++t) {
    const ContextView& target = targets[t];
    const auto start = std::chrono::steady_clock::now();
    ASSIGN_OR_RETURN(
        RenderBuffers buffers,
        renderer->Render(target.render_camera(), target.timestamp_us, {}, render_options));
    if (const EgoLayer* ego = FindEgoLayer(scene, target.camera_id)) {
      ApplyEgoLayer(*ego, target.timestamp_us, &buffers);
    }
    const double render_seconds = SecondsSince(start);
    const auto metrics_start = std::chrono::steady_clock::now();
    const std::vector<uint8_t> mask = DynamicMask(
        target.camera, target.lines().MiddleWorldFromCamera(), moving, target.middle_time_us());
    ImageF render;
    FrameMetrics m = Measure(target.rgb, target.depth, buffers, scene.colour_encoding, mask,
                             target.ego, &render);
    m.render_seconds = render_seconds;
    m.render_blur = RenderBlurAt(scene, target.render_camera());
    report.render_seconds += m.render_seconds;
    m.camera = target.camera_id;
    m.timestamp_us = target.timestamp_us;
    m.contact_sheet = absl::StrCat(target.camera_id, "_", target.timestamp_us, ".png");
    RETURN_IF_ERROR(
        WritePng(absl::StrCat(out_dir, "/", m.contact_sheet), ContactSheet(target.rgb, render)));
    const double metrics_seconds = SecondsSince(metrics_start);
    const auto baseline_start = std::chrono::steady_clock::now();
    ASSIGN_OR_RETURN(const FrameBaselines frame_baselines, baselines.Make(target));
    FrameMetrics nearest, warp;
    MeasureBaselines(target, frame_baselines, mask, loaded.clip, &nearest, &warp);
    ImageF depth(buffers.width, buffers.height, 1);
    depth.pixels = buffers.depth;
    MeasureLidarDepth(depth, frame_baselines.target_lidar, &m);
    const double baseline_seconds = SecondsSince(baseline_start);
    report.baseline_seconds += baseline_seconds;
    ReportNote(options.progress, std::nullopt,
               absl::StrCat("target ", t + 1, "/", targets.size(), " ", m.contact_sheet, ": PSNR ",
                            m.psnr, " dB (nearest ", nearest.psnr, ", warp ", warp.psnr, "), SSIM ",
                            m.ssim, " (render ", m.render_seconds, " s, metrics ", metrics_seconds,
                            " s, baselines ", baseline_seconds, " s)"));
    report.frames.push_back(std::move(m));
    report.nearest.push_back(std::move(nearest));
    report.warp.push_back(std::move(warp));
  }
  report.mean = MeanOf(report.frames);
  report.nearest_mean = MeanOf(report.nearest);
  report.warp_mean = MeanOf(report.warp);

  // The LiDAR rendered at the sweep nearest each TARGET time, unless that
  // sweep is the nearest of a CONTEXT frame (the depth stage's input).
  const auto lidar_start = std::chrono::steady_clock::now();
  ASSIGN_OR_RETURN(const std::vector<LidarSweepData> sweeps,
                   LoadLidarSweeps(loaded, options.allow_outside_paths));
  std::set<int64_t> target_times;
  for (const ContextView& target : targets) target_times.insert(target.timestamp_us);
  std::vector<SeeingCamera> context_cameras;
  std::set<int> context_sweeps, measured_sweeps;
  if (!sweeps.empty()) {
    std::map<std::string, CameraModel> models;
    for (const pointforward::v1::Camera& camera : loaded.clip.cameras()) {
      ASSIGN_OR_RETURN(models[camera.id()], CameraModelFromProto(camera));
    }
    for (const pointforward::v1::Frame& frame : loaded.clip.frames()) {
      if (frame.role() == pointforward::v1::Frame::TARGET) continue;
      // A rolling-shutter frame by its middle line's pose.
      Rigid pose = Rigid::FromRowMajor(frame.world_from_camera().data());
      if (frame.has_rolling_shutter()) {
        pose = InterpolateRigid(
            pose, Rigid::FromRowMajor(frame.rolling_shutter().world_from_camera_end().data()), 0.5);
      }
      context_cameras.push_back({models.at(frame.camera()), pose});
      context_sweeps.insert(NearestSweep(sweeps, frame.timestamp_us()));
    }
  }
  for (int64_t t : target_times) {
    const int j = NearestSweep(sweeps, t);
    if (j < 0 || context_sweeps.count(j) > 0 || !measured_sweeps.insert(j).second) continue;
    absl::StatusOr<LidarSweepFigures> figures =
        EvaluateLidarRender(scene, sweeps[j], context_cameras);
    if (absl::IsFailedPrecondition(figures.status())) continue;  // Nothing the cameras saw.
    if (!figures.ok()) return figures.status();
    report.lidar_render.push_back(*figures);
  }
  report.lidar_render_seconds = SecondsSince(lidar_start);
  if (!report.lidar_render.empty()) {
    ReportNote(options.progress, std::nullopt,
               absl::StrCat("LiDAR rendered at ", report.lidar_render.size(), " TARGET times in ",
                            report.lidar_render_seconds, " s"));
  }
  if (extra_views.has_value()) {
    RETURN_IF_ERROR(EvaluateExtraViews(scene, *renderer, *extra_views, extra->lane_shift, options,
                                       out_dir, &report));
  }
  if (report.stats.optimize_steps > 0) {
    RETURN_IF_ERROR(WritePng(absl::StrCat(out_dir, "/optimize_loss.png"),
                             LineChart(report.stats.optimize_loss, report.stats.views)));
  }
  RETURN_IF_ERROR(WriteFileAtomic(absl::StrCat(out_dir, "/report.json"), EvalReportJson(report)));
  return report;
}

}  // namespace pf
