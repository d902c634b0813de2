// Writes a synthetic clip directory (see synth_clip_writer.h).
#include "engine/synth/synth_clip_writer.h"

#include <google/protobuf/util/json_util.h>

#include <chrono>
#include <cstring>

#include "absl/strings/str_cat.h"
#include "common/elapsed.h"
#include "common/file_util.h"
#include "common/status_macros.h"
#include "engine/image/image_io.h"
#include "engine/synth/synth_lidar.h"
#include "engine/synth/synth_params.h"
#include "spdlog/spdlog.h"

namespace pf {
namespace {

namespace v1 = pointforward::v1;

std::string ImagePath(const std::string& camera, int64_t timestamp_us) {
  return absl::StrCat("images/", camera, "_", timestamp_us, ".png");
}
std::string DepthPath(const std::string& camera, int64_t timestamp_us) {
  return absl::StrCat("depth/", camera, "_", timestamp_us, ".exr");
}
std::string LidarPath(int64_t timestamp_us) { return absl::StrCat("lidar/", timestamp_us, ".bin"); }

void SetPose(const Rigid& pose, google::protobuf::RepeatedField<double>* out) {
  for (double v : pose.ToRowMajor()) out->Add(v);
}

double Seconds(int64_t timestamp_us) { return timestamp_us * 1e-6; }

}  // namespace

v1::Camera SynthCameraProto(const RigCamera& camera) {
  v1::Camera proto;
  proto.set_id(camera.id);
  proto.set_width(camera.model.width());
  proto.set_height(camera.model.height());
  v1::Intrinsics* k = proto.mutable_intrinsics();
  k->set_fx(camera.model.fx());
  k->set_fy(camera.model.fy());
  k->set_cx(camera.model.cx());
  k->set_cy(camera.model.cy());
  if (camera.model.kind() == CameraModel::Kind::kFTheta) {
    v1::Distortion* distortion = proto.mutable_distortion();
    distortion->set_model(v1::Distortion::FTHETA);
    for (double c : camera.model.ftheta_pixels()) distortion->add_ftheta_poly(c);
  }
  return proto;
}

v1::Clip BuildSynthClip(const SynthScene& scene) {
  v1::Clip clip;
  clip.set_name(absl::StrCat("synth_seed_", scene.options.seed));
  for (const RigCamera& camera : scene.cameras) *clip.add_cameras() = SynthCameraProto(camera);
  const std::vector<int64_t> timestamps = scene.FrameTimestampsUs();
  for (int64_t t : timestamps) {
    for (size_t c = 0; c < scene.cameras.size(); ++c) {
      v1::Frame* frame = clip.add_frames();
      frame->set_camera(scene.cameras[c].id);
      frame->set_timestamp_us(t);
      frame->set_image(ImagePath(scene.cameras[c].id, t));
      SetPose(scene.WorldFromCamera(static_cast<int>(c), Seconds(t)),
              frame->mutable_world_from_camera());
      frame->set_depth(DepthPath(scene.cameras[c].id, t));
      frame->set_role(IsContextTimestamp(t) ? v1::Frame::CONTEXT : v1::Frame::TARGET);
    }
    v1::LidarSweep* sweep = clip.add_lidar();
    sweep->set_timestamp_us(t);
    sweep->set_points(LidarPath(t));
    SetPose(scene.WorldFromLidar(Seconds(t)), sweep->mutable_world_from_sensor());
  }
  for (const Vehicle& vehicle : scene.vehicles) {
    v1::Instance* instance = clip.add_instances();
    instance->set_id(vehicle.id);
    instance->set_category(vehicle.category);
    for (int64_t t : timestamps) {
      const Rigid pose = vehicle.BoxToWorldAt(Seconds(t));
      const Quat q = FromMatrix(pose.rotation);
      v1::Box* box = instance->add_boxes();
      box->set_timestamp_us(t);
      for (int i = 0; i < 3; ++i) box->add_center(pose.translation[i]);
      for (int i = 0; i < 3; ++i) box->add_size(vehicle.size[i]);
      for (double v : {q.w, q.x, q.y, q.z}) box->add_rotation(v);
    }
  }
  return clip;
}

std::string EncodeLidarPoints(const std::vector<float>& points) {
  std::string bytes(points.size() * 4, '\0');
  for (size_t i = 0; i < points.size(); ++i) {
    uint32_t bits;
    std::memcpy(&bits, &points[i], 4);
    for (int b = 0; b < 4; ++b) bytes[i * 4 + b] = static_cast<char>((bits >> (8 * b)) & 0xFF);
  }
  return bytes;
}

RenderedView RenderSynthFrame(const SceneSnapshot& snapshot, int camera) {
  const SynthScene& scene = *snapshot.scene;
  return RenderView(snapshot, scene.cameras[camera].model,
                    scene.WorldFromCamera(camera, snapshot.time_s), scene.options.antialias);
}

absl::StatusOr<SynthClipSummary> WriteSynthClip(const SynthOptions& options,
                                                const std::string& out_dir) {
  const auto start = std::chrono::steady_clock::now();
  ASSIGN_OR_RETURN(SynthScene scene, GenerateSynthScene(options));
  for (const char* sub : {"images", "depth", "lidar"}) {
    RETURN_IF_ERROR(MakeDirs(absl::StrCat(out_dir, "/", sub)));
  }
  SynthClipSummary summary;
  summary.cameras = static_cast<int>(scene.cameras.size());
  summary.instances = static_cast<int>(scene.vehicles.size());
  const std::vector<int64_t> timestamps = scene.FrameTimestampsUs();
  spdlog::info("synth: seed {}, {} cameras x {} frames of {}x{}, {} vehicles, {} static boxes",
               options.seed, scene.cameras.size(), timestamps.size(), options.width, options.height,
               scene.vehicles.size(), scene.boxes.size());
  for (size_t f = 0; f < timestamps.size(); ++f) {
    const int64_t t = timestamps[f];
    const SceneSnapshot snapshot = SnapshotAt(scene, Seconds(t));
    for (size_t c = 0; c < scene.cameras.size(); ++c) {
      const RigCamera& camera = scene.cameras[c];
      const RenderedView view = RenderSynthFrame(snapshot, static_cast<int>(c));
      RETURN_IF_ERROR(WritePng(absl::StrCat(out_dir, "/", ImagePath(camera.id, t)), view.rgb));
      RETURN_IF_ERROR(
          WriteDepthExr(absl::StrCat(out_dir, "/", DepthPath(camera.id, t)), view.depth));
      ++summary.frames;
      ++(IsContextTimestamp(t) ? summary.context_frames : summary.target_frames);
    }
    const LidarPoints sweep = SimulateLidar(snapshot, scene.WorldFromLidar(Seconds(t)));
    RETURN_IF_ERROR(
        WriteFileAtomic(absl::StrCat(out_dir, "/", LidarPath(t)), EncodeLidarPoints(sweep.points)));
    ++summary.lidar_sweeps;
    summary.lidar_points += static_cast<int64_t>(sweep.size());
    const double elapsed = SecondsSince(start);
    spdlog::info("synth: frame {}/{} (t = {:.1f} s) done, {:.1f} s elapsed", f + 1,
                 timestamps.size(), Seconds(t), elapsed);
  }

  RETURN_IF_ERROR(
      WriteFileAtomic(absl::StrCat(out_dir, "/synth.json"), SynthParamsToJson(options)));
  google::protobuf::util::JsonPrintOptions print;
  print.add_whitespace = true;
  print.preserve_proto_field_names = false;
  print.always_print_primitive_fields = true;
  std::string json;
  const auto printed =
      google::protobuf::util::MessageToJsonString(BuildSynthClip(scene), &json, print);
  if (!printed.ok()) {
    return absl::InternalError(absl::StrCat("clip.json: ", printed.ToString()));
  }
  RETURN_IF_ERROR(WriteFileAtomic(absl::StrCat(out_dir, "/clip.json"), json));
  return summary;
}

}  // namespace pf
